"""The initial window a batch start is estimated over.

A batch estimate over the first ``k`` distinct times is a good start when it converged, every
state component is observable and the position's largest 1-sigma semi-axis is below
``max_relative_std`` times the range (a bearings-only EKF started at 70 % diverges, at 25 % it
stays consistent: ``docs/tracking.md``).  :func:`search_window` doubles the window from
``min_window`` until it qualifies, then bisects down to the shortest that does.  With
``fit_p_value`` > 0 a window whose fit's chi-square p-value is below it is no start either.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..batch import estimate
from ..data import MeasurementSet
from ..filters import group_times
from ..motion import ConstantVelocity
from ..results.estimate import EstimateResult
from .errors import StartError, TrackingError

__all__ = ["MIN_WINDOW", "WindowChoice", "WindowEstimate", "search_window"]

#: The smallest initial window tried (distinct measurement times).
MIN_WINDOW = 8


@dataclass(frozen=True)
class WindowEstimate:
    """The batch estimate over one initial window.

    Parameters
    ----------
    window : int
        Distinct measurement times in the window.
    time : float
        Its last time (s), the estimate's reference time.
    rows : int
        Rows in the window.
    estimate : EstimateResult or None
        The estimate; ``None`` when the estimator refused the window.
    relative_position_std : float
        Largest 1-sigma position semi-axis over the range to the nearest sensor (``inf``
        when the estimate is not a start).
    problem : str
        Why the estimate is not a start ("" when it is converged and observable).
    """

    window: int
    time: float
    rows: int
    estimate: EstimateResult | None
    relative_position_std: float
    problem: str


@dataclass(frozen=True)
class WindowChoice:
    """The window a search chose, and how many it estimated.

    Parameters
    ----------
    chosen : WindowEstimate
        The window (its estimate is converged and observable).
    windows_tried : int
        Windows estimated by the search.
    """

    chosen: WindowEstimate
    windows_tried: int


def _relative_std(result: EstimateResult, rows: MeasurementSet, time: float, dim: int
                  ) -> float | None:
    """Return the position's largest 1-sigma semi-axis over the range to the nearest sensor."""
    theta = result.estimate
    motion = result.motion
    state = motion.states(theta, np.array([time]))[0]
    jac = motion.jacobian(theta, np.array([time]))[0][list(range(dim))]
    cov = jac @ result.covariance @ jac.T
    if not np.all(np.isfinite(cov)):
        return None
    last = np.abs(rows.time - rows.time.max()) < 1e-9
    ranges = np.linalg.norm(state[None, :dim] - rows.sensor_state[last][:, :dim], axis=1)
    rng = float(np.min(ranges))
    major = float(np.sqrt(max(np.max(np.linalg.eigvalsh(cov)), 0.0)))
    return major / rng if rng > 0 else np.inf


