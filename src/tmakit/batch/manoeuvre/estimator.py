"""The entry points of the manoeuvre estimator (:mod:`tmakit.batch.manoeuvre`).

:func:`estimate_manoeuvres`, the hook :func:`estimate_for` of ``tk.estimate``, and the
estimator as an object (:class:`ManoeuvreEstimator`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from ...data import MeasurementSet
from ...motion import PiecewiseCurvilinear, default_ref_time, motion_from_name
from ...results.checks import wider_undetermined
from ...results.estimate import EstimateResult
from ...results.nuisance import KnownNuisanceLike, as_known_nuisance
from ...results.solutions import Solution, separated_solutions
from ...results.status import DIVERGED
from ..estimator import (
    BatchEstimator,
    Init,
    Options,
    refuse_manoeuvre_options,
    theta_from_init,
)
from .report import ManoeuvreEstimate, report
from .search import ManoeuvreSearch, ManoeuvreSettings, OrderFit
from .selection import OrderSelection, select_order, sparsify, unknown_price


def _fit_from_start(search: ManoeuvreSearch, ref: float,
                    init: Mapping[str, float] | ArrayLike) -> ManoeuvreEstimate:
    """Fit exactly ``max_manoeuvres`` from ``init`` (user parameters at ``ref``), no search."""
    s = search.s
    m = s.max_manoeuvres
    user = PiecewiseCurvilinear(m, ref)
    theta0 = theta_from_init(user, init)
    if m and (np.any(np.diff(theta0[6 + 2 * m:]) <= 0)
              or theta0[6 + 2 * m] <= search.t0 or theta0[-1] >= search.t_end):
        raise ValueError("init: the change-over times must increase and lie inside the "
                         f"data span ({search.t0:g} s, {search.t_end:g} s)")
    state = user.states(theta0, np.array([search.t0]))[0]
    internal = np.array(theta0, dtype=float)
    internal[:4] = (state[0], state[1], math.hypot(state[3], state[4]),
                    math.atan2(state[3], state[4]))
    fit = search.fit_from(m, internal)
    if s.accelerations == "select":
        fit = sparsify(search, fit)
    return report(search, fit, ref, None, [fit])


def _solutions_of(search: ManoeuvreSearch, res: ManoeuvreEstimate, others: list[OrderFit],
                 ref: float, selection: OrderSelection | None, fits: list[OrderFit]
                 ) -> list[Solution]:
    """Give the separated solutions among the search's fits (empty when ``res`` is the one)."""
    if not res.converged:
        return []
    alternatives = [report(search, f, ref, selection, fits) for f in others
                    if np.isfinite(f.chi2)]
    found = separated_solutions(res, alternatives, search.meas,
                                price=unknown_price(search.s, search.problem(0).noise.rank))
    return found if len(found) > 1 else []


def _wider(wider: ManoeuvreEstimate, res: ManoeuvreEstimate, meas: MeasurementSet
           ) -> ManoeuvreEstimate | None:
    """Give the widest model's fit when it leaves the final position undetermined, not ``res``."""
    if (not res.converged or wider.status == DIVERGED
            or not res.answer(meas).position_determined):
        return None
    return wider if wider_undetermined(wider, meas) else None


def _search_orders(search: ManoeuvreSearch, ref: float) -> ManoeuvreEstimate:
    """Fit every order the data span holds, select the accelerations, choose the order."""
    s = search.s
    n = search.problem(0).noise.rank
    top = search.max_order()
    note = ""
    if top < s.max_manoeuvres:
        note = (f"the data span {search.t_end - search.t0:g} s holds at most {top} "
                f"manoeuvres {s.min_segment:g} s apart on a {s.grid_step:g} s grid")
        if s.exact:
            raise ValueError(note)
    full = [search.fit_zero()]  # every acceleration fitted: the warm starts of the search
    for m in range(1, top + 1):
        full.append(search.fit(m, full[-1]))
    fits = list(full)
    if s.accelerations == "select":
        for i in (range(len(full)) if not s.exact else [len(full) - 1]):
            fits[i] = sparsify(search, full[i])
    if s.exact:
        chosen = fits[-1]
        selection = None
    else:
        selection = select_order(fits, n, s.criterion, s.alpha)
        chosen = fits[selection.chosen]
    res = report(search, chosen, ref, selection, fits)
    others = [f for f in (*fits, *full, *(a for f in {id(f): f for f in (*full, *fits)}
                                               .values() for a in f.alternatives))
              if f is not chosen]
    res.solutions = _solutions_of(search, res, others, ref, selection, fits)
    if full[-1] is not chosen:
        res.wider = _wider(report(search, full[-1], ref, selection, fits), res, search.meas)
    if selection is not None and top and selection.chosen == top == s.max_manoeuvres:
        more = (f"the largest number of manoeuvres tried ({top}) was chosen: more may fit "
                f"better (try curvilinear:{top + 1})")
        note = f"{note}; {more}" if note else more
    if note:
        res.message = f"{res.message}; {note}" if res.message else note
    return res


