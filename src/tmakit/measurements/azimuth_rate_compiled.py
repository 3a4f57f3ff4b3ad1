"""Azimuth-rate rows with their derivatives, compiled (``numba``).

The solvers' linearisation (:meth:`tmakit.observation.rows.RowModel.linearise_into`) writes
each kind's rows straight into its own arrays; for the azimuth rate this loop does it in one
pass per row (NumPy made a temporary per operation and read strided relative states: the
manoeuvre estimate of hoerst2010 took 1.17x as long).  The formulas are those of
:meth:`~tmakit.measurements.azimuth_rate.AzimuthRate.jacobian`, in the same order (no
``fastmath``: the same bits).  Importing this module imports ``numba`` (about 0.1 s a
process): the kind imports it at its first such rows.

References
----------
Hörst & Oispuu (2010), eq. 6.
"""

from __future__ import annotations

import numba

from ..arrays import Array

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def _azimuth_rate(rel: Array, values: Array, d: Array) -> None:  # pragma: no cover - compiled
    """Write azimuth rates (rad/s) into ``values``, derivatives into ``d[..., (0, 1, 3, 4)]``."""
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


def azimuth_rate(rel: Array, values: Array, d_rel: Array) -> None:
    """Write azimuth rates and their derivatives by the relative state.

    Parameters
    ----------
    rel : ndarray
        ``(..., m, 6)`` relative states (m, m/s).
    values : ndarray
        ``(..., m)`` written with the rates (rad/s).
    d_rel : ndarray
        ``(..., m, 6)``; columns 0, 1, 3, 4 written (rad/(s m), rad/m).
    """
    if rel.ndim == 3:
        _azimuth_rate(rel, values, d_rel)
    elif rel.ndim == 2:
        _azimuth_rate(rel[None], values[None], d_rel[None])
    else:  # (views of the leading axes, never copies: the outputs are written in place)
        for i in range(rel.shape[0]):
            azimuth_rate(rel[i], values[i], d_rel[i])
