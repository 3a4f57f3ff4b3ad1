"""Matrix products that keep OpenBLAS on one thread.

OpenBLAS splits a product over threads once ``m * n * k`` passes about 2.6e5; its threads then
busy-wait for the next call.  The products of tmakit's solvers are many and mid-sized, so on a
machine whose cores are already busy (Monte Carlo workers, other processes) the threads cost
far more than they gain: a 4e3 x 4 x 180 product took 5 ms with two threads on a loaded
two-core machine and 0.4 ms on one.  :func:`matmul` cuts a large product into row blocks below
that threshold.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

SINGLE_THREAD_WORK = 200_000
"""Largest ``m * n * k`` of one product (below OpenBLAS's multithreading threshold)."""


def matmul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Multiply ``a @ b`` in row blocks of ``a`` small enough for a single-threaded product.

    Parameters
    ----------
    a : numpy.ndarray
        Left factor ``(..., m, k)`` (any units).
    b : numpy.ndarray
        Right factor, 2-D ``(k, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        ``a @ b``, shape ``(..., m, n)``; equal to numpy's product (the blocks only split
        the rows).
    """
    k, n = b.shape
    rows = a.reshape(-1, k)
    block = max(1, SINGLE_THREAD_WORK // max(1, k * n))
    if rows.shape[0] <= block:
        return a @ b
    out = np.empty((rows.shape[0], n))
    for lo in range(0, rows.shape[0], block):
        np.matmul(rows[lo:lo + block], b, out=out[lo:lo + block])
    return out.reshape(*a.shape[:-1], n)
