"""Compiled piecewise-curvilinear propagation (optional ``numba``), with the NumPy path.

:class:`tmakit.motion.curvilinear_batch.ForwardPiecewise` spends nearly all of the manoeuvre
estimator's time (:mod:`tmakit.batch.manoeuvre`) in the closed form of a segment and its
derivatives at every sample, and in the chain rule to the parameters.  With ``numba``
installed (``pip install tmakit[fast]``) both run as the compiled loops of
:mod:`tmakit.motion.curvilinear_numba`; otherwise, with the environment variable
``TMAKIT_NO_NUMBA`` set to a non-empty value other than ``0``, or after
``use_compiled(False)``, :func:`available` is False and the NumPy path of
:mod:`tmakit.motion.curvilinear_closed` is used.  Both agree to rounding
(``tests/test_curvilinear_kernel.py``).  ``numba`` is imported, and the kernels compiled
(cached on disk), at the first call only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..arrays import Array, IntArray
from ..optional_kernels import OptionalKernels

#: The module's kernels (:mod:`tmakit.optional_kernels`).
KERNELS = OptionalKernels("curvilinear", lambda: _compile())
use_compiled = KERNELS.use_compiled
available = KERNELS.available


def _compile() -> dict[str, Callable[..., object]]:
    """Import ``numba`` and the kernels and compile them on tiny inputs (cached on disk)."""
    from . import curvilinear_normal_numba as kc
    from . import curvilinear_numba as kn

    theta = np.array([[0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.01, 0.01, 1.0]])
    t = np.array([0.5, 2.0])
    seg = np.empty((1, 2), dtype=np.int64)
    vals, par, d_anchor = np.empty((1, 2, 6)), np.empty((1, 2, 4, 7)), np.empty((1, 2, 4, 9))
    kn.piecewise(theta, t, 1, 0.0, np.inf, True, seg, vals, par, d_anchor)
    out = np.empty((1, 2, 9))
    kn.chain(np.ones((1, 2, 6)), par, seg, np.arange(2), d_anchor, 1, out)
    kn.chain_columns(np.ones((1, 2, 6)), par, seg, np.arange(2), d_anchor, 1,
                     np.arange(8), np.empty((8, 1, 2)))
    kn.scatter_states(vals, np.arange(2), np.empty((1, 2, 6)))
    kn.scatter_relative(vals, np.arange(2), np.zeros((2, 6)), np.empty((1, 2, 6)))
    for ds in (np.ones((1, 2, 6)), np.ones((1, 6, 2)).transpose(0, 2, 1)):  # rows or components
        kc.segment_normal(ds, np.ones((1, 2)), np.ones(2), par, seg, np.arange(2), d_anchor, 1,
                          np.zeros(1, dtype=np.int64), np.empty((1, 9, 9)), np.empty((1, 9)))
    return {"piecewise": kn.piecewise, "chain": kn.chain, "chain_columns": kn.chain_columns,
            "scatter": kn.scatter_states, "scatter_relative": kn.scatter_relative,
            "segment_normal": kc.segment_normal}


def piecewise(theta: Array, t: Array, manoeuvres: int, ref_time: float, end_time: float,
              partials: bool) -> tuple[IntArray, Array, Array | None, Array | None]:
    """Propagate a batch of piecewise curvilinear trajectories to the times ``t``, compiled.

    Parameters
    ----------
    theta : ndarray
        ``(B, p)`` parameters of :class:`~tmakit.motion.curvilinear_batch.ForwardPiecewise`
        (SI).
    t : ndarray
        ``(n,)`` times (s).
    manoeuvres : int
        The number of manoeuvres ``M``.
    ref_time, end_time : float
        Reference time and end of the admissible change-over times (s).
    partials : bool
        Whether the derivatives are wanted.

    Returns
    -------
    seg : ndarray of int
        ``(B, n)`` every sample's segment.
    values : ndarray
        ``(B, n, 6)`` ``(x, y, speed, course, vx, vy)`` (m, m, m/s, rad, m/s, m/s; NaN
        outside the model's domain).
    par : ndarray or None
        ``(B, n, 4, 7)`` ``d (x, y, vx, vy) / d (segment start x, y, speed, course, a_t, a_n,
        time since its start)``.
    d_anchor : ndarray or None
        ``(B, M + 1, 4, p)`` the derivatives of every segment's start state.

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    if not available():
        raise RuntimeError("the compiled curvilinear kernels are not available (numba)")
    theta = np.ascontiguousarray(theta, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    b, p = theta.shape
    seg = np.empty((b, t.size), dtype=np.int64)
    vals = np.empty((b, t.size, 6))
    par = np.empty((b, t.size, 4, 7)) if partials else np.empty((1, 1, 4, 7))
    d_anchor = np.empty((b, manoeuvres + 1, 4, p)) if partials else np.empty((1, 1, 4, p))
    KERNELS["piecewise"](theta, t, manoeuvres, ref_time, end_time, partials, seg,
                                   vals, par, d_anchor)
    return seg, vals, (par if partials else None), (d_anchor if partials else None)


def _rows(ds: Array, idx: IntArray | None) -> tuple[int, int, IntArray]:
    """Give the batch size, the rows and every row's unique time; refuse without the kernels."""
    if not available():
        raise RuntimeError("the compiled curvilinear kernels are not available (numba)")
    b, n = ds.shape[:2]
    return b, n, (np.arange(n) if idx is None else np.ascontiguousarray(idx, dtype=np.int64))


def chain(ds: Array, par: Array, seg: IntArray, idx: IntArray | None, d_anchor: Array,
          manoeuvres: int, columns: NDArray[np.int64] | None = None) -> Array:
    """Give ``d value / d theta`` ``(B, n, p)`` from ``d value / d state`` ``ds``, compiled.

    Parameters
    ----------
    ds : ndarray
        ``(B, n, 6)`` derivatives of some values with respect to the ENU state.
    par, seg, d_anchor : ndarray
        As :func:`piecewise` gives them at the unique times.
    idx : ndarray of int or None
        ``(n,)`` every row's unique time (None: the rows are the unique times).
    manoeuvres : int
        The number of manoeuvres ``M``.
    columns : ndarray of int, optional
        ``(q,)`` increasing: the derivatives with respect to these parameters only (the same
        values as those columns of the whole).

    Returns
    -------
    ndarray
        ``(B, n, p)``, or ``(B, n, q)`` with ``columns`` (each column contiguous in memory).

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    b, n, rows = _rows(ds, idx)
    ds = np.asarray(ds, dtype=float)
    if columns is not None:
        # each column contiguous over the rows: the layout of a column selection of the
        # whole (``jac[:, :, free]``), which the solver's J'J then reads as it is
        out = np.empty((columns.size, b, n))
        KERNELS["chain_columns"](ds, par, seg, rows, d_anchor, manoeuvres,
                                 np.ascontiguousarray(columns, dtype=np.int64), out)
        return out.transpose(1, 2, 0)
    out = np.empty((b, n, d_anchor.shape[-1]))
    KERNELS["chain"](ds, par, seg, rows, d_anchor, manoeuvres, out)
    return out


def segment_normal(ds: Array, r: Array, w: Array, par: Array, seg: IntArray, idx: IntArray | None,
                   d_anchor: Array, manoeuvres: int, runs: NDArray[np.int64] | None = None
                   ) -> tuple[Array, Array]:
    """Give ``J'J`` and ``J'r`` of the whitened Jacobian by segments, compiled.

    :func:`tmakit.motion.curvilinear_normal_numba.segment_normal`: the Jacobian (the
    :func:`chain` of ``ds``, whitened by ``w``) is not formed.

    Parameters
    ----------
    ds : ndarray
        ``(B, n, 6)`` derivatives of the predictions by the ENU state.
    r, w : ndarray
        ``(B, n)`` whitened residuals, ``(n,)`` inverse standard deviations.
    par, seg, idx, d_anchor, manoeuvres
        As for :func:`chain`.
    runs : ndarray of int, optional
        ``(R,)`` rows of the batch: the sums of these parameter vectors only, in this order
        (each the same bits as in the whole batch; default all).

    Returns
    -------
    (ndarray, ndarray)
        ``(R, p, p)`` and ``(R, p)`` (per parameter unit squared, per parameter unit).

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    b, _, rows = _rows(ds, idx)
    runs = np.arange(b) if runs is None else np.ascontiguousarray(runs, dtype=np.int64)
    p = d_anchor.shape[-1]
    jtj, jtr = np.empty((runs.size, p, p)), np.empty((runs.size, p))
    # (ds read in its own layout: the observation model's is component-major, no copy made)
    KERNELS["segment_normal"](np.asarray(ds, dtype=float), np.ascontiguousarray(r),
                              np.ascontiguousarray(w, dtype=float), par, seg, rows, d_anchor,
                              manoeuvres, runs, jtj, jtr)
    return jtj, jtr


def scatter_states(vals: Array, inv: IntArray, sensor: Array | None = None) -> Array:
    """Give ENU states ``(B, n, 6)`` of the rows from the values at the unique times, compiled.

    Parameters
    ----------
    vals : ndarray
        ``(B, nu, 6)`` ``(x, y, speed, course, vx, vy)`` (m, m, m/s, rad, m/s, m/s) as
        :func:`piecewise` gives them.
    inv : ndarray of int
        ``(n,)`` every row's unique time.
    sensor : ndarray, optional
        ``(n, 6)`` sensor states subtracted in the same pass (the same bits as after).

    Returns
    -------
    ndarray
        ``(B, n, 6)`` ``(x, y, 0, vx, vy, 0)`` (m, m/s; NaN outside the model's domain), minus
        ``sensor`` if given.

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    if not available():
        raise RuntimeError("the compiled curvilinear kernels are not available (numba)")
    out = np.empty((vals.shape[0], inv.shape[0], 6))
    inv = np.ascontiguousarray(inv, dtype=np.int64)
    if sensor is None:
        KERNELS["scatter"](vals, inv, out)
    else:
        KERNELS["scatter_relative"](vals, inv, np.ascontiguousarray(sensor, dtype=float), out)
    return out
