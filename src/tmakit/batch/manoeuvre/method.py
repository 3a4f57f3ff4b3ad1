"""The manoeuvre estimator as an object (Hörst & Oispuu (2010)): settings for ``estimate_for``."""

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

    Settings left at None take :func:`~tmakit.batch.curvilinear.estimate_for`'s defaults.

    Parameters
    ----------
    init : Mapping[str, float] or array_like, optional
        Fit exactly ``M`` from this start (SI, at ``ref_time``).
    options : Mapping, optional
        The nuisance model per kind.
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None, optional
    max_iter : int, optional
        Per fit (default 100).
    exact : bool, optional
        Fit only ``M``.
    criterion : str, optional
        ``"bic"`` (default) or ``"lrt"``.
    alpha : float, optional
        Level of the tests (default 0.01).
    accelerations : str, optional
        ``"select"`` (default) or ``"all"``.
    ref_time : float, optional
        s, of the reported parameters.
    settings : ManoeuvreSettings, optional

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
        """Collect the manoeuvre settings given (not None), by keyword.

        Returns
        -------
        dict of str to object
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
