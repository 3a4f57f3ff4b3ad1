"""Array types for annotations, defined once for the whole package.

``Array`` is a float64 NumPy array of any shape; the shapes and units of each argument are in
the docstring of the function that takes it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Array", "BoolArray", "IntArray", "broadcast", "take_rows", "zeros_broadcast"]

#: A float64 array (shapes and units are given where it is used).
Array = NDArray[np.float64]
#: An array of integers (row indices, codes, segment numbers).
IntArray = NDArray[np.integer[Any]]
#: An array of booleans (masks).
BoolArray = NDArray[np.bool_]


def broadcast(column: NDArray[np.generic]) -> bool:
    """Tell whether ``column`` holds one value for every row (a zero-stride broadcast)."""
    return column.ndim > 0 and column.strides[0] == 0


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
