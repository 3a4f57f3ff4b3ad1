"""Every batch estimator by name (:data:`METHODS`), and the short forms that build and fit.

``tk.estimate`` (:class:`MLByMotion`) sends a manoeuvring target to
:class:`~tmakit.batch.manoeuvre.ManoeuvreEstimator`, any other motion to
:class:`~tmakit.batch.ml.MaximumLikelihood`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypedDict, Unpack

from ..data import MeasurementSet
from ..motion import MotionModel, PiecewiseCurvilinear, default_ref_time, motion_from_name
from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisanceLike, as_known_nuisance
from .estimator import BatchEstimator, Init, Options, refuse_manoeuvre_options
from .hyperbolic import ChanHo, HoXu
from .init import GridSettings
from .manoeuvre import ManoeuvreEstimator, ManoeuvreSettings
from .ml import MaximumLikelihood
from .papers import GuDirect, LectureGaussNewton, RatioMethod

__all__ = ["METHODS", "EstimatorSettings", "MLByMotion", "Method", "estimate", "estimate_with",
           "estimator", "model_of"]


class EstimatorSettings(TypedDict, total=False):
    """The keywords of the batch estimators by name (:data:`METHODS`; PEP 692).

    Each estimator takes those its class documents; one it does not take raises
    :class:`TypeError` naming it, and one named nowhere here is a type error.

    Attributes
    ----------
    init, options
        Every estimator's.
    max_iter, tol
        ``max_iter``: ``ml`` and the papers' iterations; ``tol``: the papers' iterations.
    known_nuisance, grid, exact, criterion, alpha, accelerations, ref_time, settings
        ``ml`` (:class:`MLByMotion`, as for :func:`estimate`).
    kinds, c0, normal_equations, covariance
        The papers' methods (:class:`~tmakit.batch.GuDirect`,
        :class:`~tmakit.batch.RatioMethod`), each documented on its class.
    """

    init: Init
    options: Options
    max_iter: int
    tol: float
    known_nuisance: KnownNuisanceLike
    grid: GridSettings | None
    exact: bool | None
    criterion: str | None
    alpha: float | None
    accelerations: str | None
    ref_time: float | None
    settings: ManoeuvreSettings | None
    kinds: str | Sequence[str] | None
    c0: float | None
    normal_equations: bool
    covariance: str


def is_manoeuvring(motion: MotionModel) -> bool:
    """Tell whether ``motion`` is a manoeuvring target's."""
    return getattr(motion, "manoeuvres", None) is not None


def model_of(motion: MotionModel | str, meas: MeasurementSet,
             ref_time: float | None) -> MotionModel:
    """Read a motion name once, into the model it stands for; give a model back as it is."""
    if not isinstance(motion, str):
        return motion
    model = motion_from_name(motion, default_ref_time(meas.time) if ref_time is None
                             else float(ref_time))
    if ref_time is None and isinstance(model, PiecewiseCurvilinear) and len(meas):
        model = PiecewiseCurvilinear(model.manoeuvres, float(meas.time.min()))
    return model


class MLByMotion(BatchEstimator):
    """Maximum likelihood of tmakit, the estimator chosen by the motion (``"ml"`` of METHODS)."""

    name: ClassVar[str] = "ml"
    takes_known_nuisance: ClassVar[bool] = True

    def __init__(self, init: Init = None, options: Options = None,
                 known_nuisance: KnownNuisanceLike = None, grid: GridSettings | None = None,
                 max_iter: int = 100, *, exact: bool | None = None,
                 criterion: str | None = None, alpha: float | None = None,
                 accelerations: str | None = None, ref_time: float | None = None,
                 settings: ManoeuvreSettings | None = None) -> None:
        self.init = init
        self.options = options
        self.known_nuisance = as_known_nuisance(known_nuisance)
        self.grid = grid
        self.max_iter = max_iter
        self.ref_time = ref_time
        given = (("exact", exact), ("criterion", criterion), ("alpha", alpha),
                 ("accelerations", accelerations), ("ref_time", ref_time),
                 ("settings", settings))
        # (a ManoeuvreEstimator is made in fit, for a manoeuvring target only)
        self._manoeuvre_options: dict[str, Any] = {k: v for k, v in given if v is not None}

    def __repr__(self) -> str:
        """Return the constructor call that makes this estimator."""
        extra = "".join(f", {k}={v!r}" for k, v in self._manoeuvre_options.items())
        return (f"MLByMotion(init={self.init!r}, options={self.options!r}, "
                f"known_nuisance={self.known_nuisance!r}, grid={self.grid!r}, "
                f"max_iter={self.max_iter!r}{extra})")

    def fit(self, meas: MeasurementSet, motion: MotionModel | str) -> EstimateResult:
        """Return the maximum-likelihood estimate for ``motion``."""
        given = self._manoeuvre_options
        if isinstance(motion, str):  # read here, once: its ref_time is used up
            motion = model_of(motion, meas, self.ref_time)
            given = {k: v for k, v in given.items() if k != "ref_time"}
        if isinstance(motion, PiecewiseCurvilinear):
            return ManoeuvreEstimator(
                init=self.init, options=self.options, known_nuisance=self.known_nuisance,
                max_iter=self.max_iter, **given).fit(meas, motion)
        refuse_manoeuvre_options(given, motion)
        return MaximumLikelihood(self.init, self.options, self.known_nuisance, self.grid,
                                 self.max_iter).fit(meas, motion)


