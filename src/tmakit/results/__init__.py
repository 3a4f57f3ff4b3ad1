"""Results: what an estimator or a bound returns (estimates, bounds, observability).

They are in one place below every estimator so that each can build and read them.
"""

from .bound import Bound, bound_from_information
from .estimate import (
    CONVERGED,
    DIVERGED,
    NOT_CONVERGED,
    UNOBSERVABLE,
    EstimateResult,
    assemble_result,
    diverged_result,
    fit_status,
    result_from_covariance,
)
from .nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from .observability import Direction, Observability, analyse

__all__ = ["CONVERGED", "DIVERGED", "NOT_CONVERGED", "UNOBSERVABLE", "Bound", "Direction",
           "EstimateResult", "KnownNuisance", "KnownNuisanceLike", "Observability", "analyse",
           "as_known_nuisance", "assemble_result", "bound_from_information", "diverged_result",
           "fit_status", "result_from_covariance"]
