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
from ..observation.varpro_compiled import GEOMETRIC_CODES
from .belief import Belief
from .compiled import geometric_sums, planar_information, supports_planar
from .measurement_plan import SensorPlan

GammaForm = Literal["mean", "cloud"]
GAMMA_FORMS: tuple[str, ...] = ("mean", "cloud")
#: Kinds :func:`cloud_information` takes (functions of the relative state only).
GEOMETRIC_KINDS = frozenset(GEOMETRIC_CODES)


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


def cloud_information(plan: SensorPlan, states: Array, weights: Array,
                      sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (C, n, n) for candidate sensor states ``s_c``.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    batch = sensor_states.shape[:-1]
    s = np.ascontiguousarray(sensor_states, dtype=float).reshape(-1, 6)
    n = 2 * plan.dim
    if plan.covariance is None:
        whiten = np.diag(1.0 / plan.sigmas)
    else:
        whiten = np.linalg.inv(np.linalg.cholesky(plan.covariance))
    codes = np.array([GEOMETRIC_CODES[k] for k in plan.kinds])
    out = np.zeros((s.shape[0], n, n))
    geometric_sums(codes, whiten, np.ascontiguousarray(states, dtype=float),
                   np.ascontiguousarray(weights, dtype=float), s, out)
    return out.reshape(*batch, n, n)
