"""The predicted information of every candidate step at once (the heart of the planner).

Each candidate's Bayesian information is carried over one decision interval by the recursion of
Hurtado & Nehorai (2008), eq. 10, ``J <- (Q + F J^{-1} F^T)^{-1}``, ``J <- J + Gamma``, with
``Gamma`` the information ``Xi`` at the predicted cloud's mean (``"mean"``, the paper's choice,
eq. 13) or averaged over the cloud (``"cloud"``, section 4.2); vectorised over candidates and cloud.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..bounds.pcrb_recursion import PosteriorInformation, predict_information
from ..core.arrays import Array
from ..core.linalg import symmetrise
from .belief import Belief
from .cloud_information import cloud_information, supports
from .measurement_plan import SensorPlan
from .planar_information import planar_information, supports_planar

GammaForm = Literal["mean", "cloud"]
GAMMA_FORMS: tuple[str, ...] = ("mean", "cloud")


def check_gamma(gamma: str) -> GammaForm:
    """Return ``gamma`` if it names a form of ``Gamma``."""
    if gamma not in GAMMA_FORMS:
        raise ValueError(f"gamma must be 'mean' (Xi at the predicted mean, Hurtado & Nehorai "
                         f"(2008), section 4.2) or 'cloud' (the expectation over the cloud); "
                         f"got {gamma!r}")
    return gamma  # type: ignore[return-value]


def expected_information(plan: SensorPlan, states: Array, weights: Array,
                         sensor_states: Array, gamma: GammaForm) -> Array:
    """Return ``Gamma`` for each candidate sensor state at one measurement time.

    Parameters
    ----------
    plan : SensorPlan
        What is measured.
    states : ndarray, shape (N, n)
        The predicted target cloud at the measurement time.
    weights : ndarray, shape (N,)
        Its normalised weights.
    sensor_states : ndarray, shape (*B, 6)
        Candidate sensor states at that time.
    gamma : {"mean", "cloud"}
        How ``Gamma`` is formed.

    Returns
    -------
    ndarray, shape (*B, n, n)
        SI.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13, section 4.2.
    """
    if gamma == "mean" or states.shape[0] == 1:
        states, weights = (weights @ states)[None, :], _ONE
    if supports_planar(plan, sensor_states):
        return planar_information(plan, states, weights, sensor_states)
    if supports(plan):
        return cloud_information(plan, states, weights, sensor_states)
    xi = plan.information(states, sensor_states)  # (*B, N, n, n)
    return np.einsum("...kij,k->...ij", xi, weights)


def step_information(belief: Belief, information: Array, plan: SensorPlan,
                     sensor_states: Array, interval: float, gamma: GammaForm,
                     cloud: tuple[Array, Array] | None = None) -> Array:
    """Carry ``J`` through one decision step for every candidate at once.

    Parameters
    ----------
    belief : Belief
        Supplies the dynamics (``belief.posterior``), the decision time and — unless
        ``cloud`` is given — the target cloud at that time.
    information : ndarray, shape (*B, n, n) or (n, n)
        ``J`` at the start of the step (one per candidate, or one for all).
    plan : SensorPlan
        What is measured, and when in the step.
    sensor_states : ndarray, shape (*B, k, 6)
        Candidate sensor states at the plan's ``k`` measurement times.
    interval : float
        The decision interval ``T``, s.
    gamma : {"mean", "cloud"}
        How ``Gamma`` is formed.
    cloud : tuple of ndarray, optional
        ``(states (N, n), weights (N,))`` at the start of the step, when not the belief's.

    Returns
    -------
    ndarray, shape (*B, n, n)
        ``J_{k+1}`` at the end of the step, SI.

    Raises
    ------
    ValueError
        If ``sensor_states`` do not have one time per measurement of the plan.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13.
    """
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
