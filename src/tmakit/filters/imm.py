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
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.linalg import symmetrise
from ..motion.dynamics import (
    MAX_ACCELERATION,
    MAX_TURN_RATE,
    CoordinatedTurn,
    NearlyConstantVelocity,
    UnknownRateTurn,
)
from ..observation.groups import MeasurementGroup
from .base import KindOptions, ProcessNoise, TrackingFilter
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import ExtendedKalmanFilter
from .gaussian_sum import (
    component_filter,
    mixture_moments,
    update_components,
)
from .particle import ParticleFilter, ParticleStep, psd_root
from .track import Recorder, Track, UpdateInfo

#: Turn rates of the default coordinated-turn models (deg/s), each to the left and to the right:
#: any rate from 0.53 to 4.2 deg/s within sqrt(2) of a model's (docs/tracking.md, "the model
#: bank", says why none at 0.375 deg/s).
TURN_RATES_DEG = (0.75, 1.5, 3.0)
#: Acceleration std of the coordinated-turn models (m/s^2): a turn between two of the bank's
#: rates is followed by mixing the two.
TURN_Q = 0.05
#: The estimated-rate turn's random walk (rad/s per sqrt(s), :class:`UnknownRateTurn`; None: no
#: such model) and the std of its rate at the start (rad/s: 3 deg/s within 2 sigma).
RATE_NOISE = None
RATE_STD = math.radians(1.5)
#: Mean time (s) the target holds one motion before it changes to any other alike: 25 minutes,
#: as a contact's legs last tens of minutes (docs/tracking.md, "the switches").
SOJOURN = 1500.0
#: The multiple-model particle filter's default turn rates (deg/s, to the left and to the right)
#: and mean stay (s), as it was measured (docs/tracking.md): the IMM's made its smoother worse.
MMPF_TURN_RATES_DEG = (0.375, 0.75, 1.5, 3.0)
MMPF_SOJOURN = 500.0
#: The batch start's position quality (std over range) for a multiple-model filter: a range
#: error at the start is, for bearings, explained by a turn model instead of being corrected.
START_RELATIVE_STD = 0.1


class MarkovChain:
    """The models' switching: a per-step matrix, or a continuous-time chain of one mean stay.

    The chain leaves each of ``count`` models at rate ``1 / sojourn``, to each other alike: for a
    step of ``dt`` s, ``p_ii = 1/M + (1 - 1/M) exp(-M dt / ((M - 1) sojourn))``, the rest of the
    row shared equally, so the chain does not depend on the data rate.
    """

    def __init__(self, count: int, transition: ArrayLike | None,
                 sojourn: float = SOJOURN) -> None:
        if not (isinstance(sojourn, (int, float)) and math.isfinite(sojourn) and sojourn > 0):
            raise ValueError(f"sojourn must be a mean stay > 0 (s); got {sojourn!r}")
        self.count, self.sojourn = count, float(sojourn)
        self.fixed: Array | None = None
        if transition is not None:
            matrix = np.asarray(transition, dtype=float)
            if matrix.shape != (count, count) or not np.all(np.isfinite(matrix)) \
                    or np.any(matrix < 0) \
                    or not np.allclose(matrix.sum(axis=1), 1.0, atol=1e-9):
                raise ValueError(f"transition must be a {count}x{count} matrix of "
                                 f"probabilities >= 0 whose rows sum to 1 ({count} models); "
                                 f"got {matrix.tolist()}")
            self.fixed = matrix
        self._cache: tuple[float, Array] = (math.nan, np.eye(count))

    def matrix(self, dt: float) -> Array:
        """Give the transition matrix of a step of ``dt`` s (the fixed one if given)."""
        if self.fixed is not None:
            return self.fixed
        m = self.count
        if dt != self._cache[0] and m > 1:
            stay = math.exp(-m * max(dt, 0.0) / ((m - 1) * self.sojourn))
            p = np.full((m, m), (1.0 - stay) / m)
            np.fill_diagonal(p, stay + (1.0 - stay) / m)
            self._cache = (dt, p)
        return self._cache[1]


