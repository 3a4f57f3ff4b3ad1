"""The ``numba`` kernels behind :mod:`tmakit.measurements.planar_compiled` (imported there).

The derivatives of a bearing and the azimuth rate with its derivatives, row by row, with the
operations of the NumPy formulas in :mod:`tmakit.measurements.bearing` and
:mod:`tmakit.measurements.azimuth_rate` in the same order (no ``fastmath``): the same bits.
Arrays of any layout: ``rel`` ``(B, m, 6)``, ``values`` ``(B, m)``, ``d`` ``(B, m, 6)`` whose
columns not written stay as given (zeros).

References
----------
Hörst & Oispuu (2010), eq. 6.
"""

from __future__ import annotations

import numba

from ..arrays import Array

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def bearing_gradient(rel: Array, d: Array) -> None:  # pragma: no cover - compiled
    """Write ``d bearing / d (dx, dy)`` ``= (dy, -dx) / rho^2`` into ``d[..., 0:2]``.

    Parameters
    ----------
    rel : ndarray
        ``(B, m, 6)`` relative states (m, m/s).
    d : ndarray
        ``(B, m, 6)`` written in columns 0 and 1 (rad/m).
    """
    for b in range(rel.shape[0]):
        for i in range(rel.shape[1]):
            dx = rel[b, i, 0]
            dy = rel[b, i, 1]
            rho2 = dx * dx + dy * dy
            d[b, i, 0] = dy / rho2
            d[b, i, 1] = -(dx / rho2)


@_jit
def azimuth_rate(rel: Array, values: Array, d: Array) -> None:  # pragma: no cover - compiled
    """Write azimuth rates into ``values`` and their derivatives into ``d[..., (0, 1, 3, 4)]``.

    Parameters
    ----------
    rel : ndarray
        ``(B, m, 6)`` relative states (m, m/s).
    values : ndarray
        ``(B, m)`` written (rad/s).
    d : ndarray
        ``(B, m, 6)`` written in columns 0, 1, 3, 4 (rad/(s m), rad/m).
    """
    for b in range(rel.shape[0]):
        for i in range(rel.shape[1]):
            dx = rel[b, i, 0]
            dy = rel[b, i, 1]
            dvx = rel[b, i, 3]
            dvy = rel[b, i, 4]
            rho2 = dx * dx + dy * dy
            rate = (dvx * dy - dx * dvy) / rho2
            values[b, i] = rate
            d[b, i, 0] = (-dvy - 2.0 * dx * rate) / rho2
            d[b, i, 1] = (dvx - 2.0 * dy * rate) / rho2
            d[b, i, 3] = dy / rho2
            d[b, i, 4] = -dx / rho2
