"""The manoeuvre estimator as an object.

Maximum likelihood for a piecewise curvilinear target with the number of manoeuvres chosen by
a stated criterion (Hörst & Oispuu (2010)).

The search, the order selection and the reporting are in :mod:`tmakit.batch.curvilinear`;
:class:`ManoeuvreEstimator` holds their settings and calls
:func:`~tmakit.batch.curvilinear.estimate_for`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ...data import MeasurementSet
from ...motion import PiecewiseCurvilinear
from ...results.estimate import EstimateResult
from ...results.nuisance import KnownNuisanceLike, as_known_nuisance
from ..estimator import BatchEstimator, Init, Options
from .estimator import estimate_for
from .settings import ManoeuvreSettings

__all__ = ["ManoeuvreEstimator"]


@dataclass(frozen=True, eq=False)
class ManoeuvreEstimator(BatchEstimator):
    """Maximum likelihood for a manoeuvring target, ``0..M`` manoeuvres, no initial guess.

    Parameters
    ----------
    init : Mapping[str, float] or array_like, optional
        Fit exactly ``M`` manoeuvres from this start (``curvilinear:M`` parameters, SI,
        referenced at ``ref_time``), no search.
    options : Mapping, optional
        The nuisance model per kind, as for :class:`~tmakit.batch.ml.MaximumLikelihood`.
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None, optional
        Hold the nuisance parameters at known values (:mod:`tmakit.results.nuisance`).
    max_iter : int, optional
        Levenberg–Marquardt iterations per fit at most (default 100).
    exact : bool, optional
        Fit only ``M`` manoeuvres (default: search ``0..M``).
    criterion : str, optional
        ``"bic"`` (default) or ``"lrt"``: how the number of manoeuvres is chosen.
    alpha : float, optional
        Level of the likelihood-ratio tests (default 0.01).
    accelerations : str, optional
        ``"select"`` (default) holds at zero the accelerations the data do not need;
        ``"all"`` fits them all.
    ref_time : float, optional
        Reference time (s) of the reported parameters; default the motion model's, or the
        first measurement time for a motion name.
    settings : ManoeuvreSettings, optional
        The search's grid and limits.

    Notes
    -----
    Settings left at None are not passed on, so that
    :func:`~tmakit.batch.curvilinear.estimate_for` applies its own defaults (and refuses
    manoeuvre settings for a motion name without manoeuvres, such as ``"cv2d"``).

    References
    ----------
    Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9: piecewise curvilinear motion, azimuth and
    azimuth rate.
    """

    init: Init = None
    options: Options = None
    known_nuisance: KnownNuisanceLike = None
    max_iter: int = 100
    exact: bool | None = None
    criterion: str | None = None
    alpha: float | None = None
    accelerations: str | None = None
    ref_time: float | None = None
    settings: ManoeuvreSettings | None = None

    name: ClassVar[str] = "ml"
    takes_known_nuisance: ClassVar[bool] = True

    def __post_init__(self) -> None:
        """``known_nuisance`` as a :class:`KnownNuisance` or None."""
        object.__setattr__(self, "known_nuisance", as_known_nuisance(self.known_nuisance))

    def manoeuvre_options(self) -> dict[str, object]:
        """Collect the manoeuvre settings that were given.

        Returns
        -------
        dict of str to object
            The settings not left at None, by keyword of
            :func:`~tmakit.batch.curvilinear.estimate_for`.
        """
        given = {"exact": self.exact, "criterion": self.criterion, "alpha": self.alpha,
                 "accelerations": self.accelerations, "ref_time": self.ref_time,
                 "settings": self.settings}
        return {k: v for k, v in given.items() if v is not None}

    def fit(self, meas: MeasurementSet, motion: PiecewiseCurvilinear | str  # type: ignore[override]
            ) -> EstimateResult:
        """Estimate the manoeuvring target's motion."""
        return estimate_for(meas, motion, init=self.init, options=self.options,
                            known_nuisance=self.known_nuisance,
                            max_iter=self.max_iter, exact=self.exact,
                            criterion=self.criterion, alpha=self.alpha,
                            accelerations=self.accelerations, ref_time=self.ref_time,
                            settings=self.settings)
