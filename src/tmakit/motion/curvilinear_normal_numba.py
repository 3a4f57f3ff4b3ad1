"""The normal equations of piecewise curvilinear motion by segments (``numba``).

Imported by :mod:`tmakit.motion.curvilinear_compiled`.  A row in segment ``s`` depends on the
parameters through seven inputs of that segment: its start state ``(x, y, speed, course)``,
its two accelerations and its start time.  Its Jacobian row is ``J_i = D_s' v_i``: ``v_i`` the
row's derivatives by those inputs (seven numbers, from the sample's partials), ``D_s`` ``(7,
p)`` the inputs' derivatives by the parameters (the start state's, unit rows for the
accelerations, minus one for the change-over time).  So

    J'J = sum_s D_s' (sum_{i in s} v_i v_i') D_s,    J'r = sum_s D_s' (sum_{i in s} v_i r_i)

and only ``7 x 7`` sums are made per row, not the ``p`` columns of the Jacobian and their
``p (p + 1) / 2`` products (:func:`tmakit.motion.curvilinear_numba.chain_columns` gives the
same columns).  Sums in a fixed order: the same inputs give the same bits.
"""

from __future__ import annotations

import numba
import numpy as np

from ..arrays import Array, IntArray

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
# Inlined into the loop over the samples (as a call, every array argument's reference count
# would change twice per sample: more than the arithmetic).
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@_inline
def _inputs(ds: Array, par: Array, d_anchor: Array, b: int, i: int, u: int, sg: int,
            own: int, w: float, v: Array) -> None:  # pragma: no cover - compiled
    """Write row ``i``'s whitened derivatives by its segment's inputs into ``v``.

    ``v[6]`` is the row's whole derivative by the segment's own change-over time ``own``
    (column of the parameters; -1 for the first segment): through the start state and, with a
    minus sign, the time since the start.  The two nearly cancel (the trajectory is continuous
    through a change-over), so they are subtracted here, row by row, not in the sums.
    """
    d0, d1, d3, d4 = ds[b, i, 0] * w, ds[b, i, 1] * w, ds[b, i, 3] * w, ds[b, i, 4] * w
    v[0] = d0
    v[1] = d1
    for k in range(2, 7):
        v[k] = d0 * par[b, u, 0, k] + d1 * par[b, u, 1, k] + d3 * par[b, u, 2, k] \
            + d4 * par[b, u, 3, k]
    if own >= 0:
        v[6] = (d0 * d_anchor[b, sg, 0, own] + d1 * d_anchor[b, sg, 1, own]
                + v[2] * d_anchor[b, sg, 2, own] + v[3] * d_anchor[b, sg, 3, own]) - v[6]
    else:
        v[6] = 0.0


@_jit
def _inputs_by_params(d_anchor: Array, b: int, sg: int, manoeuvres: int, d: Array
                      ) -> None:  # pragma: no cover - compiled
    """Write segment ``sg``'s ``D_s`` ``(7, p)`` into ``d`` (see :func:`_inputs` for row 6)."""
    p = d.shape[1]
    k0 = 6 + 2 * manoeuvres
    d[:, :] = 0.0
    for c in range(p):  # the start state depends on earlier segments' parameters only
        if c < 4 + 2 * sg or k0 <= c < k0 + sg - 1:
            for r in range(4):
                d[r, c] = d_anchor[b, sg, r, c]
    d[4, 4 + 2 * sg] = 1.0
    d[5, 5 + 2 * sg] = 1.0
    if sg >= 1:
        d[6, k0 + sg - 1] = 1.0


@_jit
def segment_normal(ds: Array, r: Array, w: Array, par: Array, seg: IntArray, idx: IntArray,
                   d_anchor: Array, manoeuvres: int, runs: IntArray, jtj: Array, jtr: Array
                   ) -> None:  # pragma: no cover - compiled
    """Write ``J'J`` ``(R, p, p)`` and ``J'r`` ``(R, p)`` of the whitened Jacobian of ``runs``.

    Parameters
    ----------
    ds : ndarray
        ``(B, n, 6)`` derivatives of the predictions by the ENU state (not whitened).
    r, w : ndarray
        ``(B, n)`` whitened residuals and ``(n,)`` inverse standard deviations.
    par, seg, idx, d_anchor : ndarray
        As for :func:`tmakit.motion.curvilinear_numba.chain`.
    manoeuvres : int
        ``M``.
    runs : ndarray of int
        ``(R,)`` the parameter vectors (rows of the batch) summed, in the order written.
    jtj, jtr : ndarray
        Outputs.
    """
    m1 = manoeuvres + 1
    p = jtj.shape[1]
    k0 = 6 + 2 * manoeuvres
    s = np.empty((m1, 7, 7))
    g = np.empty((m1, 7))
    v = np.empty(7)
    d = np.empty((7, p))
    dv = np.empty((7, p))
    for j in range(runs.shape[0]):
        b = runs[j]
        s[:] = 0.0
        g[:] = 0.0
        for i in range(ds.shape[1]):
            u = idx[i]
            sg = seg[b, u]
            _inputs(ds, par, d_anchor, b, i, u, sg, k0 + sg - 1 if sg else -1, w[i], v)
            ri = r[b, i]
            for k in range(7):
                vk = v[k]
                g[sg, k] += vk * ri
                for m in range(k, 7):
                    s[sg, k, m] += vk * v[m]
        jtj[j] = 0.0
        jtr[j] = 0.0
        for sg in range(m1):
            _inputs_by_params(d_anchor, b, sg, manoeuvres, d)
            _add_segment(s[sg], g[sg], d, dv, jtj[j], jtr[j])


@_jit
def _add_segment(s: Array, g: Array, d: Array, dv: Array, jtj: Array, jtr: Array
                 ) -> None:  # pragma: no cover - compiled
    """Add ``D' S D`` to ``jtj`` and ``D' g`` to ``jtr`` (``S``'s upper triangle summed)."""
    p = d.shape[1]
    for k in range(7):
        for m in range(k + 1, 7):
            s[m, k] = s[k, m]
    dv[:, :] = 0.0
    for k in range(7):  # S D
        for m in range(7):
            skm = s[k, m]
            if skm != 0.0:
                for c in range(p):
                    dv[k, c] += skm * d[m, c]
    for c in range(p):  # D' (S D), D' g
        for k in range(7):
            dkc = d[k, c]
            if dkc != 0.0:
                jtr[c] += dkc * g[k]
                for e in range(p):
                    jtj[c, e] += dkc * dv[k, e]
