"""Batch estimators, each an object with its settings in the constructor.

Maximum likelihood with nuisance parameters eliminated (no initial guess needed) and the
papers' own methods (Gu et al. (2007) §3-4: ratio method, direct iterative LS; the
Gauss-Newton of the Doppler-tracking lecture notes), each an object with its settings in the
constructor and a ``fit(measurements, motion)`` that returns an :class:`EstimateResult`::

    from tmakit.batch import METHODS, MaximumLikelihood, RatioMethod
    res = MaximumLikelihood(options={"frequency": {"drift": True}}).fit(meas, motion)
    res = RatioMethod(kinds="frequency").fit(meas, motion)     # tmakit's grid start
    res = METHODS["gu-direct"](init=start).fit(meas, motion)   # by name

:func:`estimate` (``tk.estimate``) and :func:`estimate_with` are the short forms.  Which
nuisance parameters are known is said with :class:`~tmakit.results.KnownNuisance`.
"""

from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisance
from .dispatch import MLByMotion, estimate
from .estimator import BatchEstimator, PaperMethod
from .gu_direct import GuDirect
from .init import GridSettings, best_starts, grid_candidates, grid_start
from .lecture import LectureGaussNewton
from .manoeuvre import ManoeuvreEstimator
from .methods import METHODS, Method, estimate_with, estimator
from .ml import MaximumLikelihood
from .ratios import RatioMethod
from .solver import VarProProblem, levenberg_marquardt

__all__ = ["METHODS", "BatchEstimator", "EstimateResult", "GridSettings", "GuDirect",
           "KnownNuisance", "LectureGaussNewton", "MLByMotion", "ManoeuvreEstimator",
           "MaximumLikelihood", "Method", "PaperMethod", "RatioMethod", "VarProProblem",
           "best_starts", "estimate", "estimate_with", "estimator", "grid_candidates",
           "grid_start", "levenberg_marquardt"]
