"""Is a constant-velocity fit hiding a target manoeuvre?  An F test against one leg change.

A constant-velocity (CV) fit over a window in which the target changed course or speed can pass
the chi-square test when the stated bearing sigma is larger than the real noise, and then prints
a small, confident and wrong ellipse.  This test fits the same rows with one manoeuvre at an
unknown time (the manoeuvre search's order 1, every acceleration free: :mod:`.manoeuvre`) and
compares the two fits by the F statistic of nested least squares (Seber & Wild 1989, eq. 5.23)

    F = ((chi2_cv - chi2_1) / q) / (chi2_1 / (n - p_1)),

in which the stated sigma cancels: the noise level is the larger model's residuals.  The change
time is searched over the manoeuvre grid, so the p-value is Bonferroni-corrected by the number
of grid times searched (q counts the accelerations, not the time).  A warning needs, besides,
the one-manoeuvre fit's final state outside the CV fit's 95 % region: a change too small to
move the answer out of what is printed leaves that answer honest.  The threshold and its
measured false-alarm rate on simulated non-manoeuvring targets are in docs/analyst.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.special import fdtrc

from ..core import chi2 as chi2_dist
from ..data import MeasurementSet
from ..motion.curvilinear import ForwardPiecewise
from ..results.answers import fit_state
from ..results.checks import SanityWarning
from ..results.context import clock_time
from ..results.estimate import EstimateResult
from ..results.nuisance import as_known_nuisance
from .manoeuvre import ManoeuvreSearch, ManoeuvreSettings
from .ml import estimate

__all__ = ["LEG_CHANGE_P", "LegChange", "leg_change_test", "leg_change_warning"]

LEG_CHANGE_P = 1e-3
"""A CV fit is warned about when one manoeuvre explains the rows at this corrected p-value."""

REGION_4D = float(chi2_dist.ppf(0.95, 4))
"""chi2(4) 95 % quantile: the final state's region (x, y, vx, vy) of the CV fit."""

CORRELATED = 0.5
"""Above this lag-1 residual correlation the warning says the noise may be coloured."""

GRID_TIMES = 40
"""The change time is searched on this many grid steps across the window."""

MIN_LEG = 0.1
"""Each leg spans at least this share of the window (and 3 grid steps)."""

MAX_ROWS = 1000
"""Larger sets are tested on this many rows evenly spread in time, the CV fit refitted on them
(a leg change that moves the answer shows in a thousand bearings; a search over 10⁷ rows
would cost the command minutes; 0.16 s at 1,000 rows)."""


def search_settings(span: float) -> ManoeuvreSettings:
    """Give the search of the one change time over a window of ``span`` s."""
    step = span / GRID_TIMES
    return ManoeuvreSettings(max_manoeuvres=1, accelerations="all", grid_step=step,
                             min_segment=max(MIN_LEG * span, 3 * step), refine=2,
                             polish_rounds=1, polish_step=step / 10)


@dataclass(frozen=True)
class LegChange:
    """The CV fit against one manoeuvre at the best time.

    Parameters
    ----------
    statistic, p_value : float
        F and its p-value, Bonferroni-corrected for the ``times_searched``.
    times_searched, dof_num, dof_den : int
    change_time : float
        The manoeuvre's start, s.
    start, change, end : tuple of float
        ``(course_deg, speed_m_s)`` of the one-manoeuvre fit at the first row, at the change
        and at the last row.
    turn_first : bool
        Whether that fit turns before the change and holds a leg after (else a leg, then a
        turn).
    correlation : float
        The one-manoeuvre fit's residuals' lag-1 autocorrelation (:func:`residual_correlation`).
    distance2 : float
        The one-manoeuvre fit's final ``(x, y, vx, vy)`` in the CV fit's covariance there:
        Mahalanobis distance squared.
    """

    statistic: float
    p_value: float
    times_searched: int
    dof_num: int
    dof_den: int
    change_time: float
    start: tuple[float, float]
    change: tuple[float, float]
    end: tuple[float, float]
    turn_first: bool
    correlation: float
    distance2: float

    @property
    def manoeuvred(self) -> bool:
        """Whether constant velocity is rejected and the manoeuvre leaves the CV's region.

        Both at once: the F test at :data:`LEG_CHANGE_P`, and the one-manoeuvre fit's final
        state outside the CV fit's 95 % region of it (a change too small to move the answer
        out of what is printed leaves the answer honest).
        """
        return self.p_value < LEG_CHANGE_P and self.distance2 > REGION_4D


