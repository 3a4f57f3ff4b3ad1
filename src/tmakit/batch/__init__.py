"""Batch estimators: maximum likelihood with nuisance parameters eliminated (no initial guess
needed) and the papers' own methods (ratio method, direct iterative LS, the lecture's
Gauss-Newton), all returning :class:`EstimateResult`."""

from ..results.estimate import EstimateResult
from .init import GridSettings, best_starts, grid_candidates
from .methods import METHODS, estimate_with
from .ml import estimate
from .solver import VarProProblem, levenberg_marquardt

__all__ = ["METHODS", "EstimateResult", "GridSettings", "VarProProblem", "best_starts",
           "estimate", "estimate_with", "grid_candidates", "levenberg_marquardt"]
