"""Compiled bearing and azimuth-rate rows (optional ``numba``), used once ``numba`` is loaded.

The manoeuvre estimator (:mod:`tmakit.batch.manoeuvre`) linearises some ten thousand rows per
step; the NumPy formulas of :class:`~tmakit.measurements.bearing.Bearing` and
:class:`~tmakit.measurements.azimuth_rate.AzimuthRate` make a temporary per operation, read
strided relative states and took a sixth of its time.  The kernels of
:mod:`tmakit.measurements.planar_numba` do the same operations in one pass per row, giving the
same bits, so which path runs never changes a result.  The bearing itself stays NumPy's
``arctan2`` (NumPy's vectorised ``arctan2`` and the C library's differ in the last bit).

The kernels are used (:func:`wanted`) for at least :data:`KERNEL_ROWS` rows, where ``numba``
is already imported by another compiled path: they are never the reason to import it (a few
tenths of a second), and ``TMAKIT_NO_NUMBA`` or ``use_compiled(False)`` turn them off.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np

from ..arrays import Array
from ..optional_kernels import OptionalKernels

__all__ = ["KERNELS", "KERNEL_ROWS", "available", "azimuth_rate", "bearing_gradient",
           "use_compiled", "wanted"]

KERNEL_ROWS = 256
"""Fewest rows (over the batch) for which the kernels are used: below, NumPy's calls cost less
than the kernel's dispatch."""


def _compile() -> dict[str, Callable[..., object]]:
    """Import ``numba`` and the kernels; compile them on the layouts the solvers pass."""
    from . import planar_numba as kn

    rel = np.ones((1, 4, 6))[:, 1:3]  # rows of one kind: a slice of every row's states
    values = np.empty((1, 4))[:, 1:3]
    d = np.zeros((1, 6, 4)).swapaxes(-1, -2)[:, 1:3]  # component-major, as the solvers keep
    kn.bearing_gradient(rel, d)
    kn.azimuth_rate(rel, values, d)
    return {"bearing_gradient": kn.bearing_gradient, "azimuth_rate": kn.azimuth_rate}


#: The module's kernels (:mod:`tmakit.optional_kernels`).
KERNELS = OptionalKernels("planar measurement", _compile)
use_compiled = KERNELS.use_compiled
available = KERNELS.available


def wanted(rel: Array) -> bool:
    """Tell whether the kernels should take these rows (see the module docstring).

    Parameters
    ----------
    rel : ndarray
        ``(B, m, 6)`` relative states.

    Returns
    -------
    bool
        True for enough rows of a 3-D array, with ``numba`` already imported and the kernels
        switched on.
    """
    return (rel.ndim == 3 and rel.shape[0] * rel.shape[1] >= KERNEL_ROWS
            and "numba" in sys.modules and available())


def bearing_gradient(rel: Array, d_rel: Array) -> None:
    """Write the bearings' derivatives by the relative east and north, compiled.

    Parameters
    ----------
    rel : ndarray
        ``(B, m, 6)`` relative states (m, m/s).
    d_rel : ndarray
        ``(B, m, 6)``; columns 0 and 1 written with ``dy / rho^2`` and ``-dx / rho^2`` (rad/m).
    """
    KERNELS["bearing_gradient"](rel, d_rel)


def azimuth_rate(rel: Array, values: Array, d_rel: Array) -> None:
    """Write azimuth rates and their derivatives by the relative state, compiled.

    Parameters
    ----------
    rel : ndarray
        ``(B, m, 6)`` relative states (m, m/s).
    values : ndarray
        ``(B, m)`` written with the rates (rad/s).
    d_rel : ndarray
        ``(B, m, 6)``; columns 0, 1, 3, 4 written (rad/(s m), rad/m).
    """
    KERNELS["azimuth_rate"](rel, values, d_rel)