def _is_cv2d(result: EstimateResult) -> bool:
    return str(getattr(result.motion, "name", "")) == "cv2d"


def residual_correlation(meas: MeasurementSet, z: np.ndarray) -> float:
    """Pool each sensor's lag-1 autocorrelation of the residuals ``z``, in [0, 0.95]."""
    num = den = 0.0
    for sensor in np.unique(meas.sensor):
        rows = np.flatnonzero(meas.sensor == sensor)
        e = z[rows[np.argsort(meas.time[rows], kind="stable")]]
        e = e - e.mean()
        num += float(np.sum(e[1:] * e[:-1]))
        den += float(np.sum(e * e))
    return float(np.clip(num / den, 0.0, 0.95)) if den > 0 else 0.0


def leg_change_test(meas: MeasurementSet, result: EstimateResult,
                    options: Mapping[str, Mapping[str, object]] | None = None
                    ) -> LegChange | None:
    """Test a converged ``cv2d`` fit against one target manoeuvre at an unknown time.

    Parameters
    ----------
    meas, result : MeasurementSet, EstimateResult
        The rows fitted and their CV fit.
    options : mapping, optional
        The fit's measurement-model options.

    Returns
    -------
    LegChange or None
        None when the test does not apply: another motion, no converged fit, or a window
        without room or rows for a second leg.
    """
    if not _is_cv2d(result) or result.status != "converged" or not np.isfinite(result.chi2):
        return None
    span = float(np.ptp(meas.time)) if len(meas) else 0.0
    if not span > 0:
        return None
    if len(meas) > MAX_ROWS:
        meas, result = _spread_rows(meas, result, options)
        if result.status != "converged" or not np.isfinite(result.chi2):
            return None
    search = ManoeuvreSearch(meas, options, as_known_nuisance(None), search_settings(span))
    times = search.grid[(search.grid - search.t0 >= search.s.min_segment)
                        & (search.t_end - search.grid >= search.s.min_segment)]
    if times.size == 0:
        return None
    x, y, _, vx, vy, _ = result.motion.states(np.asarray(result.estimate),
                                              np.array([search.t0]))[0]
    starts = np.zeros((times.size, 9))
    starts[:, :4] = [x, y, math.hypot(vx, vy), math.atan2(vx, vy)]
    starts[:, 8] = times
    fits = []
    for turning in (slice(6, 8), slice(4, 6)):  # a leg, then a turn; a turn, then a leg
        free = np.array([True] * 4 + [False] * 5)
        free[turning] = True
        try:
            held = search.fit_from(1, starts, free)
            free[8] = True
            fits += [held, search.fit_from(1, held.theta, free)]
        except ValueError:
            continue
    fits = [f for f in fits if np.isfinite(f.chi2)]
    if not fits:
        return None
    one = min(fits, key=lambda f: f.chi2)
    n = search.problem(0).noise.rank
    p_cv = n - int(result.dof)
    q = 2  # the turn's accelerations; the time and the order by the correction
    den = n - p_cv - q - 1
    if den < 1 or not np.isfinite(one.chi2) or not one.chi2 > 0:
        return None
    pr = search.problem(1)
    z = pr.obs.residuals(one.theta, one.nuisance) / pr.obs.meas.sigma_si
    rho = residual_correlation(pr.obs.meas, z)
    f = max(float(result.chi2) - one.chi2, 0.0) / q / (one.chi2 / den)
    searched = 2 * times.size
    p = min(1.0, searched * float(fdtrc(q, den, f)))
    model = search.problem(1).obs.motion
    assert isinstance(model, ForwardPiecewise)
    t_change = float(one.theta[-1])
    st = model.segment_states(one.theta, np.array([search.t0, t_change, search.t_end]))

    def leg(s: np.ndarray) -> tuple[float, float]:
        return math.degrees(float(s[3])) % 360.0, float(s[2])

    turn_first = bool(one.free is not None and one.free[4])
    return LegChange(f, p, searched, q, den, t_change, leg(st[0]), leg(st[1]), leg(st[2]),
                     turn_first, rho, _distance2(result, st[2], search.t_end))


