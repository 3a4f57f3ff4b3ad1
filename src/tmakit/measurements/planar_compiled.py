"""Bearing and azimuth-rate rows with their derivatives, compiled (``numba``).

The solvers' linearisation (:meth:`tmakit.observation.rows.RowModel.linearise_into`) writes
each kind's rows straight into its own arrays; for the bearing and the azimuth rate these
loops do it in one pass per row (NumPy would make a temporary per operation and read strided
relative states: the manoeuvre estimate of hoerst2010 took 1.22x as long).  The formulas are
those of :meth:`~tmakit.measurements.bearing.Bearing.jacobian` and
:meth:`~tmakit.measurements.azimuth_rate.AzimuthRate.jacobian`, in the same order (no
``fastmath``).  Arrays of any layout: ``rel`` ``(B, m, 6)``, ``values`` ``(B, m)``, ``d``
``(B, m, 6)`` whose columns not written stay as given (zeros).  Importing this module imports
``numba`` (about 0.1 s a process): the kinds import it at their first such rows.

References
----------
Hörst & Oispuu (2010), eq. 6.
"""

from __future__ import annotations

from collections.abc import Callable

import numba

from ..arrays import Array

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def _bearing_gradient(rel: Array, d: Array) -> None:  # pragma: no cover - compiled
    """Write ``d bearing / d (dx, dy) = (dy, -dx) / rho^2`` (rad/m) into ``d[..., 0:2]``."""
    for b in range(rel.shape[0]):
        for i in range(rel.shape[1]):
            dx = rel[b, i, 0]
            dy = rel[b, i, 1]
            rho2 = dx * dx + dy * dy
            d[b, i, 0] = dy / rho2
            d[b, i, 1] = -(dx / rho2)


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


def bearing_gradient(rel: Array, d_rel: Array) -> None:
    """Write the bearings' derivatives by the relative east and north into ``d_rel``.

    Parameters
    ----------
    rel : ndarray
        ``(..., m, 6)`` relative states (m, m/s).
    d_rel : ndarray
        ``(..., m, 6)``; columns 0 and 1 written with ``dy / rho^2`` and ``-dx / rho^2``
        (rad/m).
    """
    _by_batch(_bearing_gradient, rel, d_rel)


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
    _by_batch(_azimuth_rate, rel, values, d_rel)


def _by_batch(kernel: Callable[..., None], rel: Array, *out: Array) -> None:
    """Call ``kernel`` on ``(B, m, ...)`` views of arrays of any leading shape (never copies)."""
    if rel.ndim == 3:
        kernel(rel, *out)
    elif rel.ndim == 2:
        kernel(rel[None], *(a[None] for a in out))
    else:
        for i in range(rel.shape[0]):
            _by_batch(kernel, rel[i], *(a[i] for a in out))
