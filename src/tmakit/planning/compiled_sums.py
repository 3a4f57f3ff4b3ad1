"""The compiled cloud sums and small inverses of :mod:`tmakit.planning.compiled`.

Every kernel works in float64 and writes into arrays it is given.  ``error_model="numpy"``: no
zero-division check per element (it would keep the loops scalar); the cloud sums may be
reassociated into SIMD lanes.
"""

from __future__ import annotations

import numba
import numpy as np

from ..core.arrays import Array

_sums = numba.njit(cache=True, nogil=True, error_model="numpy",
                   fastmath={"reassoc", "contract", "nsz"})
_exact = numba.njit(cache=True, nogil=True, error_model="numpy")


@_sums
def position_sums(x: Array, y: Array, w: Array, sx: Array, sy: Array, out: Array) -> None:
    """Write (5, C): E[c2], E[cs], E[1/r^2], E[c2/r^2], E[cs/r^2] (no velocity terms)."""
    for c in range(sx.shape[0]):
        a0 = a1 = a2 = a3 = a4 = 0.0
        px = sx[c]
        py = sy[c]
        for i in range(x.shape[0]):
            dx = x[i] - px
            dy = y[i] - py
            dx2 = dx * dx
            ir2 = 1.0 / (dx2 + dy * dy)
            c2 = dx2 * ir2
            cs = dx * dy * ir2
            wi = w[i]
            wg = wi * ir2
            a0 += wi * c2
            a1 += wi * cs
            a2 += wg
            a3 += wg * c2
            a4 += wg * cs
        out[0, c] = a0
        out[1, c] = a1
        out[2, c] = a2
        out[3, c] = a3
        out[4, c] = a4


@_sums
def general_sums(x: Array, y: Array, vx: Array, vy: Array, w: Array, s: Array,
                 out: Array) -> None:
    """Write (17, C): E[c2], E[cs], then E[g], E[g c2], E[g cs] for g in ir2, irq, qq, ir, q."""
    for c in range(s.shape[0]):
        px, py, pvx, pvy = s[c, 0], s[c, 1], s[c, 3], s[c, 4]
        a0 = a1 = b0 = b1 = b2 = d0 = d1 = d2 = e0 = e1 = e2 = 0.0
        f0 = f1 = f2 = h0 = h1 = h2 = 0.0
        for i in range(x.shape[0]):
            dx = x[i] - px
            dy = y[i] - py
            dx2 = dx * dx
            ir2 = 1.0 / (dx2 + dy * dy)
            c2 = dx2 * ir2
            cs = dx * dy * ir2
            ir = np.sqrt(ir2)
            q = ((vx[i] - pvx) * dy - (vy[i] - pvy) * dx) * ir2
            wi = w[i]
            a0 += wi * c2
            a1 += wi * cs
            g = wi * ir2
            b0 += g
            b1 += g * c2
            b2 += g * cs
            g = wi * (ir * q)
            d0 += g
            d1 += g * c2
            d2 += g * cs
            g = wi * (q * q)
            e0 += g
            e1 += g * c2
            e2 += g * cs
            g = wi * ir
            f0 += g
            f1 += g * c2
            f2 += g * cs
            g = wi * q
            h0 += g
            h1 += g * c2
            h2 += g * cs
        sums = (a0, a1, b0, b1, b2, d0, d1, d2, e0, e1, e2, f0, f1, f2, h0, h1, h2)
        for k in range(17):
            out[k, c] = sums[k]


@_exact
def _cholesky(a: Array, d: Array, low: Array) -> bool:
    """Write the Cholesky factor of ``a / (d d^T)`` to ``low``; False if not PD."""
    n = a.shape[0]
    for j in range(n):
        acc = a[j, j] / (d[j] * d[j])
        for p in range(j):
            acc -= low[j, p] * low[j, p]
        if not acc > 0.0:
            return False
        low[j, j] = np.sqrt(acc)
        for i in range(j + 1, n):
            acc = a[i, j] / (d[i] * d[j])
            for p in range(j):
                acc -= low[i, p] * low[j, p]
            low[i, j] = acc / low[j, j]
    return True


@_exact
def _lower_inverse(low: Array, inv: Array) -> None:
    """Write the inverse of the lower-triangular ``low`` to ``inv`` (forward substitution)."""
    n = low.shape[0]
    for i in range(n):
        inv[i, i] = 1.0 / low[i, i]
        for j in range(i):
            acc = 0.0
            for p in range(j, i):
                acc += low[i, p] * inv[p, j]
            inv[i, j] = -acc * inv[i, i]


@_exact
def _gram(inv: Array, d: Array, out: Array) -> bool:
    """Write ``(L^{-T} L^{-1}) / (d d^T)`` to ``out``; False if a value is not finite."""
    n = inv.shape[0]
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for p in range(j, n):
                acc += inv[p, i] * inv[p, j]
            v = acc / (d[i] * d[j])
            if not np.isfinite(v):
                return False
            out[i, j] = v
            out[j, i] = v
    return True


@_exact
def spd_inverse_stack(info: Array, out: Array) -> bool:
    """Write ``J^{-1}`` of every (n, n) matrix of ``info`` to ``out``."""
    n = info.shape[1]
    low = np.zeros((n, n))
    inv = np.zeros((n, n))
    d = np.empty(n)
    for k in range(info.shape[0]):
        for i in range(n):
            d[i] = np.sqrt(max(info[k, i, i], 1e-300))
        if not _cholesky(info[k], d, low):
            return False
        _lower_inverse(low, inv)
        if not _gram(inv, d, out[k]):
            return False
    return True


@_exact
def assemble_gamma(sums: Array, coef: Array, dgf: Array, out: Array) -> None:
    """Write ``Gamma`` (C, 4, 4) from the cloud sums, as NumPy does it."""
    d, g, f = dgf[0], dgf[1], dgf[2]
    fields = np.empty(11)
    for c in range(sums.shape[1]):
        fields[:9] = 0.0
        fields[9] = sums[0, c]
        fields[10] = sums[1, c]
        for j in range(coef.shape[0]):
            for k in range(3):
                if coef[j, k] != 0.0:
                    for m in range(3):
                        fields[3 * k + m] += coef[j, k] * sums[2 + 3 * j + m, c]
        ea, eac2, eacs, eb, ebc2, ebcs, ee, eec2, eecs, ec2, ecs = fields
        out[c, 0, 0] = ea - eac2 + 2.0 * ebcs + d * ec2
        out[c, 0, 1] = out[c, 1, 0] = -eacs + eb - 2.0 * ebc2 + d * ecs
        out[c, 1, 1] = eac2 - 2.0 * ebcs + d * (1.0 - ec2)
        out[c, 0, 2] = out[c, 2, 0] = eecs + g * ec2
        out[c, 0, 3] = out[c, 3, 0] = ee - eec2 + g * ecs
        out[c, 1, 2] = out[c, 2, 1] = -eec2 + g * ecs
        out[c, 1, 3] = out[c, 3, 1] = -eecs + g * (1.0 - ec2)
        out[c, 2, 2] = f * ec2
        out[c, 2, 3] = out[c, 3, 2] = f * ecs
        out[c, 3, 3] = f * (1.0 - ec2)