class _Windows:
    """The batch estimates of the initial windows of one set, each computed once."""

    def __init__(self, meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None, fit_p_value: float = 0.0
                 ) -> None:
        self.meas, self.dim, self.options, self.fit_p_value = meas, dim, options, fit_p_value
        self.groups = group_times(meas)
        self.tried: dict[int, WindowEstimate] = {}

    def __len__(self) -> int:
        return len(self.groups)

    def __call__(self, k: int) -> WindowEstimate:
        if k not in self.tried:
            rows = self.meas.take(np.concatenate(self.groups[:k]))
            time = float(rows.time.max())
            try:
                result = estimate(rows, ConstantVelocity(self.dim, time), options=self.options)
            except ValueError as e:  # e.g. no finite starting point on a tiny window
                self.tried[k] = WindowEstimate(k, time, len(rows), None, np.inf, f"failed: {e}")
            else:
                rel = (_relative_std(result, rows, time, self.dim)
                       if result.status == "converged" else None)
                problem = "" if rel is not None else result.status + (
                    f": {result.message}" if result.message else "")
                p = result.chi2_p_value
                if not problem and p is not None and p < self.fit_p_value:
                    rel, problem = None, (f"an improbable fit (chi2 {result.chi2:.4g} on "
                                          f"{result.dof} dof, p = {p:.2g})")
                self.tried[k] = WindowEstimate(k, time, len(rows), result,
                                               np.inf if rel is None else rel, problem)
        return self.tried[k]

    def choice(self, k: int) -> WindowChoice:
        return WindowChoice(self(k), len(self.tried))

    def no_start(self, max_relative_std: float) -> StartError:
        """Build the error when no window qualifies: the best one, and the ways out."""
        usable = [(w.relative_position_std, k) for k, w in self.tried.items()
                  if np.isfinite(w.relative_position_std)]
        fits = [w.problem for w in self.tried.values() if w.problem.startswith("an impr")]
        tried = f"{len(self.tried)} windows of up to {len(self)} measurement times tried"
        if fits and not usable:
            return StartError(
                f"cannot start the filter from the data: every converged window's estimate is "
                f"{fits[-1]} ({tried}): the data are not one target in constant velocity with "
                "the stated sigmas; look for clutter or a manoeuvre, check the sigmas, or "
                "give a prior ({prior}/{prior_std})", "prior", ["prior", "prior_std"])
        if usable:
            rel, kk = min(usable)
            detail = (f"the best converged, observable window ({kk} measurement times) "
                      f"has a position std of {rel:.0%} of the range")
        else:
            detail = "no window gave a converged, observable estimate"
        flat = ("; the track is 3-D: if the sensors move on a surface the height is not "
                "observable, track in 2-D ({dim} 2)" if self.dim == 3 else "")
        return StartError(
            f"cannot start the filter from the data: {detail}, and the start needs less "
            f"than {max_relative_std:.0%} ({tried}); "
            "give a prior ({prior}/{prior_std}) or relax the start quality "
            "({max_relative_std})" + flat, "prior",
            ["prior", "prior_std", "max_relative_std", *(["dim"] if flat else [])])


def search_window(meas: MeasurementSet, dim: int,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  init_window: int | None = None, max_relative_std: float = 0.25, *,
                  min_window: int = MIN_WINDOW, fit_p_value: float = 0.0) -> WindowChoice:
    """Return the initial window a batch start uses.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    dim : int
        Spatial dimension, 2 or 3.
    options : mapping, optional
        Per-kind measurement-model options.
    init_window : int, optional
        Use exactly this many distinct measurement times (the estimate must then converge
        and be observable); by default the shortest that is good enough.
    max_relative_std : float
        The start quality: position std over range must be below it (used in the search).
    min_window : int
        The first window tried by the search (distinct measurement times).
    fit_p_value : float
        A window whose fit's chi-square p-value is below it is no start (0: no test).

    Returns
    -------
    WindowChoice
        The window and its estimate.

    Raises
    ------
    TrackingError
        An empty set, or ``init_window`` outside 1 .. the number of times.
    StartError
        The chosen window's estimate is no start, or no window qualifies.
    """
    windows = _Windows(meas, dim, options, fit_p_value)
    n = len(windows)
    if n == 0:
        raise TrackingError("the measurement set is empty: nothing to track")
    if init_window is not None:
        if int(init_window) != init_window or not 1 <= init_window <= n:
            raise TrackingError(f"init_window: expected a whole number of measurement times "
                                f"from 1 to {n}, got {init_window}", "init_window")
        k = int(init_window)
        w = windows(k)
        if w.problem:
            verb = "" if w.problem.startswith("failed") else "is "
            raise StartError(f"the batch estimate over the first {k} measurement times "
                             f"(t <= {w.time:g} s) {verb}{w.problem}; use a longer window or "
                             "give a prior", "init_window")
        return windows.choice(k)
    if not max_relative_std > 0:
        raise TrackingError(f"max_relative_std must be > 0, got {max_relative_std}",
                            "max_relative_std")

    def good(k: int) -> bool:
        return windows(k).relative_position_std < max_relative_std

    # Double the window until it qualifies, then bisect down to the shortest that does.
    k = min(max(int(min_window), 1), n)
    bad = k - 1
    while not good(k):
        if k == n:
            raise windows.no_start(max_relative_std)
        bad = k
        k = min(2 * k, n)
    while k - bad > 1:
        mid = (k + bad) // 2
        if good(mid):
            k = mid
        else:
            bad = mid
    return windows.choice(k)