class _MultipleModels(TrackingFilter):
    """What the two multiple-model filters share: the Markov chain and the models' records."""

    start_relative_std = START_RELATIVE_STD
    start_by_likelihood = True  # judged by the batch start's covariance widened to its likelihood
    chain: MarkovChain
    models: list[NearlyConstantVelocity]
    _mu0: Array
    probability_history: list[list[float]]

    @property
    def transition(self) -> Array:
        """The Markov matrix per step given, or the chain's for a 1-s step ``(M, M)``."""
        return self.chain.matrix(1.0)

    def _track(self, rec: Recorder) -> Track:
        """Record the model probabilities, the models and the Markov matrix in ``extra``."""
        track = super()._track(rec)
        track.extra.model_probabilities = [list(p) for p in self.probability_history]
        track.extra.models = [{"q": [float(v) for v in m.axes()[0]],
                               "q_density": [float(v) for v in m.axes()[1]],
                               "turn_rate": None if isinstance(m, UnknownRateTurn)
                               else float(getattr(m, "turn_rate", 0.0)),
                               **({"rate_noise": m.rate_noise}
                                  if isinstance(m, UnknownRateTurn) else {}),
                               "prior": float(p),
                               "sojourn": None if self.chain.fixed is not None
                               else self.chain.sojourn}
                              for m, p in zip(self.models, self._mu0, strict=True)]
        track.extra.transition = self.transition.tolist()
        return track