def estimate_manoeuvres(meas: MeasurementSet, max_manoeuvres: int = 2, *,
                        exact: bool = False, criterion: str = "bic", alpha: float = 0.01,
                        accelerations: str | None = None, ref_time: float | None = None,
                        init: Mapping[str, float] | ArrayLike | None = None,
                        options: Mapping[str, Mapping[str, object]] | None = None,
                        known_nuisance: KnownNuisanceLike = None,
                        settings: ManoeuvreSettings | None = None) -> ManoeuvreEstimate:
    """Estimate piecewise curvilinear motion by maximum likelihood, no initial guess needed.

    Parameters
    ----------
    meas : MeasurementSet
    max_manoeuvres : int
        The most manoeuvres tried (orders ``0 .. max_manoeuvres``).
    exact, criterion, alpha, accelerations, options, known_nuisance, settings : optional
        As for :func:`tmakit.batch.estimate` (``accelerations``: default ``settings``').
    ref_time : float, optional
        Reference time of the reported state, s; default the first measurement time.
    init : mapping or array_like, optional
        Parameters at ``ref_time``, SI: that order alone is fitted from it.

    Returns
    -------
    ManoeuvreEstimate

    Raises
    ------
    ValueError
        For an empty set, bad settings, a bad ``init``, or ``exact`` with more manoeuvres than
        the span holds.

    References
    ----------
    Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9.
    """
    base = settings or ManoeuvreSettings()
    s = replace(base, max_manoeuvres=max_manoeuvres, exact=exact, criterion=criterion,
                alpha=alpha, accelerations=accelerations or base.accelerations)
    if len(meas) == 0:
        raise ValueError("the measurement set is empty")
    search = ManoeuvreSearch(meas, options, as_known_nuisance(known_nuisance), s)
    ref = search.t0 if ref_time is None else float(ref_time)
    if init is not None:
        return _fit_from_start(search, ref, init)
    return _search_orders(search, ref)


def estimate_for(meas: MeasurementSet, motion: PiecewiseCurvilinear | str,
                 init: Mapping[str, float] | ArrayLike | None = None,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 known_nuisance: KnownNuisanceLike = None,
                 max_iter: int = 100, *, exact: bool | None = None,
                 criterion: str | None = None, alpha: float | None = None,
                 accelerations: str | None = None, ref_time: float | None = None,
                 settings: ManoeuvreSettings | None = None) -> EstimateResult:
    """Estimate motion given by name or as a piecewise curvilinear model.

    Parameters
    ----------
    meas : MeasurementSet
    motion : PiecewiseCurvilinear or str
        ``M`` manoeuvres (or ``"curvilinear:M"``) searches ``0..M``; other names go to
        :func:`tmakit.batch.ml.estimate`.
    init, options, known_nuisance, max_iter, exact, criterion, alpha : optional
        As for :func:`tmakit.batch.estimate`.
    accelerations, ref_time, settings : optional
        As for :func:`tmakit.batch.estimate`.

    Returns
    -------
    EstimateResult

    Raises
    ------
    TypeError
        For manoeuvre settings with a motion without manoeuvres.
    ValueError
        For an unknown motion name, and as :func:`estimate_manoeuvres`.

    References
    ----------
    Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9.
    """
    given = {k: v for k, v in (("exact", exact), ("criterion", criterion), ("alpha", alpha),
                               ("accelerations", accelerations), ("settings", settings))
             if v is not None}
    if isinstance(motion, str):
        ref = ref_time
        model = motion_from_name(motion, default_ref_time(meas.time) if ref is None
                                 else float(ref))
        if not isinstance(model, PiecewiseCurvilinear):
            refuse_manoeuvre_options(given, motion)
            from ..ml import estimate

            return estimate(meas, model, init=init, options=options,
                            known_nuisance=known_nuisance, max_iter=max_iter)
        m = model.manoeuvres
    else:
        m, ref = motion.manoeuvres, motion.ref_time if ref_time is None else ref_time
    search = replace(settings or ManoeuvreSettings(), max_iter=max_iter)
    return estimate_manoeuvres(
        meas, m, exact=bool(exact), criterion="bic" if criterion is None else criterion,
        alpha=0.01 if alpha is None else alpha, accelerations=accelerations, ref_time=ref,
        init=init, options=options, known_nuisance=known_nuisance, settings=search)


@dataclass(frozen=True, eq=False)
class ManoeuvreEstimator(BatchEstimator):
    """Maximum likelihood for a manoeuvring target, ``0..M`` manoeuvres, no initial guess.

    Parameters
    ----------
    init, options, known_nuisance, max_iter, exact, criterion, alpha : optional
        As for :func:`tmakit.batch.estimate`.
    accelerations, ref_time, settings : optional
        As for :func:`tmakit.batch.estimate`.

    References
    ----------
    Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9.
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
        dict
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
