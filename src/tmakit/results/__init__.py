"""Results: what an estimator or a bound returns (estimates, bounds, observability)."""

from .answers import Answer, Ellipse, track_answer
from .bound import Bound, bound_from_information
from .checks import SanityWarning, measurement_warnings, normalised_residuals, scale_sigma
from .estimate import EstimateResult, assemble_result
from .nuisance import KnownNuisance
from .observability import Direction, Observability
from .solutions import Solution
from .status import CONVERGED, DIVERGED, NOT_CONVERGED, STATUSES, UNOBSERVABLE, Status
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
    "Observability",
    "SanityWarning",
    "Solution",
    "Status",
    "Trust",
    "assemble_result",
    "bound_from_information",
    "bound_trust",
    "measurement_warnings",
    "normalised_residuals",
    "scale_sigma",
    "track_answer",
    "trust_of",
]
