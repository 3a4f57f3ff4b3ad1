"""The layout bound's Fisher sum (:func:`tmakit.bounds.layout.layout_information`), compiled."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.arrays import Array, BoolArray, IntArray

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def _gradient(e: Array, st: Array, fdoa: bool, out: Array) -> None:
    """Write the range (fdoa: range-rate) gradient by the emitter position into ``out``."""
    rx, ry, rz = e[0] - st[0], e[1] - st[1], e[2] - st[2]
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    ux, uy, uz = rx / r, ry / r, rz / r
    if fdoa:  # a stationary emitter: relative velocity = - sensor velocity
        vx, vy, vz = -st[3], -st[4], -st[5]
        rdot = ux * vx + uy * vy + uz * vz
        out[0], out[1], out[2] = (vx - rdot * ux) / r, (vy - rdot * uy) / r, (vz - rdot * uz) / r
    else:
        out[0], out[1], out[2] = ux, uy, uz


@_jit
def information(emitters: Array, sensor: Array, ref: Array, fdoa: BoolArray,
                inv_sigma: Array, starts: IntArray, dim: int) -> Array:
    """Give the Fisher information ``(E, dim, dim)`` at each emitter (rows in group order)."""
    n, groups = sensor.shape[0], starts.shape[0]
    info = np.zeros((emitters.shape[0], dim, dim))
    at_ref, g, y, s = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    acc = np.empty((dim, dim))
    for k in range(emitters.shape[0]):
        e = emitters[k]
        acc[:] = 0.0
        for grp in range(groups):
            lo = starts[grp]
            hi = starts[grp + 1] if grp + 1 < groups else n
            _gradient(e, ref[lo], fdoa[lo], at_ref)
            s[:] = 0.0
            for i in range(lo, hi):
                _gradient(e, sensor[i], fdoa[i], g)
                for a in range(dim):
                    y[a] = (g[a] - at_ref[a]) * inv_sigma[i]
                    s[a] += y[a]
                for a in range(dim):
                    for b in range(a, dim):
                        acc[a, b] += 2.0 * y[a] * y[b]
            c = 2.0 / (1.0 + (hi - lo))
            for a in range(dim):
                for b in range(a, dim):
                    acc[a, b] -= c * s[a] * s[b]
        for a in range(dim):
            for b in range(a, dim):
                info[k, a, b] = acc[a, b]
                info[k, b, a] = acc[a, b]
    return info
