"""The planner's compiled code, loaded at its first call: ``Gamma`` over a cloud, ``J^{-1}``.

``Gamma`` of planar bearing, range and range-rate plans over a cloud is written in closed form:
per candidate, weighted sums over the cloud of products of ``1/r`` and the bearing rate ``q``
(:data:`PRODUCTS`), combined by constant coefficients of ``W = R^{-1}``.  The kernels are in
:mod:`tmakit.planning.compiled_kernels` (``numba``, imported by :func:`kernels`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.arrays import Array
from .measurement_plan import SensorPlan

#: The products of ``1/r`` and the bearing rate ``q`` the kernels sum.
PRODUCTS = ("ir2", "irq", "qq", "ir", "q")
#: Rows of the general kernel's output: ``E[c2]``, ``E[cs]``, then per product ``g``
#: ``E[g]``, ``E[g c2]``, ``E[g cs]``.
ROWS = 2 + 3 * len(PRODUCTS)
PLANAR_KINDS = frozenset({"bearing", "range", "range_rate"})
#: The coefficients of each product in ``(A, B, E)`` (names of :func:`_coefficients`).
_PRODUCT_COEFFICIENTS = (("A_rr", None, None), ("A_rq", None, None), ("A_qq", None, None),
                         (None, "B_r", "E_r"), (None, "B_q", "E_q"))
#: The basis packed for the kernels: product names, coefficients (P, 3) in ``A``, ``B``,
#: ``E``, and the constants ``D``, ``G``, ``F``.
Packed = tuple[list[str], Array, Array]


@functools.cache
def kernels() -> dict[str, Callable[..., Any]]:
    """Return the compiled kernels by name (importing ``numba`` the first time)."""
    from . import compiled_kernels as k

    return {"position": k.position_sums, "general": k.general_sums,
            "spd_inverse": k.spd_inverse_stack, "assemble": k.assemble_gamma,
            "fly": k.fly, "decide_planar": k.decide_planar}


def spd_inverse(information: Array) -> Array | None:
    """Return ``J^{-1}`` (..., n, n) of positive-definite information matrices."""
    info = np.ascontiguousarray(information, dtype=float)
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    out = np.empty_like(flat)
    if not kernels()["spd_inverse"](flat, out):
        return None
    return out.reshape(info.shape)


def supports_planar(plan: SensorPlan, sensor_states: Array) -> bool:
    """Tell whether the closed form applies: 2-D, planar kinds, every sensor at ``z = 0``."""
    return (plan.dim == 2 and set(plan.kinds) <= PLANAR_KINDS and not plan.options
            and not plan.nuisance and not np.any(sensor_states[..., 2]))


def compiled_basis(plan: SensorPlan) -> Packed:
    """Return the plan's planar basis packed for the compiled kernels (kept per plan noise)."""
    sigmas = np.asarray(plan.sigmas, dtype=float)
    cov = None if plan.covariance is None else np.asarray(plan.covariance, dtype=float)
    key = (tuple(plan.kinds), sigmas.tobytes(), None if cov is None else cov.tobytes())
    if key not in _BASES:
        if len(_BASES) >= 64:
            _BASES.clear()
        k = _coefficients(plan.kinds, sigmas, cov)
        basis = [(name, tuple(k[n] if n is not None else 0.0 for n in keys))
                 for name, keys in zip(PRODUCTS, _PRODUCT_COEFFICIENTS, strict=True)]
        basis = [(name, coef) for name, coef in basis if any(coef)]
        _BASES[key] = ([n for n, _ in basis],
                       np.array([c for _, c in basis], dtype=float).reshape(-1, 3),
                       np.array([k["D"], k["G"], k["F"]]))
    return _BASES[key]


_BASES: dict[tuple[object, ...], Packed] = {}


def _coefficients(kinds: tuple[str, ...], sigmas: Array,
                  covariance: Array | None) -> dict[str, float]:
    """Return the constant coefficients of the scalar fields, from ``W = R^{-1}``."""
    m = len(kinds)
    w = np.diag(1.0 / sigmas**2) if covariance is None else np.linalg.inv(covariance)
    alpha = np.zeros(m)   # a_j = alpha_j / r + beta_j q
    beta = np.zeros(m)
    gamma = np.zeros(m)   # b_j
    delta = np.zeros(m)   # c_j
    for j, kind in enumerate(kinds):
        if kind == "bearing":
            alpha[j] = 1.0
        elif kind == "range":
            gamma[j] = 1.0
        else:
            beta[j] = 1.0
            delta[j] = 1.0

    def dot(u: Array, v: Array) -> float:
        return float(u @ w @ v)

    return {"A_rr": dot(alpha, alpha), "A_rq": 2.0 * dot(alpha, beta),
            "A_qq": dot(beta, beta), "B_r": dot(alpha, gamma), "B_q": dot(beta, gamma),
            "D": dot(gamma, gamma), "E_r": dot(alpha, delta), "E_q": dot(beta, delta),
            "G": dot(gamma, delta), "F": dot(delta, delta)}


def planar_information(plan: SensorPlan, states: Array, weights: Array,
                       sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (*B, 4, 4) in the closed form of the module.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    names, coefficients, constants = compiled_basis(plan)
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    cols = np.ascontiguousarray(states.T)
    sums = _cloud_sums(names, cols, weights, s)
    out = np.empty((s.shape[0], 4, 4))
    kernels()["assemble"](sums, coefficients, constants, out)
    return out.reshape(*batch, 4, 4)


def _cloud_sums(names: list[str], cols: Array, weights: Array, sensors: Array) -> Array:
    """Return the weighted cloud sums (2 + 3 P, C) of the products ``names``."""
    c = sensors.shape[0]
    w = np.ascontiguousarray(weights, dtype=float)
    x = np.ascontiguousarray(cols[0])
    y = np.ascontiguousarray(cols[1])
    if names == ["ir2"]:
        out = np.empty((5, c))
        kernels()["position"](x, y, w, np.ascontiguousarray(sensors[:, 0]),
                              np.ascontiguousarray(sensors[:, 1]), out)
        return out
    full = np.empty((ROWS, c))
    kernels()["general"](x, y, np.ascontiguousarray(cols[2]), np.ascontiguousarray(cols[3]),
                         w, np.ascontiguousarray(sensors, dtype=float), full)
    rows = [0, 1]
    for name in names:
        k = 2 + 3 * PRODUCTS.index(name)
        rows += [k, k + 1, k + 2]
    return full[rows]


def fly(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float
        ) -> tuple[Array, Array]:
    """Fly every action from every start for one step (rows of ``compiled_kernels.fly``)."""
    size = starts.shape[0] * actions.shape[1]
    fields, flags = np.empty((20, size)), np.empty((4, size), dtype=np.bool_)
    kernels()["fly"](starts, actions, own_climb, limits, float(interval), fields, flags)
    return fields, flags
