"""The particle filter's move under white-noise acceleration, compiled."""

from __future__ import annotations

import numba

from ..core.arrays import Array

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def move_density(x: Array, noise: Array, dt: float, l11: Array, l21: Array,
                 l22: Array) -> None:  # pragma: no cover - compiled
    """Move the particles one step (in place)."""
    dim = l11.shape[0]
    n = x.shape[1]
    for a in range(dim):
        c11, c21, c22 = l11[a], l21[a], l22[a]
        for i in range(n):
            w0 = float(noise[0, a, i])
            x[a, i] += dt * x[dim + a, i] + c11 * w0
            x[dim + a, i] += c21 * w0 + c22 * float(noise[1, a, i])
