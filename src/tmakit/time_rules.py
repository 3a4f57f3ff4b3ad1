"""The rules of time: how far from the time origin, and from the other times, a time may be.

Part of the one set of rules of a measurement set (:mod:`tmakit.rules`, which re-exports
these): a time beyond :data:`tmakit.units.TIME_LIMIT_S` is in another unit or garbage; a time
far outside the bulk of the others is a typo, another unit or another clock; a time asked
for (an answer's, a reference time) far from the data would be extrapolated beyond use.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .units import TIME_LIMIT_S

__all__ = ["OUTLIER_SPANS", "TIME", "far_times", "time_problem", "time_reach",
           "time_within_limit"]

#: What a time must be (s).
TIME = (f"a time within [-{TIME_LIMIT_S:g}, {TIME_LIMIT_S:g}] s of the time origin (317 years; "
        "epoch milliseconds or nanoseconds must be given as seconds)")
#: A time farther than this many spans of the other times (at least :data:`_MIN_SPAN_S`)
#: from them is refused (:func:`far_times`): a typo, another unit or another clock.
OUTLIER_SPANS = 100.0
_MIN_SPAN_S = 100.0


def time_within_limit(time: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Tell where times (s) lie within :data:`tmakit.units.TIME_LIMIT_S` of the origin.

    Parameters
    ----------
    time : ndarray
        Times (s).

    Returns
    -------
    ndarray of bool
        False for a time beyond the limit (or NaN).
    """
    return np.abs(time) <= TIME_LIMIT_S


def far_times(time: NDArray[np.float64]) -> tuple[NDArray[np.bool_], str]:
    """Find the times that lie far outside the span of the others (a typo, another unit).

    The bulk of the times is their central half (from the first to the third quartile, in
    row counts); a time more than :data:`OUTLIER_SPANS` times the bulk's span (at least
    100 s) before or after it is far.  Sessions of a log a day apart are not far from each
    other; one time in milliseconds among seconds, or a 1e9 typed for a 1e3, is.

    Parameters
    ----------
    time : ndarray
        Times (s); non-finite ones are left out (another rule names them).

    Returns
    -------
    far : ndarray of bool
        The far rows.
    expected : str
        What a time was expected to be (for messages), empty when none is far.
    """
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(time)
        t = time if finite.all() else time[finite]
        n = t.size
        if n < 4 or float(t.max()) - float(t.min()) <= OUTLIER_SPANS * _MIN_SPAN_S:
            return np.zeros(time.shape, dtype=bool), ""
        i25, i75 = (n - 1) // 4, n - 1 - (n - 1) // 4
        if bool(np.all(t[1:] >= t[:-1])):  # in order already (one sensor): no copy
            low, high = float(t[i25]), float(t[i75])
        else:
            part = np.partition(t, (i25, i75))
            low, high = float(part[i25]), float(part[i75])
        reach = OUTLIER_SPANS * max(high - low, _MIN_SPAN_S)
        far = finite & ((time < low - reach) | (time > high + reach))
    if not far.any():
        return far, ""
    return far, (f"a time within {OUTLIER_SPANS:g} spans of the bulk of the times (their "
                 f"central half lies within {low:.10g} .. {high:.10g} s; a typo, another "
                 "unit or another clock)")


def time_reach(times: NDArray[np.float64]) -> tuple[float, float, float] | None:
    """Give the data's first and last time and how far from them a time may be asked for.

    A reference time or an answer's time more than :data:`OUTLIER_SPANS` spans of the data
    (at least 100 s) from them is refused: the positions there depend on the velocities that
    many times over (an answer at 1e12 s would be 1e12 s of extrapolation).

    Parameters
    ----------
    times : array_like
        The measurement times (s).

    Returns
    -------
    (low, high, reach) or None
        The first and last finite time and the reach (s); None without a finite time.
    """
    t = np.asarray(times, dtype=float)
    t = t[np.isfinite(t)]
    if not t.size:
        return None
    low, high = float(t.min()), float(t.max())
    return low, high, OUTLIER_SPANS * max(high - low, 1.0)


def time_problem(time: float, times: NDArray[np.float64] | None, what: str) -> str | None:
    """Say why a time asked for (an answer's, a reference time) cannot be used, or None.

    Parameters
    ----------
    time : float
        The time (s).
    times : array_like or None
        The measurement times (s); None: only finiteness is checked.
    what : str
        What the time is, for the message (``--at``, ``time``).

    Returns
    -------
    str or None
        The problem (not finite, or beyond :func:`time_reach` of the data), None when fine.
    """
    if not math.isfinite(time):
        return f"{what} {time}: expected a finite time (s)"
    found = None if times is None else time_reach(times)
    if found is None:
        return None
    low, high, reach = found
    if low - reach <= time <= high + reach:
        return None
    far = time - high if time > high else low - time
    return (f"{what} {time:.15g}: {far:.6g} s from the measurements (t = {low:.15g} ... "
            f"{high:.15g} s), more than {reach:.6g} s ({OUTLIER_SPANS:g} spans of the data); "
            f"the positions at a time that far depend on the velocities {far:.3g} times over")