class InteractingMultipleModel(_MultipleModels):
    """Interacting multiple model filter of EKF, UKF or cubature components.

    Parameters
    ----------
    mean, covariance, time
        The Gaussian prior, given to every model (m, m/s; s).
    component : str, optional
        ``"ekf"``, ``"ukf"`` or ``"ckf"``: the update of each model.
    iterations : int, optional
        Linearisations per update of EKF components (> 1: the iterated EKF; default 1, which
        measured better here than the Gaussian sum's 5, docs/tracking.md).
    model_q : sequence of float, optional
        Acceleration std (m/s^2, all axes) of white-noise manoeuvre models after the first;
        the first model is the filter's own ``q``/``dynamics``. Default none.
    transition : array_like, optional
        ``(M, M)`` Markov matrix, ``p_ij`` from model ``i`` to ``j`` per predict (rows sum to 1);
        default the continuous-time chain of ``sojourn`` (:class:`MarkovChain`).
    turn_rates : sequence of float, optional
        Turn rates (rad/s, counter-clockwise positive; a right turn is negative) of the
        coordinated-turn models, after the ``model_q`` models. Default :data:`TURN_RATES_DEG`
        to the left and to the right.
    turn_q : float, optional
        Acceleration std of the turn models (m/s^2).
    rate_noise : float or None, optional
        With a value, a coordinated turn whose rate is estimated (:class:`UnknownRateTurn`,
        its rate's random walk in rad/s per sqrt(s)) is a model too, after the ``model_q``
        models and before the fixed-rate turns; its rate starts at 0 with std ``rate_std``.
        Default :data:`RATE_NOISE`; ``None``: no such model.
    rate_std : float, optional
        The std of the turn rate at the start (rad/s, :data:`RATE_STD`).
    sojourn : float, optional
        Mean stay (s) in a model, for the default chain (:data:`SOJOURN`).
    probabilities : array_like, optional
        The models' prior probabilities ``(M,)`` (default equal).
    history : bool, optional
        Keep each update's models and rows in ``track.extra.history``, for the smoother.
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
                 component: str = "ekf", iterations: int = 1,
                 model_q: Sequence[float] = (),
                 transition: ArrayLike | None = None,
                 turn_rates: Sequence[float] | None = None, turn_q: float = TURN_Q,
                 rate_noise: float | None = RATE_NOISE, rate_std: float = RATE_STD,
                 sojourn: float = SOJOURN,
                 probabilities: ArrayLike | None = None, history: bool = False,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        if not (isinstance(rate_std, (int, float)) and math.isfinite(rate_std) and rate_std > 0):
            raise ValueError(f"rate_std must be a turn rate's std > 0 (rad/s); got {rate_std!r}")
        self.rate_noise, self.rate_std = rate_noise, float(rate_std)
        extra, rates, self.chain, self._mu0 = markov_chain(model_q, transition, turn_rates,
                                                           turn_q, sojourn, probabilities,
                                                           rate_noise)
        self.component = component
        self.model_q = tuple(extra)
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        self.models = model_bank(self.dynamics, extra, rates, turn_q, rate_noise)
        self._unit = component_filter(self, component, iterations, mean, covariance)
        self.iterations = self._unit.iterations
        self.probability_history: list[list[float]] = []
        #: Each update's models and rows (with ``history=True``), for :func:`imm_smooth`.
        self.history = ModelHistory(self.models, self._unit, [],
                                    self.rate_std) if history else None
        self._switch = self.chain.matrix(0.0)

    def _init_state(self, mean: Array, covariance: Array) -> None:
        count = self._mu0.shape[0]
        self._mu = self._mu0.copy()
        self._m = np.repeat(mean[None], count, axis=0)
        self._p = np.repeat(covariance[None], count, axis=0)
        if self.rate_noise is not None:  # every model carries the rate; only its own uses it
            self._m, self._p = with_rate(self._m, self._p, self.rate_std)

    @property
    def probabilities(self) -> Array:
        """The models' probabilities now ``(M,)`` (a copy)."""
        return self._mu.copy()

    @property
    def model_states(self) -> tuple[Array, Array]:
        """Each model's mean ``(M, n)`` and covariance ``(M, n, n)`` (copies; no turn rate)."""
        n = self.dynamics.n_state
        return self._m[:, :n].copy(), self._p[:, :n, :n].copy()

    @property
    def turn_rate(self) -> tuple[float, float] | None:
        """The estimated-rate turn's rate and std now (rad/s); ``None`` without that model."""
        j = next((j for j, m in enumerate(self.models) if isinstance(m, UnknownRateTurn)), None)
        if j is None:
            return None
        return float(self._m[j, -1]), float(math.sqrt(max(self._p[j, -1, -1], 0.0)))

    @property
    def state(self) -> Array:
        """The combined mean ``(n,)`` (m, m/s)."""
        return self._mu @ self._m[:, :self.dynamics.n_state]

    @property
    def covariance(self) -> Array:
        """The combined covariance ``(n, n)``."""
        n = self.dynamics.n_state
        return mixture_moments(self._mu, self._m[:, :n], self._p[:, :n, :n])[1]

    def _predict(self, dt: float) -> None:
        pij = self._switch = self.chain.matrix(dt)
        c = self._mu @ pij  # c_j
        mixed_m, mixed_p = np.empty_like(self._m), np.empty_like(self._p)
        rated = self.rate_noise is not None
        for j, model in enumerate(self.models):
            w = pij[:, j] * self._mu
            total = float(w.sum())
            w = w / total if total > 0 else np.full_like(w, 1.0 / w.shape[0])
            if rated:
                mean, cov = mix_into(j, self.models, w, self._m, self._p)
                moved, jac = model.propagate(mean, dt)
            else:  # (every model linear, one state: the filter's step kept lean)
                mean, cov = mixture_moments(w, self._m, self._p)
                jac = model.transition(dt)
                moved = jac @ mean
            k = moved.shape[0]
            if k < mixed_m.shape[1]:  # a model without the rate keeps its place holder
                mixed_m[j], mixed_p[j] = self._m[j], self._p[j]
            mixed_m[j, :k] = moved
            p = jac @ cov @ jac.T + model.noise(dt)
            mixed_p[j, :k, :k] = 0.5 * (p + p.T)
        self._m, self._p = mixed_m, mixed_p
        self._mu = c / c.sum()

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        log_l, nis, dof = update_models(self._unit, group, self.models, self._m, self._p,
                                        self._mu)
        ok = np.flatnonzero(np.isfinite(log_l))
        if ok.shape[0] == 0:
            self._record(None)
            return self._skip()
        top = float(np.max(log_l[ok]))
        post = np.zeros(log_l.shape[0])
        post[ok] = self._mu[ok] * np.exp(log_l[ok] - top)
        total = float(post.sum())
        self._mu = post / total
        self._record(group)
        return UpdateInfo(nis, dof, top + math.log(total))

    def _record(self, group: MeasurementGroup | None) -> None:
        self.probability_history.append(self._mu.tolist())
        if self.history is not None:
            self.history.steps.append(ModelStep(self.time, self._mu.copy(), self._m.copy(),
                                                self._p.copy(), self._switch, group))


