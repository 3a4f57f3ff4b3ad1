"""A sensor's state at given times, looked up along its rows of a measurement file.

The state of a range difference's reference sample at ``time_ref``: the sensor's own row at that
time (the first one), else interpolated between its rows as :class:`tmakit.sensors.RecordedTrack`
does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["QUERY_ROWS", "SensorRecord"]

#: Times looked up at a time (bounds the temporaries of a look-up: about 100 bytes each).
QUERY_ROWS = 1 << 16


def _non_decreasing(t: NDArray[np.float64]) -> bool:
    """Tell whether ``t`` never decreases (NaN: no), checked a block at a time."""
    for lo in range(0, max(t.shape[0] - 1, 0), QUERY_ROWS):
        seg = t[lo:lo + QUERY_ROWS + 1]
        if not np.all(seg[1:] >= seg[:-1]):
            return False
    return True


class SensorRecord:
    """A sensor's usable rows in time order, to look its state up at given times.

    Parameters
    ----------
    t : numpy.ndarray
        Every row's time (s).
    state : numpy.ndarray, shape (n, 6)
        Every row's sensor state (ENU m, m/s).
    mine : numpy.ndarray of int or None
        The sensor's usable rows in file order; None for every row.
    has_velocity : bool
        The file gives sensor velocities (else interpolated velocities are 0).
    """

    def __init__(self, t: NDArray[np.float64], state: NDArray[np.float64],
                 mine: NDArray[np.intp] | None, has_velocity: bool) -> None:
        times = t if mine is None else t[mine]
        self.state, self.has_velocity = state, has_velocity
        # row of the file of each entry of self.times (None: the entry's own index)
        self.index: NDArray[np.intp] | None = mine
        if not _non_decreasing(times):  # one entry per time (the first row), in time order
            times, first = np.unique(times, return_index=True)
            self.index = first if mine is None else mine[first]
        #: The sensor's times (s), non-decreasing (a time may repeat).
        self.times: NDArray[np.float64] = times
        self._spline: Any = None

    def _rows(self, k: NDArray[np.intp]) -> NDArray[np.intp]:
        """Give the file rows of entries ``k`` of :attr:`times`."""
        return k if self.index is None else self.index[k]

    def fill(self, rows: NDArray[np.intp], time_ref: NDArray[np.float64],
             ref: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Fill ``ref[rows]`` with the state at ``time_ref[rows]``; flag rows without one."""
        missing = np.ones(rows.shape[0], dtype=bool)
        m = self.times.shape[0]
        if m == 0:
            return missing
        for lo in range(0, rows.shape[0], QUERY_ROWS):
            r = rows[lo:lo + QUERY_ROWS]
            tr = time_ref[r]
            at = np.searchsorted(self.times, tr)  # the first entry at or after time_ref
            found = self.times[np.minimum(at, m - 1)] == tr
            ref[r[found]] = self.state[self._rows(at[found])]
            inside = ~found & (tr >= self.times[0]) & (tr <= self.times[-1])
            if np.any(inside):
                ref[r[inside]] = self._between(at[inside], tr[inside])
            missing[lo:lo + QUERY_ROWS] = ~found & ~inside
        return missing

    def _between(self, at: NDArray[np.intp], tr: NDArray[np.float64]) -> NDArray[np.float64]:
        """Interpolate at times ``tr`` strictly between entries ``at - 1`` and ``at``."""
        from ..sensors import RecordedTrack

        if self.has_velocity:  # cubic Hermite: each piece from its two rows only
            before = np.searchsorted(self.times, self.times[at - 1])  # first of that time
            k = np.unique(np.concatenate((before, at)))
            rows = self._rows(k)
            return RecordedTrack(self.times[k], self.state[rows, :3],
                                 self.state[rows, 3:]).states(tr)
        if self._spline is None:  # a spline through every distinct time
            t = self.times
            k = np.flatnonzero(np.concatenate(([True], t[1:] != t[:-1])))
            self._spline = RecordedTrack(t[k], self.state[self._rows(k), :3])
        out = self._spline.states(tr)
        out[:, 3:] = 0.0  # like the sensor velocities, absent from the file
        return out
