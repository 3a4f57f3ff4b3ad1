"""Blocks of pyarrow columns as numpy arrays, and their memory given back to the system.

Used by the streaming CSV reader (:mod:`.csv_stream`): no pandas import (pyarrow's own
conversions of columns with nulls import it: 39 MB of memory, whatever the file's size).
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["give_back", "malloc_trim", "numbers", "with_nan"]


def give_back() -> None:
    """Return the memory of dropped blocks to the system (pyarrow's pool and the C library's).

    Without this, pyarrow's allocator and the C library's keep freed blocks (their sum grows
    with the file: about 130 bytes per row at 3 million rows), and the peak is theirs.
    """
    import pyarrow as pa

    pa.default_memory_pool().release_unused()
    trim = malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def malloc_trim() -> Any:
    """Find the C library's ``malloc_trim`` (glibc).

    Returns
    -------
    ctypes function or None
        ``malloc_trim(pad)``; None where there is none.
    """
    try:
        return ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError):
        return None


def with_nan(col: Any) -> NDArray[np.float64]:
    """Return a pyarrow float64 array as numpy, NaN where null.

    From its buffers: ``col.to_numpy(zero_copy_only=False)`` and ``pyarrow.compute.fill_null``
    import pandas (39 MB more memory, half a second).

    Parameters
    ----------
    col : pyarrow.Array
        A float64 column (any unit).

    Returns
    -------
    numpy.ndarray
        Its values (same unit): a read-only view without nulls, else a copy with NaN.
    """
    values = numbers(col, np.float64)
    if not col.null_count:
        return values
    bits = np.frombuffer(col.buffers()[0], dtype=np.uint8)
    valid = np.unpackbits(bits, bitorder="little")[col.offset:col.offset + len(col)]
    return np.where(valid.view(bool), values, np.nan)


def numbers(col: Any, dtype: type) -> NDArray[Any]:
    """View a pyarrow array without nulls as numpy (no copy, and no pandas import).

    Parameters
    ----------
    col : pyarrow.Array
        A column of fixed-width numbers without nulls.
    dtype : type
        Its numpy type (``np.float64``, ``np.int32``).

    Returns
    -------
    numpy.ndarray
        A read-only view of its values.
    """
    return np.frombuffer(col.buffers()[1], dtype=dtype, count=len(col),
                         offset=col.offset * np.dtype(dtype).itemsize)
