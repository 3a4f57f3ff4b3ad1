"""The profile grid of the change-over times.

Tuples of grid times, their local minima, and the warm start that splits a segment in two.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from ...core.arrays import Array


def grid_tuples(grid: Array, m: int, min_gap: float) -> NDArray[np.int64]:
    """Index tuples ``i_1 < ... < i_m`` into ``grid`` whose times are ``min_gap`` apart."""
    if m == 0:
        return np.zeros((1, 0), dtype=np.int64)
    out = [c for c in itertools.combinations(range(grid.size), m)
           if m == 1 or np.all(np.diff(grid[list(c)]) >= min_gap - 1e-9)]
    return np.array(out, dtype=np.int64).reshape(-1, m)


def split_segment(theta: Array, m_prev: int, j: int, t_new: Array) -> Array:
    """Insert a change-over time into fits, splitting a segment in two."""
    b = theta.shape[0]
    acc = theta[:, 4:6 + 2 * m_prev].reshape(b, m_prev + 1, 2)
    acc = np.concatenate([acc[:, :j + 1], acc[:, j:j + 1], acc[:, j + 1:]], axis=1)
    times = np.insert(theta[:, 6 + 2 * m_prev:], j, t_new, axis=1)
    return np.concatenate([theta[:, :4], acc.reshape(b, -1), times], axis=1)


def local_minima(tuples: NDArray[np.int64], cost: Array) -> NDArray[np.int64]:
    """Find the rows of ``tuples`` that are local minima of the cost, best first."""
    where = {tuple(t): i for i, t in enumerate(tuples)}
    keep = []
    for i, t in enumerate(tuples):
        if not np.isfinite(cost[i]):
            continue
        ok = True
        for k in range(tuples.shape[1]):
            for d in (-1, 1):
                nb = list(t)
                nb[k] += d
                other = where.get(tuple(nb))
                if other is not None and cost[other] < cost[i]:
                    ok = False
        if ok:
            keep.append(i)
    keep_arr = np.array(keep, dtype=np.int64)
    return keep_arr[np.argsort(cost[keep_arr])] if keep_arr.size else keep_arr