class MultipleModelParticleFilter(_MultipleModels, ParticleFilter):
    """Multiple-model particle filter: each particle carries a model of the IMM's Markov chain.

    At each predict every particle draws its next model from its row of the Markov matrix and
    moves by that model; the models' probabilities are the weight shares of their particles.

    Parameters
    ----------
    mean, covariance, time
        The Gaussian prior of the first cloud, as for :class:`ParticleFilter` (m, m/s; s).
    model_q, transition, turn_rates, turn_q, sojourn, probabilities
        The models and their Markov chain, as for :class:`InteractingMultipleModel`, but by
        default the turns of :data:`MMPF_TURN_RATES_DEG` and the stay :data:`MMPF_SOJOURN`.
    particles, rng, resample_threshold, regularise, bandwidth, history, bearing_start
        As for :class:`ParticleFilter`.
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

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
                 model_q: Sequence[float] = (), transition: ArrayLike | None = None,
                 turn_rates: Sequence[float] | None = None, turn_q: float = TURN_Q,
                 sojourn: float = MMPF_SOJOURN, probabilities: ArrayLike | None = None,
                 particles: int = 1000, rng: np.random.Generator | int | None = None,
                 resample_threshold: float = 0.5, regularise: bool = True,
                 bandwidth: float = 1.0, history: bool = False,
                 bearing_start: tuple[BearingPrior, FirstBearing] | None = None,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        extra, rates, self.chain, self._mu0 = markov_chain(
            model_q, transition, turn_rates, turn_q, sojourn, probabilities,
            default_rates_deg=MMPF_TURN_RATES_DEG)
        self.model_q = tuple(extra)
        self._switch = self.chain.matrix(0.0)
        super().__init__(mean, covariance, time, particles=particles, rng=rng,
                         resample_threshold=resample_threshold, regularise=regularise,
                         bandwidth=bandwidth, history=history, bearing_start=bearing_start,
                         q=q, dynamics=dynamics, options=options, nuisance=nuisance)
        self.models = model_bank(self.dynamics, extra, rates, turn_q)
        self.probability_history: list[list[float]] = []

    def _init_state(self, mean: Array, covariance: Array) -> None:
        super()._init_state(mean, covariance)
        self._label: NDArray[np.int64] = self.rng.choice(self._mu0.shape[0],
                                                         size=self.n_particles, p=self._mu0)
        self._mu = self._mu0.copy()
        if self.history:
            self.history[-1] = LabelledStep(**vars(self.history[-1]), labels=self._label.copy(),
                                            transition=self._switch)

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
        self._switch = self.chain.matrix(dt)
        cumulative = np.cumsum(self._switch, axis=1)
        u = self.rng.random(self.n_particles)
        self._label = np.minimum(np.sum(u[:, None] > cumulative[self._label], axis=1),
                                 len(self.models) - 1)
        for j, model in enumerate(self.models):
            k = np.flatnonzero(self._label == j)
            root = psd_root(model.noise(dt))
            self._x[:, k] = (model.transition(dt) @ self._x[:, k]
                             + root @ self.rng.standard_normal((root.shape[0], k.shape[0])))
        self._moments = None

    def _carry(self, idx: NDArray[np.int64]) -> None:
        self._mu = self.probabilities
        self._label = self._label[idx]

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        before, labels = self.resamples, self._label.copy()
        kept = len(self.history) if self.history is not None else 0
        info = super()._update(group)
        if self.resamples == before:
            self._mu = self.probabilities
        self.probability_history.append(self._mu.tolist())
        if self.history is not None and len(self.history) > kept:
            # the labels of the weighted cloud: those before any resampling
            self.history[-1] = LabelledStep(**vars(self.history[-1]), labels=labels,
                                            transition=self._switch)
        return info


@dataclass(frozen=True)
class ModelStep:
    """The IMM's models after one update: what its smoother needs."""

    time: float  # (s)
    probabilities: Array  # (M,)
    means: Array  # (M, n) (m, m/s)
    covariances: Array  # (M, n, n)
    transition: Array  # (M, M): the Markov matrix of the predict into this update
    group: MeasurementGroup | None  # the update's rows (for the backward filter)


