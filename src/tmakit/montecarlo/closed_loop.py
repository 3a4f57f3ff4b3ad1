"""The closed loop (truth, the planner's move, a measurement, the tracker) and its Monte Carlo.

:func:`run_closed_loop` is one run of Hurtado & Nehorai (2008), §4-5; :func:`closed_loop_study`
runs cases many times, run ``r`` of every case on child ``r`` of ``np.random.SeedSequence(seed)``
(common random numbers, whatever the chunking).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from ..bounds.pcrb_recursion import (
    MIN_RUNS,
    PosteriorInformation,
    noise_factor,
    pcrb_over_runs,
    ratio_interval,
)
from ..core.arrays import Array
from ..core.frames import wrap_angle
from ..data import MeasurementSet
from ..filters import FILTERS, TrackingFilter
from ..motion.dynamics import NearlyConstantVelocity
from ..observation import MeasurementGroup
from ..planning.belief import Belief
from ..planning.candidates import (
    GammaForm,
    check_gamma,
    expected_information,
    step_information,
)
from ..planning.measurement_plan import SensorPlan
from ..planning.policies import Policy, for_run
from ..sensors.platform import PlatformState
from .execution import cluster, execute, whole_number

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = ["TRACKERS", "ClosedLoopStudy", "LoopCase", "LoopChunk", "LoopRecord", "LoopSetup",
           "LoopTask", "closed_loop_study", "run_closed_loop", "run_loop_chunk",
           "simulate_group"]

#: Trackers the loop can run (names of :data:`tmakit.filters.FILTERS`).
TRACKERS = ("pf", "ekf", "ukf")
_STREAMS = 4  # truth, prior, measurements, tracker
_ONE = np.ones(1)
#: Runs per chunk in this process (a chunk's records are kept until the study ends).
LOOP_RUNS_PER_CHUNK = 5
#: Fewest runs for an interval (:data:`tmakit.bounds.pcrb_recursion.MIN_RUNS`).
MIN_RUNS_INTERVAL = MIN_RUNS


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
        whole_number(self.steps, "steps")
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
        whole_number(self.particles, "particles", 2)
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
    t = group.time if time is None else float(time)
    return MeasurementSet.from_si(np.full(m, t), np.full(m, sensor), kinds.astype(str), value,
                                  np.sqrt(np.diagonal(r)), np.repeat(s, m, axis=0),
                                  check=False)  # noisy: a range may be < 0


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
    """Run the closed loop for ``setup.steps`` decisions (Hurtado & Nehorai (2008), §3-5)."""
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


@dataclass(frozen=True, eq=False)
class LoopCase:
    """One case of a closed-loop study.

    Parameters
    ----------
    name : str
        The case's name (a column of the table).
    policy : Policy
        What chooses the steps.
    plan : SensorPlan
        What the sensor measures.
    setup : LoopSetup
        Truth, sensor start, tracker, decisions.
    """

    name: str
    policy: Policy
    plan: SensorPlan
    setup: LoopSetup


@dataclass(frozen=True, eq=False)
class LoopTask:
    """Runs ``first_run .. first_run + len(seeds) - 1`` of one case."""

    case: LoopCase  # The case
    first_run: int  # Index of the first run
    seeds: tuple[np.random.SeedSequence, ...]  # One per run


@dataclass
class LoopChunk:
    """The records of one task's runs, in run order."""

    case: str  # The case's name
    first_run: int  # Index of the first run
    records: list[LoopRecord] = field(default_factory=list)  # One per run

    def __len__(self) -> int:
        """Return the number of runs."""
        return len(self.records)

    def table(self) -> pd.DataFrame:
        """Return the chunk's rows of the per-step table."""
        return pd.concat([pd.DataFrame({"case": np.full(len(rec), self.case, dtype=object),
                                        "run": np.full(len(rec), self.first_run + i,
                                                       dtype=np.int64), **rec.columns()})
                          for i, rec in enumerate(self.records)], ignore_index=True)


def run_loop_chunk(task: LoopTask) -> LoopChunk:
    """Run a task's closed loops (in this process or on a Dask worker)."""
    c = task.case
    return LoopChunk(c.name, task.first_run,
                     [run_closed_loop(c.policy, c.plan, c.setup, s) for s in task.seeds])


