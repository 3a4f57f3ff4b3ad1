"""Batch estimators: tmakit's maximum likelihood and the papers' methods (Gu et al. (2007) §3-4).

:func:`estimate` builds and fits; :data:`METHODS` names every estimator.
"""

from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisance
from .methods import METHODS, estimate
from .papers import GuDirect, LectureGaussNewton, RatioMethod
from .solver import VarProProblem, levenberg_marquardt

__all__ = ["METHODS", "EstimateResult", "GuDirect", "KnownNuisance", "LectureGaussNewton",
           "RatioMethod", "VarProProblem", "estimate", "levenberg_marquardt"]
