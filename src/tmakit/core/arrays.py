"""Array types for annotations, defined once for the whole package.

``Array`` is a float64 NumPy array of any shape; the shapes and units of each argument are in
the docstring of the function that takes it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Array", "BoolArray", "IntArray", "broadcast", "finite_range", "row_labels",
           "take_rows", "zeros_broadcast"]

#: A float64 array (shapes and units are given where it is used).
Array = NDArray[np.float64]
#: An array of integers (row indices, codes, segment numbers).
IntArray = NDArray[np.integer[Any]]
#: An array of booleans (masks).
BoolArray = NDArray[np.bool_]


def broadcast(column: NDArray[np.generic]) -> bool:
    """Tell whether ``column`` holds one value for every row (a zero-stride broadcast)."""
    return column.ndim > 0 and column.strides[0] == 0


def finite_range(values: Array) -> tuple[float, float] | None:
    """Give the least and greatest finite values (None if none), copying nothing when all are."""
    if not values.size:
        return None
    low, high = float(np.min(values)), float(np.max(values))
    if not (math.isfinite(low) and math.isfinite(high)):  # (a NaN gives NaN to both)
        finite = values[np.isfinite(values)]
        if not finite.size:
            return None
        low, high = float(finite.min()), float(finite.max())
    return low, high


_ZERO = np.zeros(1)
_ZERO.flags.writeable = False


def zeros_broadcast(shape: tuple[int, ...]) -> Array:
    """Give ``np.broadcast_to(0.0, shape)`` (read-only zeros) at a fifth of its cost."""
    return np.ndarray(shape, buffer=_ZERO, strides=(0,) * len(shape))


def take_rows(column: Array, rows: NDArray[np.intp]) -> Array:
    """Give ``column``'s ``rows``; a broadcast column stays one (no memory per row)."""
    if broadcast(column):
        m = rows.shape[0]
        if m <= column.shape[0] and not column.flags.writeable:
            return column[:m]  # every row the same: a slice is the broadcast (no call)
        return np.broadcast_to(column[:1], (m, *column.shape[1:]))
    return np.take(column, rows, 0)


def row_labels(key: Array) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Label the distinct rows of ``key (m, k)`` 0, 1, ... in lexicographic order.

    Gives each row's label and each label's count: ``np.unique(key, axis=0,
    return_inverse=True, return_counts=True)[1:]`` without its structured view, whose fixed
    cost dominates on the few rows of one time's differences (a NaN row is its own label).
    """
    m = key.shape[0]
    if m == 0:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    order = np.lexsort(key.T[::-1])
    ordered = key[order]
    new = np.ones(m, dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    label = np.empty(m, dtype=np.intp)
    label[order] = np.cumsum(new) - 1
    return label, np.diff(np.flatnonzero(np.append(new, True)))
