"""Batch estimators: maximum likelihood with nuisance parameters eliminated, no initial
guess needed."""

from .init import GridSettings, best_starts, grid_candidates
from .ml import EstimateResult, estimate
from .solver import VarProProblem, levenberg_marquardt

__all__ = ["EstimateResult", "GridSettings", "VarProProblem", "best_starts", "estimate",
           "grid_candidates", "levenberg_marquardt"]
