"""Results: what an estimator or a bound returns (estimates, bounds, observability)."""

from .answers import Answer, Ellipse, answer_from_state, estimate_answer, track_answer
from .bound import Bound, bound_from_information
from .checks import (
    SanityWarning,
    chi2_warning,
    fit_warnings,
    measurement_warnings,
    normalised_residuals,
    scale_sigma,
)
from .estimate import EstimateResult, assemble_result, diverged_result, result_from_covariance
from .nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from .observability import Direction, Observability, analyse
from .solutions import Solution, separated_solutions
from .status import (
    CONVERGED,
    DIVERGED,
    NOT_CONVERGED,
    STATUSES,
    UNOBSERVABLE,
    Status,
    fit_status,
)
from .trust import TRUST_NONE, TRUST_OK, TRUST_WARNING, Trust, bound_trust, trust_of

__all__ = [
    "CONVERGED",
    "DIVERGED",
    "NOT_CONVERGED",
    "STATUSES",
    "TRUST_NONE",
    "TRUST_OK",
    "TRUST_WARNING",
    "UNOBSERVABLE",
    "Answer",
    "Bound",
    "Direction",
    "Ellipse",
    "EstimateResult",
    "KnownNuisance",
    "KnownNuisanceLike",
    "Observability",
    "SanityWarning",
    "Solution",
    "Status",
    "Trust",
    "analyse",
    "answer_from_state",
    "as_known_nuisance",
    "assemble_result",
    "bound_from_information",
    "bound_trust",
    "chi2_warning",
    "diverged_result",
    "estimate_answer",
    "fit_status",
    "fit_warnings",
    "measurement_warnings",
    "normalised_residuals",
    "result_from_covariance",
    "scale_sigma",
    "separated_solutions",
    "track_answer",
    "trust_of",
]