def _distance2(result: EstimateResult, segment_state: np.ndarray, t_end: float) -> float:
    """Mahalanobis distance squared of a segment's end state from the CV fit's at ``t_end``."""
    x, y, speed, course = segment_state
    end = np.array([x, y, speed * math.sin(course), speed * math.cos(course)])
    state, cov, _, _ = fit_state(result, t_end)
    keep = [0, 1, 3, 4]
    gap = end - state[keep]
    try:
        d2 = float(gap @ np.linalg.solve(cov[np.ix_(keep, keep)], gap))
    except np.linalg.LinAlgError:
        return math.inf
    return d2 if np.isfinite(d2) else math.inf


def _spread_rows(meas: MeasurementSet, result: EstimateResult,
                 options: Mapping[str, Mapping[str, object]] | None
                 ) -> tuple[MeasurementSet, EstimateResult]:
    """``MAX_ROWS`` rows evenly spread in time, and the CV fit refitted on them."""
    rows = np.linspace(0, len(meas) - 1, MAX_ROWS).round().astype(int)
    t = meas.time  # (no sort of rows already in time order)
    meas = meas.take(rows if np.all(t[1:] >= t[:-1]) else np.argsort(t, kind="stable")[rows])
    return meas, estimate(meas, result.motion, init=result.estimate, options=options)


def leg_change_warning(meas: MeasurementSet, result: EstimateResult,
                       options: Mapping[str, Mapping[str, object]] | None = None,
                       subject: str = "the constant-velocity answer",
                       advice: str = "fit the last leg alone (--from after the change) or "
                                     "--motion curvilinear:1") -> SanityWarning | None:
    """Warn (code ``target-manoeuvre``) when :func:`leg_change_test` rejects constant velocity.

    Parameters
    ----------
    meas, result, options
        As for :func:`leg_change_test`.
    subject, advice : str
        What assumed constant velocity over ``meas``, and what to do, for the message.

    Returns
    -------
    SanityWarning or None
    """
    test = leg_change_test(meas, result, options)
    if test is None or not test.manoeuvred:
        return None
    clock = clock_time(meas, test.change_time)
    when = f"t = {test.change_time:.0f} s" + (f" ({clock[11:19]} UTC)" if clock else "")
    kn = 3600.0 / 1852.0

    def leg(c: tuple[float, float]) -> str:
        return f"course {c[0]:.1f} deg, speed {c[1]:.3g} m/s ({c[1] * kn:.3g} kn)"

    return SanityWarning("target-manoeuvre", (
        f"the target manoeuvred inside the window of {subject}: a change of leg near {when} "
        f"explains the rows far better than a constant velocity (F = {test.statistic:.3g} on "
        f"{test.dof_num} and {test.dof_den} dof, p = {test.p_value:.2g} after searching "
        f"{test.times_searched} change times; the noise level is the larger fit's residuals, "
        f"not the stated sigma), and its final position and velocity lie outside the printed "
        f"95 % region (Mahalanobis distance squared {test.distance2:.3g} > {REGION_4D:.3g}). "
        + (f"It turns from {leg(test.start)} at the window's start to {leg(test.change)}, "
           "then holds that leg to the end. " if test.turn_first else
           f"It holds {leg(test.start)} until the change, then turns, reaching "
           f"{leg(test.end)} at "
           "the end. ")
        + (f"Even that fit's residuals run in long same-sign stretches (lag-1 correlation "
           f"{test.correlation:.2f}): more than one manoeuvre, or noise correlated in time, "
           "which would also make the printed ellipse too small. " if test.correlation
           > CORRELATED else "")
        + f"{subject[0].upper()}{subject[1:]} and its ellipse assume no manoeuvre and may not "
        f"hold the truth: {advice}"))
