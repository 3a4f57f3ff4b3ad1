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

    Splitting rows does not change any sum.

    Parameters
    ----------
    a : numpy.ndarray
        Left factor ``(..., m, k)`` (any units).
    b : numpy.ndarray
        Right factor: 2-D ``(k, n)`` (the rows of every leading index of ``a`` are then split
        together), or a batch ``(..., k, n)`` matching ``a``'s leading axes (the ``m`` rows
        of each are split) (any units).

    Returns
    -------
    numpy.ndarray
        ``a @ b``, shape ``(..., m, n)``; equal to numpy's product (the blocks only split
        the rows).
    """
    k, n = b.shape[-2:]
    rows = a.reshape(-1, k) if b.ndim == 2 else a
    count = rows.shape[-2]
    block = max(1, SINGLE_THREAD_WORK // max(1, k * n))
    if count <= block:
        return a @ b
    out = np.empty((*rows.shape[:-1], n))
    for lo in range(0, count, block):
        np.matmul(rows[..., lo:lo + block, :], b, out=out[..., lo:lo + block, :])
    return out.reshape(*a.shape[:-1], n)
