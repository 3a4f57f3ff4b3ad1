"""Compiled kernels of the planner's hot loops (optional ``numba``), with NumPy fallbacks.

* :func:`cloud_sums` — the cloud sums of :mod:`tmakit.planning.planar_information`: ``Gamma``
  over a cloud of ``N`` members for ``C`` candidate sensors reduces to weighted sums over the
  cloud of a few fields (``c2``, ``cs`` and the products ``1/r^2``, ``q/r``, ``q^2``, ``1/r``,
  ``q`` times ``1``, ``c2``, ``cs``).  In NumPy each field is a ``(C, N)`` array written to
  memory and read back; here one compiled loop per candidate runs over the cloud once and
  keeps every sum in a register, in float64 (reassociated into SIMD lanes, so the sums may
  differ from NumPy's in the last bits).
* :func:`fly` — :meth:`~tmakit.sensors.PlatformKinematics.step` of every candidate action from
  a batch of start states in one compiled loop (:mod:`tmakit.planning.numba_decision`).
* ``kernel("decide_planar")`` — a whole one-step decision of the planner for a planar plan
  measured at the end of the step: kinematics, predicted information, ``Gamma``, ``J^{-1}``,
  cost, bound and choice over every candidate in one compiled call
  (:mod:`tmakit.planning.fused`).
* :func:`spd_inverse` — ``J^{-1}`` of a stack of small positive-definite information
  matrices, as :func:`tmakit.planning.criteria.bound_covariance` computes it (normalised by
  the diagonal, Cholesky, triangular inverse), one loop instead of a dozen NumPy calls.

``tests/test_planning_kernel.py`` checks that both agree with the NumPy path to 1e-12
relative.  ``numba`` is an optional extra (``pip install tmakit[fast]``): without it, or with
the environment variable ``TMAKIT_NO_NUMBA`` set to a non-empty value other than ``0``, or
after ``use_compiled(False)``, :func:`available` is False and the NumPy path is used.
``numba`` is imported, and the kernels compiled (cached on disk), at the first call only.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.arrays import Array
from .optional_kernels import OptionalKernels

#: The products of ``1/r`` and the bearing rate ``q`` the kernels sum, in the order of
#: :data:`tmakit.planning.planar_information._PRODUCTS`.
PRODUCTS = ("ir2", "irq", "qq", "ir", "q")
#: Rows of the general kernel's output: ``E[c2]``, ``E[cs]``, then per product ``g``
#: ``E[g]``, ``E[g c2]``, ``E[g cs]``.
ROWS = 2 + 3 * len(PRODUCTS)

#: The module's kernels (:mod:`tmakit.planning.optional_kernels`).
KERNELS = OptionalKernels("planning", lambda: _compile())
use_compiled = KERNELS.use_compiled
available = KERNELS.available


def _compile() -> dict[str, Callable[..., object]]:
    """Import ``numba`` and the kernels and compile them on tiny inputs (cached on disk).

    Compiling here, not at the first real call, lets :func:`available` fall back to NumPy
    when ``numba`` is installed but cannot compile (an incompatible NumPy, no cache dir).
    """
    from . import numba_decision as nd
    from . import numba_kernels as nk

    kernels: dict[str, Callable[..., object]] = {
        "position": nk.position_sums, "general": nk.general_sums,
        "spd_inverse": nk.spd_inverse_stack, "assemble": nk.assemble_gamma,
        "fly": nd.fly, "decide_planar": nd.decide_planar}
    one, sensor = np.ones(1), np.zeros((1, 6))
    _warm_decision(nd)
    nk.position_sums(one, one, one, one[:1] * 0, one[:1] * 0, np.empty((5, 1)))
    nk.general_sums(one, one, one, one, one, sensor, np.empty((ROWS, 1)))
    nk.spd_inverse_stack(np.eye(4)[None], np.empty((1, 4, 4)))
    nk.assemble_gamma(np.ones((5, 1)), np.ones((1, 3)), np.ones(3), np.empty((1, 4, 4)))
    return kernels


def spd_inverse(information: Array) -> Array | None:
    """Return ``J^{-1}`` (..., n, n) of positive-definite information matrices, compiled.

    Parameters
    ----------
    information : ndarray, shape (..., n, n)
        ``J``, SI.

    Returns
    -------
    ndarray or None
        The inverses (SI); None when the kernels are not :func:`available` or a matrix is
        not numerically positive definite (the caller then takes its NumPy path).
    """
    if not available():
        return None
    info = np.ascontiguousarray(information, dtype=float)
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    out = np.empty_like(flat)
    if not KERNELS["spd_inverse"](flat, out):
        return None
    return out.reshape(info.shape)


def cloud_sums(names: list[str], cols: Array, weights: Array, sensors: Array) -> Array:
    """Return the weighted cloud sums (2 + 3 P, C) of the products ``names``, compiled.

    Parameters
    ----------
    names : list of str
        The products needed (a subsequence of :data:`PRODUCTS`), ``P`` of them.
    cols : ndarray, shape (4, N)
        The cloud ``[x, y, vx, vy]`` by rows (m, m/s).
    weights : ndarray, shape (N,)
        Normalised weights.
    sensors : ndarray, shape (C, 6)
        Candidate sensor states (m, m/s).

    Returns
    -------
    ndarray, shape (2 + 3 P, C)
        Rows ``E[c2]``, ``E[cs]``, then per product ``g`` of ``names``: ``E[g]``,
        ``E[g c2]``, ``E[g cs]`` (SI).

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    if not available():
        raise RuntimeError("the compiled planning kernels are not available (numba)")
    kernels = KERNELS
    c = sensors.shape[0]
    w = np.ascontiguousarray(weights, dtype=float)
    x = np.ascontiguousarray(cols[0])
    y = np.ascontiguousarray(cols[1])
    if names == ["ir2"]:
        out = np.empty((5, c))
        kernels["position"](x, y, w, np.ascontiguousarray(sensors[:, 0]),
                            np.ascontiguousarray(sensors[:, 1]), out)
        return out
    full = np.empty((ROWS, c))
    kernels["general"](x, y, np.ascontiguousarray(cols[2]), np.ascontiguousarray(cols[3]), w,
                       np.ascontiguousarray(sensors, dtype=float), full)
    rows = [0, 1]
    for name in names:
        k = 2 + 3 * PRODUCTS.index(name)
        rows += [k, k + 1, k + 2]
    return full[rows]


