"""tmakit's maximum likelihood for any motion: ``tk.estimate(meas, motion)``.

The motion decides the estimator: a manoeuvring target (a
:class:`~tmakit.motion.PiecewiseCurvilinear`, or a motion given by name) goes to
:class:`~tmakit.batch.manoeuvre.ManoeuvreEstimator`, any other motion model to
:class:`~tmakit.batch.ml.MaximumLikelihood`.  This module sits above both, so neither imports
the other (:mod:`tmakit.batch.curvilinear` uses :mod:`tmakit.batch.ml` for its constant-velocity
start; :mod:`tmakit.batch.ml` imports no manoeuvre code).
"""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

from ..data import MeasurementSet
from ..motion import MotionModel, PiecewiseCurvilinear, default_ref_time, motion_from_name
from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisanceLike, as_known_nuisance
from .estimator import BatchEstimator, Init, Options
from .init import GridSettings
from .manoeuvre import ManoeuvreEstimator, ManoeuvreSettings
from .ml import estimate as estimate_ml

__all__ = ["MLByMotion", "estimate", "model_of"]


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
    """Maximum likelihood of tmakit, the estimator chosen by the motion at :meth:`fit`.

    This is the ``"ml"`` entry of :data:`tmakit.batch.METHODS`.

    Parameters
    ----------
    init : Mapping[str, float] or array_like, optional
        A starting point (SI); default: none needed.
    options : Mapping, optional
        The nuisance model per kind.
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None, optional
        Hold the nuisance parameters at known values (:mod:`tmakit.results.nuisance`).
    grid : GridSettings, optional
        The grid of starting points of :class:`~tmakit.batch.ml.MaximumLikelihood` (not used
        for a manoeuvring target, whose search has its own grid).
    max_iter : int, optional
        Iterations per start at most (default 100).
    exact, criterion, alpha, accelerations, ref_time, settings : optional
        Settings of :class:`~tmakit.batch.manoeuvre.ManoeuvreEstimator`, for manoeuvring
        targets; refused with a motion model that has no manoeuvres (``ref_time`` also sets
        the reference time of a motion given by name).
    """

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
        #: The manoeuvre settings given (None: not given, the estimator's default).
        self.manoeuvre = ManoeuvreEstimator(
            exact=exact, criterion=criterion, alpha=alpha, accelerations=accelerations,
            ref_time=ref_time, settings=settings)

    def __repr__(self) -> str:
        """Return the constructor call that makes this estimator."""
        extra = "".join(f", {k}={v!r}" for k, v in self.manoeuvre.manoeuvre_options().items())
        return (f"MLByMotion(init={self.init!r}, options={self.options!r}, "
                f"known_nuisance={self.known_nuisance!r}, grid={self.grid!r}, "
                f"max_iter={self.max_iter!r}{extra})")

    def fit(self, meas: MeasurementSet, motion: MotionModel | str) -> EstimateResult:
        """Return the maximum-likelihood estimate for ``motion``."""
        chosen = self.manoeuvre
        if isinstance(motion, str):  # the name is read here, once; its ref_time is used up
            motion = model_of(motion, meas, self.ref_time)
            chosen = replace(chosen, ref_time=None)
        if isinstance(motion, PiecewiseCurvilinear):
            return replace(chosen, init=self.init, options=self.options,
                           known_nuisance=self.known_nuisance,
                           max_iter=self.max_iter).fit(meas, motion)
        given = chosen.manoeuvre_options()
        if given:
            raise TypeError(f"estimate() got options for manoeuvring targets "
                            f"({', '.join(given)}) with motion "
                            f"{getattr(motion, 'name', motion)!r}")
        return estimate_ml(meas, motion, init=self.init, options=self.options,
                           known_nuisance=self.known_nuisance, grid=self.grid,
                           max_iter=self.max_iter)


def estimate(meas: MeasurementSet, motion: MotionModel | str, init: Init = None,
             options: Options = None, known_nuisance: KnownNuisanceLike = None,
             grid: GridSettings | None = None, max_iter: int = 100, *,
             exact: bool | None = None, criterion: str | None = None,
             alpha: float | None = None, accelerations: str | None = None,
             ref_time: float | None = None,
             settings: ManoeuvreSettings | None = None) -> EstimateResult:
    """Estimate the motion parameters by maximum likelihood, no initial guess needed.

    The short form of :class:`MLByMotion` (``tk.estimate``).

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    motion : MotionModel or str
        The motion model, or its name.  A :class:`~tmakit.motion.PiecewiseCurvilinear` with
        ``M`` manoeuvres, or ``"curvilinear:M"``, searches ``0..M`` manoeuvres, the number
        chosen by a stated criterion.
    init : Mapping[str, float] or array_like, optional
        A starting point by name or as a vector (SI); without it the grid of
        :mod:`tmakit.batch.init` finds the starting points.
    options : Mapping, optional
        The nuisance model per kind (``{"frequency": {"drift": True}, "power": {"exponent":
        None}}``).
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None, optional
        Fix the nuisance parameters at the given values instead of estimating them.
    grid : GridSettings, optional
        The grid of starting points (motion models without manoeuvres).
    max_iter : int, optional
        Iterations per start at most (default 100).
    exact : bool, optional
        For a manoeuvring target: fit exactly ``M`` manoeuvres (default: search ``0..M``).
    criterion : {"bic", "lrt"}, optional
        For a manoeuvring target: how the number of manoeuvres is chosen (default "bic").
    alpha : float, optional
        For a manoeuvring target: level of the likelihood-ratio tests (default 0.01).
    accelerations : {"select", "all"}, optional
        For a manoeuvring target: hold unneeded accelerations at zero, or fit them all.
    ref_time : float, optional
        Reference time (s) of a motion given by name, and of a manoeuvring target's
        reported parameters.
    settings : ManoeuvreSettings, optional
        For a manoeuvring target: the search's grid and limits.

    Returns
    -------
    EstimateResult
        The estimate, its covariance (inverse Fisher information at the estimate) and a
        status that is never hidden.

    Raises
    ------
    TypeError
        For manoeuvre options with a motion model without manoeuvres.
    ValueError
        For a bad ``init``, a bad motion name, or data no grid point fits.

    References
    ----------
    Hörst & Oispuu (2010), eqs. 1-4 (motion) and 8 (likelihood), for the manoeuvring target.
    """
    return MLByMotion(init, options, known_nuisance, grid, max_iter, exact=exact,
                      criterion=criterion, alpha=alpha, accelerations=accelerations,
                      ref_time=ref_time, settings=settings).fit(meas, motion)
