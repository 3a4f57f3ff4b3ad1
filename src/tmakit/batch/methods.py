"""Every batch estimator by name (:data:`METHODS`), and the short forms that build and fit.

The papers' local iterations start, when given no start, from tmakit's likelihood grid
(:func:`tmakit.batch.init.grid_start`), which the result says in ``extra["start"]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from ..data import MeasurementSet
from ..motion import MotionModel
from ..results.estimate import EstimateResult
from .dispatch import MLByMotion
from .estimator import BatchEstimator, Init, Options
from .gu_direct import GuDirect
from .hyperbolic import ChanHo, HoXu
from .lecture import LectureGaussNewton
from .ratios import RatioMethod

__all__ = ["METHODS", "Method", "estimate_with", "estimator"]


@dataclass(frozen=True)
class Method:
    """A batch estimator by name: its class and the settings the name fixes.

    Parameters
    ----------
    cls : type
        A :class:`~tmakit.batch.estimator.BatchEstimator` subclass.
    fixed : Mapping[str, object], optional
        Settings the name fixes (``ratio-power``: ``kinds=("power",)``).
    summary : str, optional
    """

    cls: type[BatchEstimator]
    fixed: Mapping[str, object] = field(default_factory=dict, hash=False)
    summary: str = ""

    @property
    def takes_known_nuisance(self) -> bool:
        """Whether the method can hold the nuisance parameters at known values."""
        return self.cls.takes_known_nuisance

    def __call__(self, **settings: object) -> BatchEstimator:
        """Build the estimator with these settings (and the ones the name fixes)."""
        clash = sorted(set(settings) & set(self.fixed))
        if clash:
            raise TypeError(f"{self.cls.__name__}: {', '.join(clash)} fixed by the method's "
                            "name")
        return self.cls(**{**self.fixed, **settings})


METHODS: dict[str, Method] = {
    "ml": Method(MLByMotion, summary="tmakit's maximum likelihood, no initial guess"),
    "gu-direct": Method(GuDirect, summary="Gu et al. (2007) §3, direct iterative LS"),
    "ratio-power": Method(RatioMethod, {"kinds": ("power",)},
                          "Gu et al. (2007) §4, power ratios"),
    "ratio-doppler": Method(RatioMethod, {"kinds": ("frequency",)},
                            "Gu et al. (2007) §4, Doppler ratios"),
    "ratio": Method(RatioMethod, {"kinds": ("power", "frequency")},
                    "Gu et al. (2007) §4, power and Doppler ratios"),
    "lecture-gn": Method(LectureGaussNewton,
                         summary="the Doppler-tracking lecture's Gauss–Newton"),
    "chan-ho": Method(ChanHo, summary="Chan & Ho (1994), closed-form TDOA (stationary source)"),
    "ho-xu": Method(HoXu, summary="Ho & Xu (2004), closed-form TDOA + FDOA (moving source)"),
}
"""Batch estimators by name, each building a :class:`~tmakit.batch.estimator.BatchEstimator`."""


def estimator(method: str, **settings: object) -> BatchEstimator:
    """Build the batch estimator ``method`` (a key of :data:`METHODS`) with ``settings``.

    Parameters
    ----------
    method : str
    **settings
        Its class's constructor parameters.

    Returns
    -------
    BatchEstimator

    Raises
    ------
    ValueError
        For an unknown method, or settings it refuses.
    TypeError
        For a setting it does not take.

    References
    ----------
    Gu et al. (2007), §3 (``gu-direct``), eqs. 19-25 (``ratio-power``), 26-32
    (``ratio-doppler``), 33-34 (``ratio``); the Doppler-tracking lecture notes (``lecture-gn``);
    Chan & Ho (1994) (``chan-ho``), Ho & Xu (2004) (``ho-xu``).
    """
    if method not in METHODS:
        raise ValueError(f"unknown estimation method {method!r}; expected one of "
                         f"{', '.join(METHODS)}")
    return METHODS[method](**settings)


def estimate_with(method: str, meas: MeasurementSet, motion: MotionModel,
                  init: Init = None, options: Options = None,
                  **settings: object) -> EstimateResult:
    """Run the batch estimator ``method`` on the data.

    Parameters
    ----------
    method : str
        A key of :data:`METHODS`.
    meas : MeasurementSet
    motion : MotionModel
        For ``ml`` also a motion name.
    init, options : optional
        The start (SI) and the nuisance model per kind, as for :func:`tmakit.batch.estimate`.
    **settings
        Other settings of the method's class.

    Returns
    -------
    EstimateResult

    Raises
    ------
    ValueError
        For an unknown method, refused settings, or data the method cannot use.
    TypeError
        For a setting the method does not take.
    """
    return estimator(method, init=init, options=options, **settings).fit(meas, motion)
