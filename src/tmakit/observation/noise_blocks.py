"""The correlated noise blocks of a set of rows, one per group of overlapping spans.

TDOA/FDOA rows sharing a reference at one time form a block; range differences whose spans
share pulse intervals (Chen & Sun, eq. 1) form a group, found in ``O(m log m)``.  The
covariance is block-diagonal by group.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from ..measurements import MeasurementModel

__all__ = ["MAX_GROUP_ROWS", "correlated_blocks", "overlapping_groups",
           "shared_reference_groups"]

Index = NDArray[np.intp] | slice

#: Most rows of one sensor whose spans overlap in one chain (one dense correlated noise block;
#: its covariance and eigen-decomposition take about 5 * 8 * n^2 bytes and n^3 operations).
MAX_GROUP_ROWS = 4096


def overlapping_groups(rows: NDArray[np.intp], time: Array, time_ref: Array,
                       singletons: bool = True) -> Iterator[NDArray[np.intp]]:
    """Split rows into groups whose spans ``(time_ref, time]`` overlap (transitively)."""
    if rows.shape[0] == 0:
        return
    order = np.argsort(time_ref[rows], kind="stable")
    start, end = time_ref[rows][order], time[rows][order]
    # a new group starts where a span begins at or after the end of every earlier span
    reach = np.maximum.accumulate(end)
    cut = np.flatnonzero(start[1:] >= reach[:-1]) + 1
    bounds = np.concatenate(([0], cut, [rows.shape[0]]))
    for lo, hi in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
        if hi - lo > 1 or singletons:
            yield np.sort(rows[order[lo:hi]])


def shared_reference_groups(rows: NDArray[np.intp], time: Array, ref_state: Array | None,
                            singletons: bool = True) -> Iterator[NDArray[np.intp]]:
    """Split differences between sensors into the groups at one time with one reference."""
    if rows.shape[0] == 0:
        return
    key = time[rows][:, None]
    if ref_state is not None:
        key = np.concatenate([key, ref_state[rows, :3]], axis=1)
    _, label = np.unique(key, axis=0, return_inverse=True)
    order = np.argsort(label.ravel(), kind="stable")
    cuts = np.flatnonzero(np.diff(label.ravel()[order])) + 1
    for g in np.split(order, cuts):
        if g.shape[0] > 1 or singletons:
            yield rows[np.sort(g)]


def correlated_blocks(models: Mapping[str, MeasurementModel], index: Mapping[str, Index],
                      time: Array, time_ref: Array, sigma: Array, sensor: NDArray[Any],
                      singletons: bool = True, ref_state: Array | None = None
                      ) -> list[tuple[NDArray[np.intp], Array]]:
    """Return the correlated noise blocks of a set of rows."""
    blocks: list[tuple[NDArray[np.intp], Array]] = []
    m = time.shape[0]
    for kind, model in models.items():
        if not model.correlated_noise:
            continue
        rows = np.arange(m)[index[kind]]
        if model.between_sensors:
            for g in shared_reference_groups(rows, time, ref_state, singletons):
                _check_group_size(g.shape[0])
                blocks.append((g, model.noise_covariance(time[g], time_ref[g], sigma[g])))
            continue
        for s in np.unique(sensor[rows]):
            own = rows[sensor[rows] == s]
            for g in overlapping_groups(own, time, time_ref, singletons):
                _check_group_size(g.shape[0])
                blocks.append((g, model.noise_covariance(time[g], time_ref[g], sigma[g])))
    return blocks


def _check_group_size(n: int) -> None:
    """Refuse one chain of overlapping rows too large for a dense covariance."""
    if n > MAX_GROUP_ROWS:
        raise ValueError(
            f"{n:,} range differences of one sensor share pulse intervals (their spans "
            f"time_ref..time overlap in one chain, e.g. one time_ref for all): their noise is "
            f"one dense {n:,} x {n:,} covariance, more than the limit of {MAX_GROUP_ROWS:,} "
            "rows (its memory grows with the square, its time with the cube); use differences "
            "between consecutive samples, or fewer rows (--from/--to)")
