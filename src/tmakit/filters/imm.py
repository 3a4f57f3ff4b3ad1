"""Multiple-model filters: a bank of motion models with Markov switching (IMM, and a particle one).

References
----------
Blom & Bar-Shalom (1988), IEEE Trans. Autom. Control 33(8); Bar-Shalom, Li & Kirubarajan
(2001), *Estimation with Applications to Tracking and Navigation*, §11.6.6; McGinnity & Irwin
(2000), "Multiple model bootstrap filter for maneuvering target tracking", IEEE Trans. AES 36(3).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.linalg import symmetrise
from ..motion.dynamics import CoordinatedTurn, NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import Array, KindOptions, ProcessNoise, TrackingFilter, UpdateInfo
from .ekf import ExtendedKalmanFilter
from .gaussian_sum import check_component, component_filter, mixture_moments, update_components
from .particle import ParticleFilter
from .track import Recorder, Track

#: Acceleration std of the default manoeuvre model (m/s^2): twice the 0.5 m/s^2 of an
#: aircraft's or fast vessel's standard-rate turn at 50 m/s (Hoerst & Oispuu 2010, sec. 4),
#: the setting with no divergence on ``benchmarks/imm_hoerst.py``'s runs.
MANOEUVRE_Q = 1.0
#: Acceleration std of the coordinated-turn models (m/s^2).
TURN_Q = 0.05
#: Probability per step of switching model (the default two-model Markov matrix).
SWITCH = 0.01


class InteractingMultipleModel(TrackingFilter):
    """Interacting multiple model filter of EKF, UKF or cubature components.

    Parameters
    ----------
    mean, covariance, time
        The Gaussian prior, given to every model (m, m/s; s).
    component : str, optional
        ``"ekf"``, ``"ukf"`` or ``"ckf"``: the update of each model.
    model_q : sequence of float, optional
        Acceleration std (m/s^2, all axes) of the models after the first; the first model is the
        filter's own ``q``/``dynamics``. Default ``(MANOEUVRE_Q,)``.
    transition : array_like, optional
        ``(M, M)`` Markov matrix, ``p_ij`` from model ``i`` to ``j`` per predict (rows sum to 1);
        default ``1 - SWITCH`` on the diagonal, ``SWITCH / (M - 1)`` elsewhere.
    turn_rates : sequence of float, optional
        Turn rates (rad/s, counter-clockwise positive; a right turn is negative) of further
        coordinated-turn models, after the ``model_q`` models (default none).
    turn_q : float, optional
        Acceleration std of the turn models (m/s^2).
    probabilities : array_like, optional
        The models' prior probabilities ``(M,)`` (default equal).
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter` (the first model).

    Raises
    ------
    ValueError
        A setting out of its range, or a matrix or probabilities that are not stochastic.

    References
    ----------
    Blom & Bar-Shalom (1988); Bar-Shalom, Li & Kirubarajan (2001), §11.6.6.
    """

    name = "imm"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 component: str = "ekf", model_q: Sequence[float] = (MANOEUVRE_Q,),
                 transition: ArrayLike | None = None,
                 turn_rates: Sequence[float] = (), turn_q: float = TURN_Q,
                 probabilities: ArrayLike | None = None,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        check_component(component)
        extra, rates, matrix, self._mu0 = markov_chain(model_q, transition, turn_rates, turn_q,
                                                       probabilities)
        self.component = component
        self.model_q = tuple(extra)
        self.transition = matrix
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        self.models = model_bank(self.dynamics, extra, rates, turn_q)
        self._unit: ExtendedKalmanFilter = component_filter(self, component, mean, covariance)
        self.probability_history: list[list[float]] = []

    def _init_state(self, mean: Array, covariance: Array) -> None:
        count = self._mu0.shape[0]
        self._mu = self._mu0.copy()
        self._m = np.repeat(mean[None], count, axis=0)
        self._p = np.repeat(covariance[None], count, axis=0)

    @property
    def probabilities(self) -> Array:
        """The models' probabilities now ``(M,)`` (a copy)."""
        return self._mu.copy()

    @property
    def model_states(self) -> tuple[Array, Array]:
        """Each model's mean ``(M, n)`` and covariance ``(M, n, n)`` (copies)."""
        return self._m.copy(), self._p.copy()

    @property
    def state(self) -> Array:
        """The combined mean ``(n,)`` (m, m/s)."""
        return self._mu @ self._m

    @property
    def covariance(self) -> Array:
        """The combined covariance ``(n, n)``."""
        return mixture_moments(self._mu, self._m, self._p)[1]

    def _predict(self, dt: float) -> None:
        pij = self.transition
        c = self._mu @ pij  # c_j
        mixed_m, mixed_p = np.empty_like(self._m), np.empty_like(self._p)
        for j, model in enumerate(self.models):
            w = pij[:, j] * self._mu
            total = float(w.sum())
            w = w / total if total > 0 else np.full_like(w, 1.0 / w.shape[0])
            mean, cov = mixture_moments(w, self._m, self._p)
            phi = model.transition(dt)
            mixed_m[j] = phi @ mean
            mixed_p[j] = phi @ cov @ phi.T + model.noise(dt)
            mixed_p[j] = 0.5 * (mixed_p[j] + mixed_p[j].T)
        self._m, self._p = mixed_m, mixed_p
        self._mu = c / c.sum()

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        log_l, nis, dof = update_components(self._unit, group, self._m, self._p, self._mu)
        ok = np.flatnonzero(np.isfinite(log_l))
        if ok.shape[0] == 0:
            self.probability_history.append(self._mu.tolist())
            return self._skip()
        top = float(np.max(log_l[ok]))
        post = np.zeros(log_l.shape[0])
        post[ok] = self._mu[ok] * np.exp(log_l[ok] - top)
        total = float(post.sum())
        self._mu = post / total
        self.probability_history.append(self._mu.tolist())
        return UpdateInfo(nis, dof, top + math.log(total))

    def _track(self, rec: Recorder) -> Track:
        return model_records(self, super()._track(rec))


class MultipleModelParticleFilter(ParticleFilter):
    """Multiple-model particle filter: each particle carries a model of the IMM's Markov chain.

    At each predict every particle draws its next model from its row of the Markov matrix and
    moves by that model; the models' probabilities are the weight shares of their particles.

    Parameters
    ----------
    mean, covariance, time
        The Gaussian prior of the first cloud, as for :class:`ParticleFilter` (m, m/s; s).
    model_q, transition, turn_rates, turn_q, probabilities
        The models and their Markov chain, as for :class:`InteractingMultipleModel`.
    **kwargs
        As for :class:`ParticleFilter` (``particles``, ``rng``, ``q``, ``dynamics``, ...).

    Raises
    ------
    ValueError
        A setting out of its range, as for the two filters above.

    References
    ----------
    McGinnity & Irwin (2000); Ristic, Arulampalam & Gordon (2004), §11.3 (the MM-PF).
    """

    name = "mmpf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 model_q: Sequence[float] = (MANOEUVRE_Q,), transition: ArrayLike | None = None,
                 turn_rates: Sequence[float] = (), turn_q: float = TURN_Q,
                 probabilities: ArrayLike | None = None, **kwargs: Any) -> None:
        extra, rates, self.transition, self._mu0 = markov_chain(model_q, transition, turn_rates,
                                                                turn_q, probabilities)
        self.model_q = tuple(extra)
        super().__init__(mean, covariance, time, **kwargs)
        self.models = model_bank(self.dynamics, extra, rates, turn_q)
        self.probability_history: list[list[float]] = []

    def _init_state(self, mean: Array, covariance: Array) -> None:
        super()._init_state(mean, covariance)
        self._label: NDArray[np.int64] = self.rng.choice(self._mu0.shape[0],
                                                         size=self.n_particles, p=self._mu0)
        self._mu = self._mu0.copy()

    @property
    def labels(self) -> NDArray[np.int64]:
        """Each particle's model index ``(N,)`` (a copy)."""
        return self._label.copy()

    @property
    def probabilities(self) -> Array:
        """The models' probabilities now ``(M,)``: their particles' weight shares."""
        return np.bincount(self._label, weights=self._w,
                           minlength=len(self.models)).astype(float)

    def _predict(self, dt: float) -> None:
        cumulative = np.cumsum(self.transition, axis=1)
        u = self.rng.random(self.n_particles)
        self._label = np.minimum(np.sum(u[:, None] > cumulative[self._label], axis=1),
                                 len(self.models) - 1)
        for j, model in enumerate(self.models):
            k = np.flatnonzero(self._label == j)
            evals, evecs = np.linalg.eigh(symmetrise(model.noise(dt)))
            root = evecs * np.sqrt(np.clip(evals, 0.0, None))
            self._x[:, k] = (model.transition(dt) @ self._x[:, k]
                             + root @ self.rng.standard_normal((root.shape[0], k.shape[0])))
        self._moments = None

    def _carry(self, idx: NDArray[np.int64]) -> None:
        self._mu = self.probabilities
        self._label = self._label[idx]

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        before = self.resamples
        info = super()._update(group)
        if self.resamples == before:
            self._mu = self.probabilities
        self.probability_history.append(self._mu.tolist())
        return info

    def _track(self, rec: Recorder) -> Track:
        return model_records(self, super()._track(rec))


def markov_chain(model_q: Sequence[float], transition: ArrayLike | None,
                 turn_rates: Sequence[float], turn_q: float, probabilities: ArrayLike | None
                 ) -> tuple[list[float], list[float], Array, Array]:
    """Check the model options; give the extra q's, turn rates, Markov matrix and prior."""
    extra = [float(v) for v in np.atleast_1d(np.asarray(model_q, dtype=float))]
    if not all(math.isfinite(v) and v >= 0 for v in extra):
        raise ValueError(f"model_q must be accelerations >= 0 (m/s^2); got {extra}")
    rates = [float(v) for v in np.atleast_1d(np.asarray(turn_rates, dtype=float))]
    if not all(math.isfinite(v) and v != 0 for v in rates):
        raise ValueError(f"turn_rates must be finite and != 0 (rad/s); got {rates}")
    if not (math.isfinite(turn_q) and turn_q >= 0):
        raise ValueError(f"turn_q must be an acceleration >= 0 (m/s^2); got {turn_q}")
    count = 1 + len(extra) + len(rates)
    if transition is None:
        off = SWITCH / max(count - 1, 1)
        matrix = np.full((count, count), off)
        np.fill_diagonal(matrix, 1.0 - SWITCH if count > 1 else 1.0)
    else:
        matrix = np.asarray(transition, dtype=float)
    if matrix.shape != (count, count) or not np.all(np.isfinite(matrix)) \
            or np.any(matrix < 0) or not np.allclose(matrix.sum(axis=1), 1.0, atol=1e-9):
        raise ValueError(f"transition must be a {count}x{count} matrix of probabilities "
                         f">= 0 whose rows sum to 1 ({count} models); got "
                         f"{matrix.tolist()}")
    mu = (np.full(count, 1.0 / count) if probabilities is None
          else np.asarray(probabilities, dtype=float).reshape(-1))
    if mu.shape != (count,) or not np.all(np.isfinite(mu)) or np.any(mu < 0) \
            or not mu.sum() > 0:
        raise ValueError(f"probabilities must be {count} values >= 0, not all 0; got "
                         f"{mu.tolist()}")
    return extra, rates, matrix, mu / mu.sum()


def model_bank(dynamics: NearlyConstantVelocity, extra: Sequence[float],
               rates: Sequence[float], turn_q: float) -> list[NearlyConstantVelocity]:
    """Give the models: ``dynamics``, then its ``extra`` q's, then the turns at ``rates``."""
    if type(dynamics) is not NearlyConstantVelocity:
        raise ValueError("the IMM filter's models are NearlyConstantVelocity dynamics")
    base_q, density = dynamics.axes()
    return [dynamics] + [
        NearlyConstantVelocity(dynamics.dim, tuple(float(max(v, b)) for b in base_q),
                               tuple(density)) for v in extra] + [
        CoordinatedTurn(dynamics.dim, tuple(float(max(turn_q, b)) for b in base_q),
                        tuple(density), turn_rate=w) for w in rates]


def model_records(f: InteractingMultipleModel | MultipleModelParticleFilter, track: Track
                  ) -> Track:
    """Put the filter's model probabilities, models and Markov matrix in ``track.extra``."""
    track.extra.model_probabilities = [list(p) for p in f.probability_history]
    track.extra.models = [{"q": [float(v) for v in m.axes()[0]],
                           "q_density": [float(v) for v in m.axes()[1]],
                           "turn_rate": float(getattr(m, "turn_rate", 0.0)),
                           "prior": float(p)} for m, p in zip(f.models, f._mu0, strict=True)]
    track.extra.transition = f.transition.tolist()
    return track


__all__ = ["MANOEUVRE_Q", "SWITCH", "TURN_Q", "InteractingMultipleModel",
           "MultipleModelParticleFilter"]
