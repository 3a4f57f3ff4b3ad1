"""Matrix products that keep OpenBLAS on one thread.

:func:`matmul` cuts a large product into row blocks when asked (:func:`split_products` or
``TMAKIT_SPLIT_PRODUCTS=1``; off by default); :func:`one_thread` limits BLAS to one thread
around thin, large products.  Results do not depend on the thread count.
"""

from __future__ import annotations

import os
from contextlib import AbstractContextManager, nullcontext
from typing import Any

import numpy as np
from numpy.typing import NDArray

SINGLE_THREAD_WORK = 200_000
"""Largest ``m * n * k`` of one product (below OpenBLAS's multithreading threshold)."""

CHUNKED_ROWS = 1_000_000
"""Rows above which a fit with independent rows sums ``J'J`` and ``J'r`` over chunks of
:data:`CHUNK_ROWS` rows (no ``(n, p)`` Jacobian held)."""
CHUNK_ROWS = 1 << 17


_SPLIT = os.environ.get("TMAKIT_SPLIT_PRODUCTS", "") == "1"


def split_products(active: bool = True) -> None:
    """Have :func:`matmul` split large products into single-threaded row blocks (or not)."""
    global _SPLIT
    _SPLIT = bool(active)


def matmul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Multiply ``a @ b``, in single-threaded row blocks when :func:`split_products` asks."""
    if not _SPLIT:
        return a @ b
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


#: Rows from which, and most parameters for which, :func:`normal_rows` forms the normal
#: equations by dot products; the columns of one of its blocks (in a core's cache).
DOT_ROWS = 32_768
DOT_MOST_ROWS = 6
DOT_BLOCK = 16_384


def normal_rows(rows: NDArray[np.float64], r: NDArray[np.float64] | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Form ``J'J`` and ``J'r`` of a thin Jacobian held by rows, by dot products on one thread."""
    p, n = rows.shape
    jtj = np.zeros((p, p))
    jtr = None if r is None else np.zeros(p)
    with one_thread():
        for lo in range(0, n, DOT_BLOCK):
            block = rows[:, lo:lo + DOT_BLOCK]
            part = None if r is None else r[lo:lo + DOT_BLOCK]
            for i in range(p):
                row = block[i]
                if jtr is not None:
                    jtr[i] += row.dot(part)
                for k in range(i, p):
                    jtj[i, k] += row.dot(block[k])
    upper = np.triu_indices(p, 1)
    jtj[upper[1], upper[0]] = jtj[upper]
    return jtj, jtr


def by_dots(jacobian: NDArray[np.float64]) -> bool:
    """Tell whether :func:`normal_rows` forms the normal equations of ``jacobian`` ``(n, p)``."""
    n, p = jacobian.shape
    return (n >= DOT_ROWS and p <= DOT_MOST_ROWS and jacobian.dtype == np.float64
            and jacobian.T.flags.c_contiguous)


_CONTROLLER: Any = None


def one_thread(active: bool = True) -> AbstractContextManager[object]:
    """Give a context in which BLAS runs on one thread (``threadpoolctl``)."""
    global _CONTROLLER
    if not active:
        return nullcontext()
    if _CONTROLLER is None:
        import scipy.linalg  # noqa: F401  (load SciPy's BLAS before the controller looks)
        from threadpoolctl import ThreadpoolController

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")