@dataclass
class ModelHistory:
    """What the IMM smoother needs: the models, the update's arithmetic, each update's models."""

    models: list[NearlyConstantVelocity]
    unit: ExtendedKalmanFilter
    steps: list[ModelStep]
    rate_std: float = RATE_STD  # the turn rate's std at the start (rad/s)


@dataclass(frozen=True)
class LabelledStep(ParticleStep):
    """A multiple-model particle filter's weighted cloud with each particle's model."""

    labels: NDArray[np.int64] | None = None  # (N,)
    transition: Array | None = None  # (M, M): the Markov matrix of the predict into this step


def markov_chain(model_q: Sequence[float], transition: ArrayLike | None,
                 turn_rates: Sequence[float] | None, turn_q: float, sojourn: float,
                 probabilities: ArrayLike | None, rate_noise: float | None = None,
                 default_rates_deg: Sequence[float] = TURN_RATES_DEG
                 ) -> tuple[list[float], list[float], MarkovChain, Array]:
    """Check the model options; give the extra q's, turn rates, Markov chain and prior.

    Without ``turn_rates``, the turns of ``default_rates_deg`` (deg/s) to the left and right.
    """
    extra = [float(v) for v in np.atleast_1d(np.asarray(model_q, dtype=float))]
    if not all(0 <= v <= MAX_ACCELERATION for v in extra):
        raise ValueError(f"model_q must be accelerations within [0, {MAX_ACCELERATION:g}] "
                         f"m/s^2 (1000 g); got {extra}")
    if turn_rates is None:
        turn_rates = [math.radians(s * v) for v in default_rates_deg for s in (1.0, -1.0)]
    rates = [float(v) for v in np.atleast_1d(np.asarray(turn_rates, dtype=float))]
    top = f"{MAX_TURN_RATE:.4g} rad/s ({math.degrees(MAX_TURN_RATE):g} deg/s, a turn a second)"
    if not all(v != 0 and abs(v) <= MAX_TURN_RATE for v in rates):
        raise ValueError(f"turn_rates must be != 0 and within +-{top}; got {rates} rad/s "
                         f"({', '.join(f'{math.degrees(v):g}' for v in rates)} deg/s)")
    if not (math.isfinite(turn_q) and turn_q >= 0):
        raise ValueError(f"turn_q must be an acceleration >= 0 (m/s^2); got {turn_q}")
    if rate_noise is not None and not isinstance(rate_noise, (int, float)):
        raise ValueError(f"rate_noise must be a number or None; got {rate_noise!r}")
    if rate_noise is not None and not 0 <= rate_noise <= MAX_TURN_RATE:
        raise ValueError(f"rate_noise must be a turn rate's random walk within [0, {top}] per "
                         f"sqrt(s), or None for no estimated-rate turn; got {rate_noise!r} "
                         f"({math.degrees(rate_noise):g} deg/s)")
    count = 1 + len(extra) + (rate_noise is not None) + len(rates)
    chain = MarkovChain(count, transition, sojourn)
    mu = (np.full(count, 1.0 / count) if probabilities is None
          else np.asarray(probabilities, dtype=float).reshape(-1))
    if mu.shape != (count,) or not np.all(np.isfinite(mu)) or np.any(mu < 0) \
            or not mu.sum() > 0:
        raise ValueError(f"probabilities must be {count} values >= 0, not all 0; got "
                         f"{mu.tolist()}")
    return extra, rates, chain, mu / mu.sum()


