"""``Gamma`` over a cloud in closed form for planar bearing, range and range-rate plans."""

from __future__ import annotations

import numpy as np

from ..core.arrays import Array
from . import compiled
from .measurement_plan import SensorPlan

PLANAR_KINDS = frozenset({"bearing", "range", "range_rate"})


def supports_planar(plan: SensorPlan, sensor_states: Array) -> bool:
    """Tell whether the closed form applies: 2-D, planar kinds, every sensor at ``z = 0``."""
    return (plan.dim == 2 and set(plan.kinds) <= PLANAR_KINDS and not plan.options
            and not plan.nuisance and not np.any(sensor_states[..., 2]))


#: The basis of :func:`_coefficients`, packed for the compiled kernels: names, coefficients
#: (P, 3) in ``A``, ``B``, ``E``, and the constants ``D``, ``G``, ``F``.
Packed = tuple[list[str], Array, Array]
Basis = list[tuple[str, tuple[float, float, float]]]


def _coefficients(plan: SensorPlan) -> tuple[dict[str, float], Basis, Packed]:
    """Return the constant coefficients of the scalar fields (from ``W = R^{-1}``), the basis."""
    sigmas = np.asarray(plan.sigmas, dtype=float)
    cov = None if plan.covariance is None else np.asarray(plan.covariance, dtype=float)
    key = (tuple(plan.kinds), sigmas.tobytes(), None if cov is None else cov.tobytes())
    if key not in _COEFFICIENTS:
        if len(_COEFFICIENTS) >= 64:
            _COEFFICIENTS.clear()
        k = _compute_coefficients(plan.kinds, sigmas, cov)
        basis = _basis(k)
        _COEFFICIENTS[key] = (k, basis, _compiled_basis(k, basis))
    return _COEFFICIENTS[key]


_COEFFICIENTS: dict[tuple[object, ...], tuple[dict[str, float], Basis, Packed]] = {}


def _compute_coefficients(kinds: tuple[str, ...], sigmas: Array,
                          covariance: Array | None) -> dict[str, float]:
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
    packed = _coefficients(plan)[2]
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    cols = np.ascontiguousarray(states.T)
    return compiled.planar_gamma(*packed, cols, weights, s).reshape(*batch, 4, 4)


def compiled_basis(plan: SensorPlan) -> Packed:
    """Return the plan's planar basis packed for the compiled kernels."""
    return _coefficients(plan)[2]


def _compiled_basis(k: dict[str, float], basis: Basis) -> Packed:
    """Pack the basis for the compiled kernels: names, coefficients (P, 3), D, G, F."""
    coef = np.array([c for _, c in basis], dtype=float).reshape(-1, 3)
    return [n for n, _ in basis], coef, np.array([k["D"], k["G"], k["F"]])


#: The products of ``1/r`` and ``q`` the fields are made of, and their coefficients in
#: ``(A, B, E)`` (names of :func:`_coefficients`, None for none).
_PRODUCTS = (("ir2", ("A_rr", None, None)), ("irq", ("A_rq", None, None)),
             ("qq", ("A_qq", None, None)), ("ir", (None, "B_r", "E_r")),
             ("q", (None, "B_q", "E_q")))


def _basis(k: dict[str, float]) -> list[tuple[str, tuple[float, float, float]]]:
    """Return the products needed (non-zero coefficient) with their coefficients in A, B, E."""
    out = []
    for name, keys in _PRODUCTS:
        coef = tuple(k[n] if n is not None else 0.0 for n in keys)
        if any(coef):
            out.append((name, coef))
    return out   # type: ignore[return-value]
