"""Compiled normal equations of bearings under affine motion (optional ``numba``).

A full-size evaluation of a bearings-only problem (one kind, no nuisance, independent noise,
an affine motion model such as constant velocity, one parameter vector) writes the
residual, the ``(p, n)`` Jacobian of :mod:`tmakit.observation.fused`, whitens both and forms
``J'J`` and ``J'r``: six passes over fresh arrays of the rows' size.  With ``numba`` installed
(``pip install tmakit[fast]``) the relative positions and the bearings (NumPy's vectorised
``arctan2``) are made as before, and one compiled loop
(:func:`tmakit.observation.fused_numba.bearing_normal`) gives the whitened residual and sums
``J'J`` and ``J'r`` row by row, the Jacobian never written.  Both agree to rounding
(``tests/test_fused_kernel.py``).

The kernel is taken only where it pays (:func:`worth_loading`): loading ``numba`` costs
about 0.3 s once per process, and the kernel saves about 5 ns per row and evaluation, so a
single fit of 10^5 rows (three evaluations) would lose 0.3 s to win 1.5 ms.  It is used at
once when ``numba`` is already loaded (by the manoeuvre or planning kernels, or by the user),
else once this process has evaluated :data:`PAYBACK_ROWS` rows on the NumPy path; a single
``tma estimate`` of a large file never waits for ``numba``.  ``TMAKIT_NO_NUMBA`` (non-empty,
not ``0``) or ``use_compiled(False)`` keep the NumPy path; below :data:`KERNEL_ROWS` rows it is
always used.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from ..arrays import Array
from ..optional_kernels import OptionalKernels

__all__ = ["KERNELS", "KERNEL_ROWS", "PAYBACK_ROWS", "available", "bearing_normal_equations",
           "bearing_residuals", "use_compiled", "worth_loading"]

KERNEL_ROWS = 4_000
"""Rows from which the compiled kernel is used (below, the NumPy path's few passes cost
little, and the results of small problems stay those of the NumPy path to the bit)."""

PAYBACK_ROWS = 60_000_000
"""Rows evaluated on the NumPy path (full-size bearing evaluations from :data:`KERNEL_ROWS`
rows) after which loading ``numba`` pays: 0.3 s at the 5 ns per row the kernel saves."""


def _compile() -> dict[str, Callable[..., object]]:
    """Import ``numba`` and the kernels and compile them on tiny inputs (cached on disk)."""
    from . import fused_numba as fn

    one = np.ones(1)
    out = np.empty((2, 1))
    fn.relative_east_north(np.ones((2, 1)), np.zeros((1, 6)), True, np.ones(4), one, True,
                           out, np.empty((2, 1)))
    fn.bearing_normal(one, one, one, one, one, one, True, np.empty(1), np.zeros((4, 4)),
                      np.zeros(4))
    fn.bearing_residual(one, one, one, np.empty(1))
    return {"normal": fn.bearing_normal, "relative": fn.relative_east_north,
            "residual": fn.bearing_residual}


#: The module's kernels (:mod:`tmakit.optional_kernels`).
KERNELS = OptionalKernels("bearing", _compile)
use_compiled = KERNELS.use_compiled
_numpy_rows = [0]  # rows evaluated on the NumPy path where the kernel would have applied


def worth_loading() -> bool:
    """Tell whether the kernel pays in this process: ``numba`` loaded, or enough rows done.

    Returns
    -------
    bool
        True once ``numba`` is imported (loading it costs nothing more) or
        :data:`PAYBACK_ROWS` rows were evaluated on the NumPy path.
    """
    return "numba" in sys.modules or _numpy_rows[0] >= PAYBACK_ROWS


def available() -> bool:
    """Tell whether the kernel is switched on, pays here and could be compiled.

    Returns
    -------
    bool
    """
    return KERNELS.enabled and worth_loading() and KERNELS.available()


def _plan(obs: Any) -> tuple[bool, Array | None] | None:
    """Give whether the kernel's map has velocities, and their coefficient array, or None.

    The kernel applies to the east and north positions alone, or followed by the velocities
    times one coefficient array (2-D constant velocity); None for any other affine map.
    """
    east_north = sorted(((i, c, coef) for i, c, coef in obs._rel_map.terms if c < 2),
                        key=lambda t: (t[0], t[1]))
    pos = [(i, c) for i, c, coef in east_north[:2] if coef is None]
    if pos != [(0, 0), (1, 1)] or obs._rel_map.p not in (2, 4):
        return None
    vel = east_north[2:]
    if obs._rel_map.p == 2:
        return (False, None) if not vel else None
    if [(i, c) for i, c, _ in vel] != [(2, 0), (3, 1)]:
        return None
    coef_x, coef_y = vel[0][2], vel[1][2]
    if coef_x is None or coef_y is None or not (coef_x is coef_y
                                                or np.array_equal(coef_x, coef_y)):
        return None
    return True, coef_x


def _applies(obs: Any, theta: Array, n: int) -> bool:
    """Whether the kernel applies to ``obs`` at ``theta`` on ``n`` rows."""
    rel_map = obs._rel_map
    if (n < KERNEL_ROWS or rel_map is None or obs.n_nuisance or obs._ref is not None
            or len(obs.models) != 1 or theta.shape != (1, rel_map.p)):
        return False
    model = next(iter(obs.models.values()))
    if getattr(model, "planar_gradient", None) is None or not KERNELS.enabled:
        return False
    if available():
        return True
    _numpy_rows[0] += n  # the NumPy path does it: counted towards the kernel's payback
    return False


def bearing_normal_equations(obs: Any, theta: Array, u: Array, inv_sigma: Array
                             ) -> tuple[Array, Array, Array] | None:
    """Give the whitened residual, ``J'J`` and ``J'r`` of bearings in one pass, or None.

    Parameters
    ----------
    obs : ObservationModel
        The observation model (one kind with a planar fused gradient: the bearing).
    theta : numpy.ndarray
        ``(1, p)`` motion parameters, SI.
    u : numpy.ndarray
        ``(1, n)`` measured bearings in the model's grouped order (rad).
    inv_sigma : numpy.ndarray
        ``(n,)`` inverse standard deviations of independent rows (1/rad).

    Returns
    -------
    (ndarray, ndarray, ndarray) or None
        ``(1, n)`` whitened residuals ``(u - h) / sigma`` wrapped to one turn before the
        scaling (dimensionless), ``(1, p, p)`` ``J'J`` and ``(1, p)`` ``J'r`` of the whitened
        Jacobian of the predictions (per parameter unit squared, per parameter unit); None
        when the kernel does not apply (the caller takes the NumPy path).
    """
    found = _bearings(obs, theta, u)
    if found is None:
        return None
    rel, h, velocity, coef = found
    p = obs._rel_map.p
    r, jtj, jtr = np.empty((1, rel.shape[1])), np.zeros((1, p, p)), np.zeros((1, p))
    bad = KERNELS["normal"](rel[0], rel[1], h, u[0], inv_sigma, h if coef is None else coef,
                           velocity, r[0], jtj[0], jtr[0])
    if bad:  # residuals more than a turn out: wrapped by the NumPy path
        return None
    return r, jtj, jtr


def bearing_residuals(obs: Any, theta: Array, u: Array, inv_sigma: Array
                      ) -> tuple[Array, float] | None:
    """Give the whitened residual of bearings and half its squared norm in one pass, or None.

    As :func:`bearing_normal_equations` without the derivatives (a step checked by its cost).

    Parameters
    ----------
    obs, theta, u, inv_sigma
        As for :func:`bearing_normal_equations`.

    Returns
    -------
    (ndarray, float) or None
        ``(1, n)`` whitened residuals (dimensionless) and half their squared norm; None when
        the kernel does not apply.
    """
    found = _bearings(obs, theta, u)
    if found is None:
        return None
    h = found[1]
    r = np.empty((1, h.shape[0]))
    residual: Callable[..., tuple[float, bool]] = KERNELS["residual"]  # type: ignore[assignment]
    half, bad = residual(h, u[0], inv_sigma, r[0])
    return None if bad else (r, float(half))


def _bearings(obs: Any, theta: Array, u: Array
              ) -> tuple[Array, Array, bool, Array | None] | None:
    """Give the relative east and north positions and the bearings, where the kernel applies.

    ``(rel (2, n) m, h (n,) rad, velocity, coef)``; None where it does not.
    """
    if u.ndim != 2 or u.shape[0] != 1 or not _applies(obs, theta, u.shape[-1]):
        return None
    plan = _plan(obs)
    if plan is None:
        return None
    velocity, coef = plan
    theta = obs.motion.check_theta(theta)
    rel_map = obs._rel_map
    base, sensor, lazy = rel_map.position_source()
    rel = np.empty((2, rel_map.m))  # east, north
    head = np.empty((2, rel_map.m) if lazy else (2, 0))  # kept for the next evaluations
    KERNELS["relative"](base, sensor, lazy, theta[0], base[0] if coef is None else coef,
                        velocity, rel, head)
    if lazy:
        rel_map.keep_head(head)
    return rel, np.arctan2(rel[0], rel[1]), velocity, coef