def model_bank(dynamics: NearlyConstantVelocity, extra: Sequence[float],
               rates: Sequence[float], turn_q: float, rate_noise: float | None = None
               ) -> list[NearlyConstantVelocity]:
    """Give the models: ``dynamics``, its ``extra`` q's, the estimated-rate turn, the turns."""
    if type(dynamics) is not NearlyConstantVelocity:
        raise ValueError("the IMM filter's models are NearlyConstantVelocity dynamics")
    base_q, density = dynamics.axes()
    turn_axes = tuple(float(max(turn_q, b)) for b in base_q)
    rated = [] if rate_noise is None else [
        UnknownRateTurn(dynamics.dim, turn_axes, tuple(density), rate_noise=float(rate_noise))]
    return [dynamics] + [
        NearlyConstantVelocity(dynamics.dim, tuple(float(max(v, b)) for b in base_q),
                               tuple(density)) for v in extra] + rated + [
        CoordinatedTurn(dynamics.dim, tuple(float(max(turn_q, b)) for b in base_q),
                        tuple(density), turn_rate=w) for w in rates]


def with_rate(means: Array, covs: Array, rate_std: float) -> tuple[Array, Array]:
    """Give the models' Gaussians ``(M, n)``, ``(M, n, n)`` with a turn rate ``0 +- rate_std``."""
    count = means.shape[0]
    out_p = np.pad(covs, ((0, 0), (0, 1), (0, 1)))
    out_p[:, -1, -1] = rate_std**2
    return np.concatenate([means, np.zeros((count, 1))], axis=1), out_p


def mix_into(j: int, models: Sequence[NearlyConstantVelocity], weights: Array, means: Array,
             covs: Array) -> tuple[Array, Array]:
    """Give the mixture of the models' Gaussians with ``weights`` in model ``j``'s state.

    A model without a turn rate mixes the others' position and velocity. Into the
    estimated-rate turn, a model without the rate brings the turn model's own estimate of it
    (mean and variance, uncorrelated with the rest): the mixing of unequal states of
    Granström, Willett & Bar-Shalom (2015), which does not pull the rate towards 0 as a
    straight model taken to turn at rate 0 would.
    """
    n = models[j].n_state
    if n == means.shape[1] and not isinstance(models[j], UnknownRateTurn):
        return mixture_moments(weights, means, covs)
    if not isinstance(models[j], UnknownRateTurn):
        return mixture_moments(weights, means[:, :n], covs[:, :n, :n])
    filled_m, filled_p = means.copy(), covs.copy()
    for i, model in enumerate(models):
        if not isinstance(model, UnknownRateTurn):
            filled_m[i, -1] = means[j, -1]
            filled_p[i, -1, :] = filled_p[i, :, -1] = 0.0
            filled_p[i, -1, -1] = covs[j, -1, -1]
    return mixture_moments(weights, filled_m, filled_p)


