"""tmakit's maximum likelihood for any motion: ``tk.estimate(meas, motion)``.

A manoeuvring target goes to :class:`~tmakit.batch.manoeuvre.ManoeuvreEstimator`, any other
motion to :class:`~tmakit.batch.ml.MaximumLikelihood`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

from ..data import MeasurementSet
from ..motion import MotionModel, PiecewiseCurvilinear, default_ref_time, motion_from_name
from ..results.estimate import EstimateResult
from ..results.nuisance import KnownNuisanceLike, as_known_nuisance
from .estimator import BatchEstimator, Init, Options, refuse_manoeuvre_options
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
    """Maximum likelihood of tmakit, the estimator chosen by the motion (``"ml"`` of METHODS).

    Parameters
    ----------
    init, options, known_nuisance, grid, max_iter : optional
        As for :func:`estimate`.
    exact, criterion, alpha, accelerations, ref_time, settings : optional
        As for :func:`estimate`.
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
        refuse_manoeuvre_options(chosen.manoeuvre_options(), motion)
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
    Hörst & Oispuu (2010), eqs. 1-4 (motion) and 8 (likelihood), for the manoeuvring target.
    """
    return MLByMotion(init, options, known_nuisance, grid, max_iter, exact=exact,
                      criterion=criterion, alpha=alpha, accelerations=accelerations,
                      ref_time=ref_time, settings=settings).fit(meas, motion)
