"""Frame and angle conventions, written once.

Local ENU frame in metres (2-D: z = 0); bearings and courses clockwise from North,
``atan2(d_east, d_north)`` (Hörst & Oispuu (2010), eq. 6); papers' counter-clockwise-from-East
angles (Gu et al. (2007), Chen & Sun) are converted once, where a scenario file is read
(``angle_convention = "east_ccw"``).  Relative state = target minus sensor; angle residuals wrap
to (-pi, pi].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

TWO_PI = 2.0 * np.pi
"""A turn (rad), as the float ``2 * np.pi`` (twice ``np.pi`` exactly)."""


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to the interval (-pi, pi]."""
    out = np.array(angle, dtype=float, order="C")
    if out.ndim == 0:
        return np.array(_wrap_moved(out.reshape(1))[0])
    flat = out.reshape(-1)  # a view: out is a new C-contiguous array (not so from order "K")
    moved = np.flatnonzero((flat > np.pi) | (flat <= -np.pi))
    if moved.size:
        flat[moved] = _wrap_moved(flat[moved])
    return out


def _wrap_moved(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrap angles ``(m,)`` of :func:`wrap_angle` (those out of the interval: a new array)."""
    w = np.where(v > np.pi, v - TWO_PI, np.where(v <= -np.pi, v + TWO_PI, v))
    far = (w > np.pi) | (w <= -np.pi)  # more than a turn out (NaN never is)
    if far.any():
        m = np.mod(v[far] + np.pi, TWO_PI) - np.pi
        m[m == -np.pi] = np.pi  # mod maps +pi to -pi; the convention keeps +pi
        w[far] = m
    return w


_LOWEST, _HIGHEST = np.minimum.reduce, np.maximum.reduce


def wrap_angle_own(e: NDArray[np.float64], in_place: bool = False) -> NDArray[np.float64]:
    """Return :func:`wrap_angle` of ``e``, the same bits, in place where it can."""
    if not e.size:
        return wrap_angle(e)
    low, high = float(_LOWEST(e, None)), float(_HIGHEST(e, None))  # (axis=None: all)
    # a - 2 pi is exact for a in [pi, 4 pi] (Sterbenz): the tests hold for the shifted rows
    if not (high - TWO_PI <= np.pi and low + TWO_PI > -np.pi):  # (NaN fails too)
        return wrap_angle(e)
    out = e if in_place else e.copy()
    # (a masked ufunc: one pass, no gather and scatter of the rows out)
    if high > np.pi:
        np.subtract(out, TWO_PI, out=out, where=out > np.pi)
    if low <= -np.pi:
        np.add(out, TWO_PI, out=out, where=out <= -np.pi)
    return out