def update_models(unit: ExtendedKalmanFilter, group: MeasurementGroup,
                  models: Sequence[NearlyConstantVelocity], means: Array, covs: Array,
                  weights: Array) -> tuple[Array, float, int]:
    """Update each model's Gaussian in place, as :func:`update_components` (the same returns).

    The rows see position and velocity only, so the component filter updates those; the
    turn rate of an estimated-rate turn follows by its regression on them, unchanged by the
    rows given them (``r | x`` is Gaussian with mean ``r + G (x - m_x)``,
    ``G = P_rx P_xx^-1``): ``r' = r + G (x' - x)``, ``P_rx' = G P_xx'``,
    ``P_rr' = P_rr - G (P_xx - P_xx') G^T``, which is the augmented filter's update whenever
    it linearises (or draws its points) as the component does.
    """
    n = means.shape[1] if not any(isinstance(m, UnknownRateTurn) for m in models) \
        else means.shape[1] - 1
    if n == means.shape[1]:
        return update_components(unit, group, means, covs, weights)
    kin_m, kin_p = means[:, :n].copy(), covs[:, :n, :n].copy()
    log_l, nis, dof = update_components(unit, group, kin_m, kin_p, weights)
    for j, model in enumerate(models):
        if isinstance(model, UnknownRateTurn) and np.isfinite(log_l[j]):
            gain = np.linalg.solve(covs[j, :n, :n], covs[j, :n, n])
            cross = gain @ kin_p[j]
            means[j, n] += gain @ (kin_m[j] - means[j, :n])
            covs[j, n, n] -= gain @ (covs[j, :n, :n] - kin_p[j]) @ gain
            covs[j, n, :n] = covs[j, :n, n] = cross
    means[:, :n], covs[:, :n, :n] = kin_m, kin_p
    return log_l, nis, dof


def models_of(track: Track) -> list[NearlyConstantVelocity]:
    """Rebuild a multiple-model track's models from ``track.extra.models``."""
    dim = len(track.state_names) // 2
    return [UnknownRateTurn(dim, tuple(m["q"]), tuple(m["q_density"]),
                            rate_noise=float(m["rate_noise"])) if m.get("rate_noise") is not None
            else CoordinatedTurn(dim, tuple(m["q"]), tuple(m["q_density"]),
                                 turn_rate=float(m["turn_rate"])) if m["turn_rate"]
            else NearlyConstantVelocity(dim, tuple(m["q"]), tuple(m["q_density"]))
            for m in track.extra.models or ()]


#: Factor on the forward filter's last covariance that starts the backward filter of the IMM
#: smoother: ten times the std, so that the backward filter carries (almost) only the data.
BACKWARD_INFLATE = 100.0


def _stationary(transition: Array) -> Array:
    """Give a Markov matrix's stationary probabilities (from equal ones, 2^20 steps on)."""
    start = np.full(transition.shape[0], 1.0 / transition.shape[0])
    pi = start @ np.linalg.matrix_power(transition, 1 << 20)
    return pi / pi.sum() if np.all(np.isfinite(pi)) and pi.sum() > 0 else start


def imm_smooth(track: Track) -> tuple[Array, Array, Array]:
    """Smooth an IMM track (its ``extra.history``): the smoothed means, covariances, model shares.

    A backward IMM filter, started from the forward filter's last estimate with its covariance
    times :data:`BACKWARD_INFLATE`, its models mixed by the reverse chain, fused with the forward
    filter model by model at every update (docs/tracking.md, "The IMM smoother"): the two-filter
    IMM smoother of Helmick, Blair & Hoffman (1995), IEEE Trans. Inf. Theory 41(6), each fusion
    that of two independent Gaussians (Fraser & Potter 1969, IEEE Trans. Autom. Control 14(4)).
    """
    history: ModelHistory = track.extra.history
    models, count = history.models, len(history.models)
    steps = list(history.steps)
    if len(steps) == len(track) - 1:  # the start's row: fused, never updated
        steps.insert(0, ModelStep(float(track.times[0]), np.asarray(
            (track.extra.model_probabilities or [[1.0]])[0]), *_row_models(track, 0, 1.0),
            np.eye(count), None))
    if len(steps) != len(track) or not np.allclose([s.time for s in steps], track.times):
        raise ValueError("the IMM filter's model states do not match the track's rows; it "
                         "cannot be smoothed")
    out_mu = np.array([s.probabilities for s in steps])
    out_m, out_p = track.states.copy(), track.covariances.copy()
    mu = _stationary(steps[-1].transition)
    means, covs = _row_models(track, len(track) - 1, BACKWARD_INFLATE)
    mu = _backward_update(history, steps[-1].group, means, covs, mu)
    for k in range(len(steps) - 2, -1, -1):
        dt = float(steps[k + 1].time - steps[k].time)
        pij = steps[k + 1].transition
        pi = _stationary(pij)
        moved_m, moved_p = means.copy(), covs.copy()
        for j, model in enumerate(models):
            w = model.n_state
            moved, back = model.propagate(means[j, :w], -dt)
            moved_m[j, :w] = moved
            moved_p[j, :w, :w] = back @ (covs[j, :w, :w] + model.noise(dt)) @ back.T
        reverse = pij * pi[:, None] / np.maximum(pi @ pij, 1e-300)[None, :]  # (i, j)
        joint = reverse * mu[None, :]
        c = joint.sum(axis=1)
        weights = np.divide(joint, c[:, None], out=np.full_like(joint, 1.0 / count),
                            where=c[:, None] > 0)
        mu = c / c.sum()
        for i, model in enumerate(models):
            w = model.n_state
            means[i], covs[i] = moved_m[i], moved_p[i]  # (the place holder of the rate)
            means[i, :w], covs[i, :w, :w] = mix_into(i, models, weights[i], moved_m, moved_p)
        out_m[k], out_p[k], out_mu[k] = _fuse(steps[k], means, covs, mu, pi,
                                              track.states.shape[1])
        if steps[k].group is not None:
            mu = _backward_update(history, steps[k].group, means, covs, mu)
    return out_m, out_p, out_mu


