"""Batch estimators, each an object with its settings in the constructor and ``fit``.

tmakit's maximum likelihood and the papers' methods (Gu et al. (2007) §3-4; the
Doppler-tracking lecture notes); :func:`estimate` and :func:`estimate_with` build and fit.
"""

from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisance
from .estimator import BatchEstimator
from .init import GridSettings, best_starts, grid_candidates, grid_start
from .manoeuvre import ManoeuvreEstimator
from .methods import METHODS, Method, MLByMotion, estimate, estimate_with, estimator
from .ml import MaximumLikelihood
from .papers import GuDirect, LectureGaussNewton, PaperMethod, RatioMethod
from .solver import VarProProblem, levenberg_marquardt

__all__ = ["METHODS", "BatchEstimator", "EstimateResult", "GridSettings", "GuDirect",
           "KnownNuisance", "LectureGaussNewton", "MLByMotion", "ManoeuvreEstimator",
           "MaximumLikelihood", "Method", "PaperMethod", "RatioMethod", "VarProProblem",
           "best_starts", "estimate", "estimate_with", "estimator", "grid_candidates",
           "grid_start", "levenberg_marquardt"]