def estimate(meas: MeasurementSet, motion: MotionModel | str, init: Init = None,
             options: Options = None, known_nuisance: KnownNuisanceLike = None,
             grid: GridSettings | None = None, max_iter: int = 100, *,
             exact: bool | None = None, criterion: str | None = None,
             alpha: float | None = None, accelerations: str | None = None,
             ref_time: float | None = None,
             settings: ManoeuvreSettings | None = None) -> EstimateResult:
    """Estimate the motion parameters by maximum likelihood, no initial guess needed.

    Parameters
    ----------
    meas : MeasurementSet
    motion : MotionModel or str
        ``M`` manoeuvres (or ``"curvilinear:M"``) searches ``0..M``.
    init : Mapping[str, float] or array_like, optional
        A start, SI; default the likelihood grid.
    options : Mapping, optional
        The nuisance model per kind, e.g. ``{"frequency": {"drift": True}}``.
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None, optional
        Fix the nuisance at these values.
    grid : GridSettings, optional
    max_iter : int, optional
        Per start (default 100).
    exact : bool, optional
        Manoeuvring target: fit exactly ``M``.
    criterion : {"bic", "lrt"}, optional
        Manoeuvring target: how ``M`` is chosen (default "bic").
    alpha : float, optional
        Manoeuvring target: level of the tests (default 0.01).
    accelerations : {"select", "all"}, optional
        Manoeuvring target: hold unneeded accelerations at zero, or fit all.
    ref_time : float, optional
        Reference time, s, of a named motion and of the reported parameters.
    settings : ManoeuvreSettings, optional
        Manoeuvring target: the search's grid and limits.

    Returns
    -------
    EstimateResult

    Raises
    ------
    TypeError
        For manoeuvre options with a motion without manoeuvres.
    ValueError
        For a bad ``init``, a bad motion name, or data no grid point fits.

    References
    ----------
    Hörst & Oispuu (2010), eqs. 1-4 and 8 (the manoeuvring target).
    """
    return MLByMotion(init, options, known_nuisance, grid, max_iter, exact=exact,
                      criterion=criterion, alpha=alpha, accelerations=accelerations,
                      ref_time=ref_time, settings=settings).fit(meas, motion)


@dataclass(frozen=True)
class Method:
    """A batch estimator by name: its class and the settings the name fixes."""

    cls: type[BatchEstimator]
    fixed: Mapping[str, object] = field(default_factory=dict, hash=False)
    summary: str = ""

    @property
    def takes_known_nuisance(self) -> bool:
        """Whether the method can hold the nuisance at known values."""
        return self.cls.takes_known_nuisance

    def __call__(self, **settings: Unpack[EstimatorSettings]) -> BatchEstimator:
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


def estimator(method: str, **settings: Unpack[EstimatorSettings]) -> BatchEstimator:
    """Build the batch estimator ``method`` (a key of :data:`METHODS`) with ``settings``.

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
                  **settings: Unpack[EstimatorSettings]) -> EstimateResult:
    """Run the batch estimator ``method`` on the data (``settings`` as for :func:`estimator`)."""
    return estimator(method, **settings).fit(meas, motion)