def _row_models(track: Track, k: int, inflate: float) -> tuple[Array, Array]:
    """Give every model the track's row ``k``, its covariance times ``inflate`` (and a rate)."""
    history: ModelHistory = track.extra.history
    count = len(history.models)
    means = np.repeat(track.states[k:k + 1], count, axis=0)
    covs = np.repeat(track.covariances[k:k + 1] * inflate, count, axis=0)
    if any(isinstance(m, UnknownRateTurn) for m in history.models):
        return with_rate(means, covs, math.sqrt(inflate) * history.rate_std)
    return means, covs


def _fuse(forward: ModelStep, means: Array, covs: Array, mu: Array, pi: Array, n: int
          ) -> tuple[Array, Array, Array]:
    """Fuse each model's two Gaussians, weighed by both and their overlap in the first ``n``."""
    total = forward.covariances + covs
    gain = np.swapaxes(np.linalg.solve(total, forward.covariances), -1, -2)
    d = means - forward.means
    fused_m = forward.means + np.einsum("iab,ib->ia", gain, d)
    fused_p = forward.covariances - gain @ forward.covariances
    chol = np.linalg.cholesky(symmetrise(total[:, :n, :n]))
    white = np.linalg.solve(chol, d[:, :n, None])[..., 0]
    with np.errstate(divide="ignore"):
        log_w = (np.log(forward.probabilities) + np.log(mu) - np.log(pi)
                 - 0.5 * np.einsum("ia,ia->i", white, white)
                 - np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(axis=-1))
    top = np.max(log_w)
    w = np.exp(log_w - top) if np.isfinite(top) else forward.probabilities.copy()
    w = w / w.sum()
    mean, cov = mixture_moments(w, fused_m[:, :n], fused_p[:, :n, :n])
    return mean, cov, w


def _backward_update(history: ModelHistory, group: MeasurementGroup | None, means: Array,
                     covs: Array, mu: Array) -> Array:
    """Update the backward filter's models in place; give their probabilities."""
    if group is None:
        return mu
    log_l, _, _ = update_models(history.unit, group, history.models, means, covs, mu)
    ok = np.isfinite(log_l)
    if not ok.any():
        return mu
    post = np.where(ok, mu * np.exp(np.where(ok, log_l, 0.0) - np.max(log_l[ok])), 0.0)
    return post / post.sum() if post.sum() > 0 else mu


__all__ = ["BACKWARD_INFLATE", "MMPF_SOJOURN", "MMPF_TURN_RATES_DEG", "SOJOURN",
           "START_RELATIVE_STD", "TURN_Q", "TURN_RATES_DEG",
           "InteractingMultipleModel", "MarkovChain", "ModelHistory", "ModelStep",
           "MultipleModelParticleFilter", "imm_smooth", "models_of"]