def planar_gamma(names: list[str], coefficients: Array, constants: Array, cols: Array,
                 weights: Array, sensors: Array) -> Array:
    """Return ``Gamma`` (C, 4, 4) of the planar closed form, compiled end to end.

    Parameters
    ----------
    names : list of str
        The products needed (a subsequence of :data:`PRODUCTS`), ``P`` of them.
    coefficients : ndarray, shape (P, 3)
        Each product's coefficients in the fields ``A``, ``B``, ``E``.
    constants : ndarray, shape (3,)
        The constant fields ``D``, ``G``, ``F``.
    cols, weights, sensors
        As for :func:`cloud_sums`.

    Returns
    -------
    ndarray, shape (C, 4, 4)
        SI.

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    sums = cloud_sums(names, cols, weights, sensors)
    out = np.empty((sensors.shape[0], 4, 4))
    KERNELS["assemble"](sums, coefficients, constants, out)
    return out


def _warm_decision(nd: Any) -> None:
    """Compile ``fly`` and ``decide_planar`` on tiny inputs (both cloud forms)."""
    start = np.array([[0.0, 0.0, 0.0, 0.0, 50.0, 0.0]])
    acts = np.array([[0.1], [1.0], [0.0], [0.0]])
    limits = np.array([0.0, np.inf, np.inf, np.inf, np.inf, -np.inf, np.inf])
    out, flags = np.empty((nd.COLUMNS, 1)), np.empty((4, 1), dtype=np.bool_)
    nd.fly(start, acts, True, limits, 1.0, out, flags)
    eye, cloud = np.eye(4), np.array([[1e3, 1e3, 1.0, 1.0]])
    for at_mean, position_only in ((True, True), (False, False)):
        coef = np.ones((1 if position_only else len(PRODUCTS), 3))
        nd.decide_planar(start[0, :3].copy(), 0.0, 50.0, 0.0, acts, True, limits, 1.0, eye,
                         eye, np.ones((4, 1)), eye,
                         cloud, np.ones(1), at_mean, coef, np.ones(3), position_only, eye,
                         out, flags, np.empty((1, 4, 4)), np.empty((1, 4, 4)), np.empty(1),
                         np.empty(1))


def fly(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float
        ) -> tuple[Array, Array]:
    """Fly every action from every start for one step, compiled (rows of ``numba_decision``).

    Parameters
    ----------
    starts : ndarray, shape (M, 6)
        ``[x, y, z, heading, speed, climb rate]`` (m, rad, m/s).
    actions : ndarray, shape (4, A)
        Heading change (rad), speed factor, speed change (m/s), climb rate (m/s).
    own_climb : bool
        Each start keeps its climb rate (the actions give none).
    limits : ndarray, shape (7,)
        Speed range (m/s), turn rate (rad/s), acceleration (m/s^2), climb rate (m/s) and
        altitude band (m) limits.
    interval : float
        The step, s.

    Returns
    -------
    fields : ndarray, shape (20, M A)
        Rows of :mod:`tmakit.planning.numba_decision` (SI).
    flags : ndarray of bool, shape (4, M A)
        Speed range, turn-rate, acceleration, climb-rate/altitude limit acted.

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    if not available():
        raise RuntimeError("the compiled planning kernels are not available (numba)")
    size = starts.shape[0] * actions.shape[1]
    fields, flags = np.empty((20, size)), np.empty((4, size), dtype=np.bool_)
    KERNELS["fly"](starts, actions, own_climb, limits, float(interval), fields,
                             flags)
    return fields, flags


def kernel(name: str) -> Callable[..., Any] | None:
    """Return the compiled kernel ``name`` (``"fly"``, ``"decide_planar"``, ...), or None.

    Parameters
    ----------
    name : str
        A kernel of :mod:`tmakit.planning.numba_kernels` or
        :mod:`tmakit.planning.numba_decision` as registered here.

    Returns
    -------
    callable or None
        None when the kernels are not :func:`available`.
    """
    return KERNELS[name] if available() else None