@dataclass
class ClosedLoopStudy:
    """The runs of every case of a closed-loop study.

    Attributes
    ----------
    records : dict of str to list of LoopRecord
        Per case, the runs in order.
    seed : int or None
        The study's seed.
    wall_s : float
        Wall time of the study (s).
    setups : dict of str to LoopSetup
        Per case, its loop setup (the prior and the process noise of the bound).

    Every method takes a ``case`` of :attr:`cases` (ValueError for another) and gives its
    figures per decision, (D,) in metres, unless it says otherwise.
    """

    records: dict[str, list[LoopRecord]]
    seed: int | None
    wall_s: float = 0.0
    setups: dict[str, LoopSetup] = field(default_factory=dict)
    _efficiency: dict[tuple[str, float], dict[str, float | None]] = field(
        default_factory=dict, init=False, repr=False, compare=False)

    @property
    def cases(self) -> list[str]:
        """The case names, in order."""
        return list(self.records)

    def runs(self, case: str) -> int:
        """Return the number of runs of ``case``.

        Parameters
        ----------
        case : str

        Returns
        -------
        int
        """
        return len(self._of(case))

    def _of(self, case: str) -> list[LoopRecord]:
        if case not in self.records:
            raise ValueError(f"no case {case!r}; the study has {', '.join(self.records)}")
        return self.records[case]

    def times(self, case: str) -> Array:
        """Return the decision times of ``case``.

        Parameters
        ----------
        case : str

        Returns
        -------
        ndarray, shape (D,)
            s.
        """
        return self._of(case)[0].times

    def stack(self, case: str, name: str) -> Array:
        """Return one per-step field of every run of ``case`` stacked, (runs, D, ...).

        Parameters
        ----------
        case : str
            The case.
        name : str
            A :class:`~tmakit.montecarlo.closed_loop.LoopRecord` field (``error_m``,
            ``criterion_m``, ``range_m``, ``sensor``, ...).

        Returns
        -------
        ndarray
        """
        return np.stack([getattr(r, name) for r in self._of(case)])

    def rmse(self, case: str) -> Array:
        """Return the position RMSE over runs at each step.

        Parameters
        ----------
        case : str

        Returns
        -------
        ndarray, shape (D,)
            m.
        """
        return np.sqrt(np.mean(self.stack(case, "error_m") ** 2, axis=0))

    def criterion(self, case: str) -> Array:
        """Return the RMS over runs of the planning criterion along the flown path, each step.

        What the planner believed (``Gamma`` over the tracker's cloud); not a bound (:meth:`pcrb`).

        Parameters
        ----------
        case : str

        Returns
        -------
        ndarray, shape (D,)
            m.
        """
        return np.sqrt(np.mean(self.stack(case, "criterion_m") ** 2, axis=0))

    def pcrb_covariance(self, case: str) -> Array:
        """Return the posterior CRB of ``case`` at each step, SI.

        Parameters
        ----------
        case : str

        Returns
        -------
        ndarray, shape (D, n, n)
            The bound on the mean-square error matrix of the state.

        Raises
        ------
        ValueError
            For a case the study does not have, or without its setup.
        """
        if case not in self.setups:
            raise ValueError(f"the study holds no setup of case {case!r}: no bound")
        s = self.setups[case]
        return pcrb_over_runs(self.stack(case, "information"), self.times(case),
                              s.prior_covariance, NearlyConstantVelocity(s.dim, s.q),
                              s.platform.time)

    def pcrb(self, case: str) -> Array:
        """Return the posterior CRB of the position at each step (D,), m.

        Parameters
        ----------
        case : str

        Returns
        -------
        ndarray, shape (D,)
            ``sqrt(trace)`` of the position block of :meth:`pcrb_covariance`.
        """
        cov = self.pcrb_covariance(case)
        d = cov.shape[-1] // 2
        return np.sqrt(np.clip(np.einsum("kii->k", cov[:, :d, :d]), 0.0, None))

    def efficiency(self, case: str, level: float = 0.95) -> dict[str, float | None]:
        """Return the final RMSE over the posterior CRB with its Monte Carlo interval.

        Parameters
        ----------
        case : str
        level : float, optional
            The coverage of the interval (:func:`tmakit.bounds.pcrb_recursion.ratio_interval`).

        Returns
        -------
        dict
            ``final_pcrb_m`` (m), ``rmse_over_pcrb`` and its interval ``rmse_over_pcrb_low``,
            ``rmse_over_pcrb_high`` (None under ``MIN_RUNS`` runs).
        """
        if (case, level) not in self._efficiency:
            cov = self.pcrb_covariance(case)[-1]
            p = cov[:cov.shape[-1] // 2, :cov.shape[-1] // 2]
            ratio, low, high = ratio_interval(self.stack(case, "error_m")[:, -1], p, level,
                                              0 if self.seed is None else self.seed)
            self._efficiency[case, level] = {
                "final_pcrb_m": float(np.sqrt(np.trace(p))), "rmse_over_pcrb": ratio,
                "rmse_over_pcrb_low": low, "rmse_over_pcrb_high": high}
        return dict(self._efficiency[case, level])

    def summary(self, case: str) -> dict[str, float | int | None]:
        """Return the case's key figures.

        Parameters
        ----------
        case : str

        Returns
        -------
        dict
            ``final_rmse_m`` (last step, m), the :meth:`efficiency` figures (``final_pcrb_m``,
            ``rmse_over_pcrb`` and its 95 % interval, where the study has the case's setup),
            ``final_criterion_m`` (the planning criterion, m), ``min_range_m`` (true range over
            every run and step, m), ``mean_decision_ms`` (ms), ``runs``.
        """
        bound = self.efficiency(case) if case in self.setups else {}
        return {"final_rmse_m": float(self.rmse(case)[-1]), **bound,
                "final_criterion_m": float(self.criterion(case)[-1]),
                "min_range_m": float(self.stack(case, "range_m").min()),
                "mean_decision_ms": float(self.stack(case, "decision_ms").mean()),
                "runs": self.runs(case)}

    def table(self) -> pd.DataFrame:
        """Return the per-step table of every case and run.

        Returns
        -------
        pandas.DataFrame
            One row per case, run and decision: ``case``, ``run``, ``step``, ``time`` (s),
            ``sensor_x``, ``sensor_y``, ``action``, ``criterion_m``, ``predicted_criterion_m``,
            ``error_m``, ``range_m`` (m), ``decision_ms`` (ms), ``violation_m`` and one
            ``violation_<constraint>_m`` per constraint (m; 0 where a case lacks it).
        """
        frames = [LoopChunk(case, 0, recs).table() for case, recs in self.records.items()]
        out = pd.concat(frames, ignore_index=True)
        viol = [c for c in out.columns if c.startswith("violation_")]
        out[viol] = out[viol].fillna(0.0)
        return out


def closed_loop_study(cases: Sequence[LoopCase], runs: int = 100, seed: int | None = 0,
                      chunk: int | None = None, dask: str | Client | None = None,
                      progress: bool = True,
                      on_chunk: Callable[[LoopChunk], None] | None = None
                      ) -> ClosedLoopStudy:
    """Run every case ``runs`` times.

    Parameters
    ----------
    cases : sequence of LoopCase
        The cases (distinct names).
    runs : int, optional
        Runs per case.
    seed : int or None, optional
        The study's seed (>= 0).
    chunk : int, optional
        Runs per task (default :data:`LOOP_RUNS_PER_CHUNK`); the results do not depend on it.
    dask : str or distributed.Client, optional
        Run the tasks on a Dask cluster (its workers must import tmakit).
    progress : bool, optional
        Show a progress bar.
    on_chunk : callable, optional
        Called with each finished :class:`LoopChunk`.

    Returns
    -------
    ClosedLoopStudy

    Raises
    ------
    ValueError
        On no cases, repeated names, or ``runs``, ``chunk`` or ``seed`` out of range.
    """
    cases = list(cases)
    if not cases:
        raise ValueError("a closed-loop study needs at least one case")
    names = [c.name for c in cases]
    if len(set(names)) != len(names):
        raise ValueError(f"case names must differ, got {names}")
    runs = whole_number(runs, "runs")
    size = LOOP_RUNS_PER_CHUNK if chunk is None else whole_number(chunk, "chunk")
    if seed is not None:
        whole_number(seed, "seed", 0)
    seeds = np.random.SeedSequence(seed).spawn(runs)
    # chunk by chunk, every case for each (finished chunks then cover every case evenly)
    tasks = [LoopTask(c, lo, tuple(seeds[lo:lo + size]))
             for lo in range(0, runs, size) for c in cases]
    with cluster(dask) as client:
        outputs, wall, _ = execute(tasks, client, "closed loop", runs * len(cases), progress,
                                   on_chunk, fn=run_loop_chunk)
    records: dict[str, list[LoopRecord]] = {n: [] for n in names}
    for out in sorted(outputs, key=lambda o: (names.index(o.case), o.first_run)):
        records[out.case].extend(out.records)
    return ClosedLoopStudy(records, seed, wall, {c.name: c.setup for c in cases})
