"""The predicted information of every candidate step at once (the heart of the planner).

Each candidate's information is carried over one decision interval by Hurtado & Nehorai (2008),
eq. 10, ``J <- (Q + F J^{-1} F^T)^{-1} + Gamma``, with ``Gamma`` the information ``Xi`` at the
predicted cloud's mean (``"mean"``, eq. 13) or averaged over the cloud (``"cloud"``, section
4.2).  Planar plans take the compiled closed form (:mod:`.compiled`), other geometric plans
:func:`cloud_information`, any other :meth:`MeasurementGroup.information`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..bounds.pcrb_recursion import PosteriorInformation, predict_information
from ..core.arrays import Array
from ..core.linalg import symmetrise
from .belief import Belief
from .compiled import planar_information, supports_planar
from .measurement_plan import SensorPlan

GammaForm = Literal["mean", "cloud"]
GAMMA_FORMS: tuple[str, ...] = ("mean", "cloud")
#: Kinds :func:`cloud_information` writes out (functions of the relative state only).
GEOMETRIC_KINDS = frozenset({"bearing", "elevation", "range", "range_rate"})


def check_gamma(gamma: str) -> GammaForm:
    """Return ``gamma`` if it names a form of ``Gamma``."""
    if gamma not in GAMMA_FORMS:
        raise ValueError(f"gamma must be 'mean' (Xi at the predicted mean, Hurtado & Nehorai "
                         f"(2008), section 4.2) or 'cloud' (the expectation over the cloud); "
                         f"got {gamma!r}")
    return gamma  # type: ignore[return-value]


def expected_information(plan: SensorPlan, states: Array, weights: Array,
                         sensor_states: Array, gamma: GammaForm) -> Array:
    """Return ``Gamma`` (*B, n, n) of each candidate sensor state at one time (eqs. 11, 13)."""
    if gamma == "mean" or states.shape[0] == 1:
        states, weights = (weights @ states)[None, :], _ONE
    if supports_planar(plan, sensor_states):
        return planar_information(plan, states, weights, sensor_states)
    if set(plan.kinds) <= GEOMETRIC_KINDS and not plan.options and not plan.nuisance:
        return cloud_information(plan, states, weights, sensor_states)
    xi = plan.information(states, sensor_states)  # (*B, N, n, n)
    return np.einsum("...kij,k->...ij", xi, weights)


def step_information(belief: Belief, information: Array, plan: SensorPlan,
                     sensor_states: Array, interval: float, gamma: GammaForm,
                     cloud: tuple[Array, Array] | None = None) -> Array:
    """Carry ``J`` through one decision step for every candidate at once (eqs. 10-13)."""
    posterior = belief.posterior
    states, weights = (belief.states, belief.weights) if cloud is None else cloud
    times = plan.measurement_times(interval)
    if sensor_states.shape[-2] != times.size:
        raise ValueError(f"sensor states have {sensor_states.shape[-2]} times; the plan "
                         f"measures at {times.size}")
    info = np.asarray(information, dtype=float)
    if gamma == "mean" or states.shape[0] == 1:   # Xi at the mean: move the mean only
        states, weights = (weights @ states)[None, :], _ONE
    done = 0.0
    for j, s in enumerate(times):   # a few measurement times per step, not candidates
        info = _predict(posterior, info, s - done)
        f = posterior.dynamics.transition(s)
        # (F X^T)^T: the moved cloud with contiguous columns (what the compiled sums read)
        info = info + expected_information(plan, (f @ states.T).T, weights,
                                           sensor_states[..., j, :], gamma)
        done = s
    return symmetrise(_predict(posterior, info, interval - done))


_ONE = np.ones(1)


def _predict(posterior: PosteriorInformation, info: Array, dt: float) -> Array:
    if dt <= 1e-12:
        return info
    f_inv, g = posterior.step_factors(dt)
    return predict_information(info, f_inv, g)



def _rows(kind: str, d: list[Array], u: list[Array], rho2: Array, inv_r: Array
          ) -> list[tuple[int, Array]]:
    """Non-zero components ``(relative-state index 0..5, values (C, N))`` of one row."""
    dx, dy, dz = d
    if kind == "bearing":
        inv = 1.0 / rho2
        return [(0, dy * inv), (1, -dx * inv)]
    if kind == "range":
        return [(0, dx * inv_r), (1, dy * inv_r), (2, dz * inv_r)]
    if kind == "elevation":
        rho = np.sqrt(rho2)
        a = inv_r * inv_r / rho
        return [(0, -dx * dz * a), (1, -dy * dz * a), (2, rho2 * a)]
    # range rate
    ex, ey, ez = dx * inv_r, dy * inv_r, dz * inv_r
    rdot = ex * u[0] + ey * u[1] + ez * u[2]
    return [(0, (u[0] - rdot * ex) * inv_r), (1, (u[1] - rdot * ey) * inv_r),
            (2, (u[2] - rdot * ez) * inv_r), (3, ex), (4, ey), (5, ez)]


#: Cloud members per block: keeps the temporaries small enough to be reused by the
#: allocator (whole-cloud temporaries of a few MB are returned to the system after every call
#: and fault back in on the next, which costs more than the arithmetic).
BLOCK_ELEMENTS = 1 << 15


def cloud_information(plan: SensorPlan, states: Array, weights: Array,
                      sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (C, n, n) for candidate sensor states ``s_c``.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    n = 2 * plan.dim
    block = max(1, BLOCK_ELEMENTS // s.shape[0])
    out = np.zeros((s.shape[0], n, n))
    for lo in range(0, states.shape[0], block):   # blocks of the cloud, not members
        out += _block_information(plan, states[lo:lo + block], weights[lo:lo + block], s)
    return out.reshape(*batch, n, n)


def _block_information(plan: SensorPlan, states: Array, weights: Array, s: Array) -> Array:
    dim = plan.dim
    n = 2 * dim
    c = s.shape[0]
    cols = np.ascontiguousarray(states.T)
    d = [(cols[i][None, :] if i < dim else 0.0) - s[:, i, None] for i in range(3)]
    u = [(cols[dim + i][None, :] if i < dim else 0.0) - s[:, 3 + i, None]
         for i in range(3)]
    d = [np.broadcast_to(a, (c, states.shape[0])) for a in d]
    rho2 = d[0] * d[0] + d[1] * d[1]
    inv_r = 1.0 / np.sqrt(rho2 + d[2] * d[2])
    rows = [_rows(k, d, u, rho2, inv_r) for k in plan.kinds]
    # state columns: relative position i -> i, velocity 3 + i -> dim + i (i < dim)
    col = {i: i for i in range(dim)} | {3 + i: dim + i for i in range(dim)}
    if plan.covariance is None:
        whiten = np.diag(1.0 / plan.sigmas)
    else:
        whiten = np.linalg.inv(np.linalg.cholesky(plan.covariance))
    # whitened rows: w_k = sum_j whiten[k, j] h_j, component by component
    whitened: list[dict[int, Array]] = []
    for k in range(len(rows)):
        acc: dict[int, Array] = {}
        for j, row in enumerate(rows):
            if whiten[k, j] == 0.0:
                continue
            for idx, val in row:
                if idx in col:
                    term = val * whiten[k, j]
                    if col[idx] in acc:
                        acc[col[idx]] += term
                    else:
                        acc[col[idx]] = term
        whitened.append(acc)
    # sum over rows of the products, then one weighted sum over the cloud per entry
    products: dict[tuple[int, int], Array] = {}
    for acc in whitened:
        present = sorted(acc)
        for i, a in enumerate(present):
            for b in present[i:]:
                prod = acc[a] * acc[b]
                if (a, b) in products:
                    products[(a, b)] += prod
                else:
                    products[(a, b)] = prod
    out = np.zeros((c, n, n))
    for (a, b), prod in products.items():   # at most n (n + 1) / 2 entries
        out[:, a, b] = out[:, b, a] = prod @ weights
    return out
