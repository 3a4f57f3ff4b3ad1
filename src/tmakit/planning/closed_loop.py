"""The closed loop: target truth, the planner's move, a measurement, the tracker, replan.

One run of Hurtado & Nehorai (2008), §4-5, for ``D`` decisions of one interval ``T`` each (the
radar's pulse repetition interval, 0.5 s).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..bounds.pcrb_recursion import PosteriorInformation, noise_factor
from ..core.arrays import Array
from ..core.frames import wrap_angle
from ..data import MeasurementSet
from ..filters import FILTERS, TrackingFilter
from ..measurements import KINDS
from ..motion.dynamics import NearlyConstantVelocity
from ..observation import MeasurementGroup
from ..sensors.platform import PlatformState
from .belief import Belief
from .candidates import GammaForm, check_gamma, expected_information, step_information
from .measurement_plan import SensorPlan
from .policies import Choice, FixedChoice, FixedPolicy, Policy, for_run

__all__ = ["TRACKERS", "Choice", "FixedChoice", "FixedPolicy", "LoopRecord", "LoopSetup",
           "Policy", "run_closed_loop", "simulate_group"]

#: Trackers the loop can run (names of :data:`tmakit.filters.FILTERS`).
TRACKERS = ("pf", "ekf", "ukf")
_STREAMS = 4  # truth, prior, measurements, tracker
_ONE = np.ones(1)


@dataclass(frozen=True)
class LoopSetup:
    """One closed-loop run's fixed inputs (the truth's start, the sensor's, the tracker)."""

    #: True target state at ``time`` (m, m/s), ``[x, y, vx, vy]`` in 2-D; shape (2 dim,)
    target: Array
    platform: PlatformState  # The sensor's start (one state, its time the start time)
    steps: int  # Decisions ``D`` (>= 1)
    interval: float = 0.5  # Decision interval ``T`` (s), one measurement group per decision
    #: Process-noise acceleration standard deviation (m/s^2) of the target's nearly constant
    #: velocity motion, of the truth and of the tracker
    q: float = 0.1
    #: Prior standard deviations of position (m) and velocity (m/s) per axis
    prior_std: tuple[float, float] = (100.0, 5.0)
    #: The tracker: the particle filter with the transitional prior (Hurtado & Nehorai (2008),
    #: §3.1), an EKF or a UKF
    tracker: str = "pf"
    particles: int = 2000  # Particles of the particle filter
    #: How ``Gamma`` of the recorded planning criterion is formed
    criterion_gamma: str = "cloud"

    def __post_init__(self) -> None:
        """Check the options (see Raises)."""
        x = np.asarray(self.target, dtype=float).reshape(-1)
        object.__setattr__(self, "target", x)
        if x.shape[0] not in (4, 6) or not np.all(np.isfinite(x)):
            raise ValueError(f"target must be a finite [x, y, vx, vy] (or 3-D) state, got "
                             f"{x.shape[0]} values")
        if self.platform.shape != ():
            raise ValueError("platform must be one PlatformState (batch shape ())")
        if isinstance(self.steps, bool) or not isinstance(self.steps, int | np.integer) \
                or self.steps < 1:
            raise ValueError(f"steps must be a whole number >= 1, got {self.steps!r}")
        if not (math.isfinite(self.interval) and self.interval > 0):
            raise ValueError(f"interval must be > 0 s, got {self.interval}")
        if not (math.isfinite(self.q) and self.q >= 0):
            raise ValueError(f"q must be >= 0 m/s^2, got {self.q}")
        if len(self.prior_std) != 2 or not all(math.isfinite(s) and s > 0
                                               for s in self.prior_std):
            raise ValueError(f"prior_std must be two positive values (m, m/s), got "
                             f"{self.prior_std}")
        if self.tracker not in TRACKERS:
            raise ValueError(f"tracker must be one of {', '.join(TRACKERS)}, got "
                             f"{self.tracker!r}")
        if isinstance(self.particles, bool) or not isinstance(self.particles, int | np.integer) \
                or self.particles < 2:
            raise ValueError(f"particles must be a whole number >= 2, got {self.particles!r}")
        if self.criterion_gamma not in ("cloud", "mean"):
            raise ValueError(f"criterion_gamma must be 'cloud' or 'mean', got "
                             f"{self.criterion_gamma!r}")

    @property
    def dim(self) -> int:
        """Spatial dimension, 2 or 3."""
        return int(self.target.shape[0] // 2)

    @property
    def prior_covariance(self) -> Array:
        """``P_0`` (n, n), m^2 and m^2/s^2."""
        d = self.dim
        return np.diag([self.prior_std[0] ** 2] * d + [self.prior_std[1] ** 2] * d)


@dataclass
class LoopRecord:
    """One closed-loop run, one entry per decision (at the time after it, ``t_{k+1}``)."""

    times: Array  # Measurement times (s); shape (D,)
    sensor: Array  # Sensor state ``[x, y, z, vx, vy, vz]`` (m, m/s); shape (D, 6)
    #: truth, estimate: True and estimated target state (m, m/s); shape (D, n)
    truth: Array
    estimate: Array
    covariance: Array  # The tracker's covariance (SI); shape (D, n, n)
    #: Chosen action index among a planner's actions (0 for a policy of one candidate: a fixed
    #: action or path, the mission planner's leg); shape (D,)
    action: Array
    decision_ms: Array  # Wall time of each decision (ms; a measurement of this machine); shape (D,)
    #: The planning criterion along the flown path (m): the position RMS of ``J`` carried with
    #: ``Gamma`` over the tracker's cloud (not a bound); shape (D,)
    criterion_m: Array
    #: The policy's prediction for its choice (m): a planner's bound after the step, the mission
    #: planner's at the mission end; shape (D,)
    predicted_criterion_m: Array
    #: error_m, range_m: Position error of the estimate and true sensor-target range (m); shape (D,)
    error_m: Array
    range_m: Array
    #: Per constraint, the violation amount of the chosen step (m, >= 0)
    violations: dict[str, Array]
    #: Fisher information ``Xi`` of each step's measurements at the true target state and the flown
    #: sensor state (SI): the runs' mean is the posterior CRB's ``Gamma``; shape (D, n, n)
    information: Array

    def __len__(self) -> int:
        """Return the number of decisions ``D``."""
        return int(self.times.shape[0])

    def columns(self) -> dict[str, Array]:
        """Return the per-step columns of the run table (without ``run`` and ``case``)."""
        d = len(self)
        cols: dict[str, NDArray[Any]] = {
            "step": np.arange(1, d + 1, dtype=np.int64), "time": self.times,
            "sensor_x": self.sensor[:, 0], "sensor_y": self.sensor[:, 1],
            "action": self.action.astype(np.int64), "criterion_m": self.criterion_m,
            "predicted_criterion_m": self.predicted_criterion_m, "error_m": self.error_m,
            "range_m": self.range_m, "decision_ms": self.decision_ms}
        amounts = list(self.violations.values())
        cols["violation_m"] = np.max(amounts, axis=0) if amounts else np.zeros(d)
        for name, a in self.violations.items():
            cols[f"violation_{name}_m"] = a
        return cols


def simulate_group(group: MeasurementGroup, target: ArrayLike, sensor_state: ArrayLike,
                   rng: np.random.Generator, time: float | None = None,
                   sensor: str = "radar") -> MeasurementSet:
    """Draw the group's measurements of a target: ``h(x) + L n``, ``L L^T = R`` (full ``R``)."""
    s = np.asarray(sensor_state, dtype=float).reshape(1, 6)
    value = group.predict(np.asarray(target, dtype=float), s)
    r = group.covariance
    m = r.shape[0]
    value = value + np.linalg.cholesky(r) @ rng.standard_normal(m)
    value = np.where(group.angle, wrap_angle(value), value)
    kinds = np.empty(m, dtype=object)
    for kind, idx in group.index.items():
        kinds[idx] = kind
    scale = np.array([float(KINDS[k].file_scale) for k in kinds])
    offset = np.array([float(KINDS[k].file_offset) for k in kinds])
    t = group.time if time is None else float(time)
    return MeasurementSet(np.full(m, t), np.full(m, sensor), kinds.astype(str),
                          (value - offset) / scale, np.sqrt(np.diagonal(r)) / scale,
                          np.repeat(s, m, axis=0), check=False)  # noisy: a range may be < 0


def _truth_path(setup: LoopSetup, dynamics: NearlyConstantVelocity,
                rng: np.random.Generator) -> Array:
    """Draw the true states at ``t_0 .. t_D`` (D + 1, n) by eq. 2 with process noise."""
    f = dynamics.transition(setup.interval)
    g = noise_factor(dynamics.noise(setup.interval))
    noise = rng.standard_normal((setup.steps, g.shape[1])) @ g.T
    x = np.empty((setup.steps + 1, setup.target.shape[0]))
    x[0] = setup.target
    for k in range(setup.steps):
        x[k + 1] = f @ x[k] + noise[k]
    return x


def _tracker(setup: LoopSetup, mean: Array, rng: np.random.Generator) -> TrackingFilter:
    cls = FILTERS[setup.tracker]
    kwargs: dict[str, Any] = {"q": setup.q}
    if cls.takes_particles:
        kwargs["particles"] = int(setup.particles)
    if cls.takes_rng:
        kwargs["rng"] = rng
    return cls(mean, setup.prior_covariance, setup.platform.time, **kwargs)


def _with_covariance(rows: MeasurementSet, plan: SensorPlan, t: float
                     ) -> MeasurementSet | MeasurementGroup:
    """Give the rows as the tracker updates with them: with the plan's full ``R`` if any."""
    if plan.covariance is None:
        return rows
    return MeasurementGroup(rows, t, plan.dim, plan.options, plan.nuisance, plan.covariance)


def _streams(seed: int | np.random.SeedSequence | None) -> list[np.random.SeedSequence]:
    """Return the run's four child seeds, as ``seed.spawn(4)`` of a fresh sequence."""
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return [np.random.SeedSequence(ss.entropy, spawn_key=(*ss.spawn_key, i),
                                   pool_size=ss.pool_size) for i in range(_STREAMS)]


def _check_plan(plan: SensorPlan, setup: LoopSetup) -> None:
    if plan.dim != setup.dim:
        raise ValueError(f"the sensor plan is {plan.dim}-D, the target {setup.dim}-D")
    times = plan.measurement_times(setup.interval)
    if times.size != 1 or abs(times[0] - setup.interval) > 1e-9 * setup.interval:
        raise ValueError("the closed loop measures once per decision, at the end of the step "
                         "(a sensor plan without times)")


def _column_name(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name.strip().lower())


def run_closed_loop(policy: Policy, plan: SensorPlan, setup: LoopSetup,
                    seed: int | np.random.SeedSequence | None = None) -> LoopRecord:
    """Run the closed loop for ``setup.steps`` decisions.

    References
    ----------
    Hurtado & Nehorai (2008), sections 3-5 and eqs. 10-13.
    """
    _check_plan(plan, setup)
    r_truth, r_prior, r_meas, r_track = (np.random.default_rng(s) for s in _streams(seed))
    dim, d_steps, n = setup.dim, int(setup.steps), 2 * setup.dim
    dyn = NearlyConstantVelocity(dim, setup.q)
    truth = _truth_path(setup, dyn, r_truth)
    p0 = setup.prior_covariance
    tracker = _tracker(setup, truth[0] + np.linalg.cholesky(p0) @ r_prior.standard_normal(n),
                       r_track)
    belief = Belief.from_filter(tracker, PosteriorInformation.from_prior(
        p0, dyn, setup.platform.time))
    platform = setup.platform
    rec = {k: np.empty((d_steps, *s)) for k, s in (
        ("times", ()), ("sensor", (6,)), ("estimate", (n,)), ("covariance", (n, n)),
        ("action", ()), ("decision_ms", ()), ("criterion_m", ()), ("predicted_criterion_m", ()),
        ("information", (n, n)))}
    violations: dict[str, Array] = {}
    gamma: GammaForm = check_gamma(setup.criterion_gamma)
    policy = for_run(policy)
    for k in range(d_steps):
        start = time.perf_counter()
        choice = policy.recommend(platform, belief)
        rec["decision_ms"][k] = 1e3 * (time.perf_counter() - start)
        idx, step = int(choice.index), choice.step
        platform, t1 = step.end, step.end_time
        sensor = platform.sensor_state
        rows = simulate_group(plan.group, truth[k + 1], sensor, r_meas, t1)
        tracker.predict(t1)
        tracker.update(_with_covariance(rows, plan, t1))
        info = step_information(belief, belief.posterior.information, plan,
                                sensor[None, None], setup.interval, gamma)[0]
        belief = Belief.from_filter(tracker, PosteriorInformation(info, dyn, t1))
        for name, amount in choice.violations.items():
            col = violations.setdefault(_column_name(name), np.zeros(d_steps))
            col[k] = float(np.asarray(amount)[idx])
        rec["times"][k], rec["sensor"][k], rec["action"][k] = t1, sensor, idx
        rec["estimate"][k], rec["covariance"][k] = tracker.state, tracker.covariance
        rec["criterion_m"][k] = float(belief.posterior.position_rms)
        rec["predicted_criterion_m"][k] = float(np.asarray(choice.bound)[idx])
        rec["information"][k] = expected_information(plan, truth[k + 1][None], _ONE,
                                                     sensor[None], "mean")[0]
    est, tru = rec["estimate"], truth[1:]
    return LoopRecord(
        rec["times"], rec["sensor"], tru, est, rec["covariance"],
        rec["action"].astype(np.int64), rec["decision_ms"], rec["criterion_m"],
        rec["predicted_criterion_m"], np.linalg.norm(est[:, :dim] - tru[:, :dim], axis=1),
        np.linalg.norm(tru[:, :dim] - rec["sensor"][:, :dim], axis=1), violations,
        rec["information"])
