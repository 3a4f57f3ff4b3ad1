"""Speed of one planning decision: tmakit's ``Planner.recommend`` beside Stone Soup's
``BruteForceSensorManager``, on the same 15 candidate positions, in the same run.

The decision (Hurtado & Nehorai (2008), section 5 geometry, scenario ``hurtado2008``): the
radar at (0, 0) heading North at 50 m/s, the target estimated at (-2 km, 15 km) moving East at
25 m/s with covariance diag(500^2, 500^2, 10^2, 10^2) (m, m/s); nearly-constant-velocity
dynamics with q = ``--q`` m/s^2 per axis (Chen & Sun, §2.1, the same ``Q_k`` on both sides);
one azimuth (sigma 1 deg) and one range (sigma 30 m) at the end of the 0.5 s step.  The
candidates are the 15 actions of ``HURTADO_NEHORAI_2008`` (speed x0.9 / x1 / x1.1, heading
-10..+10 deg), flown for one step by ``PlatformKinematics.step``.

tmakit, on those 15 candidates:

* ``mean``  — ``gamma="mean"``: Xi at the predicted mean (the paper's suboptimal Gamma).  This
  is the like-for-like comparison with Stone Soup's reward on an EKF track (both linearise the
  measurement at the predicted mean), so the 100x per-candidate goal is held to it;
* ``cloud`` — ``gamma="cloud"``: the expectation of Xi over ``--particles`` (10,000) particles;
* ``H=3``   — ``horizon=3``: the exhaustive receding-horizon search over 15^3 = 3375 action
  sequences (``gamma="cloud"`` in the first step, the mean beyond).

Stone Soup (``pip install stonesoup``, the ``bench`` extra):

* an EKF track (``Track`` of one ``GaussianState``, order [x, vx, y, vy]), tmakit's ``Q_k`` as a
  small ``LinearGaussianTransitionModel`` subclass, ``ExtendedKalmanPredictor`` and
  ``ExtendedKalmanUpdater``;
* a ``RadarBearingRange`` (noise diag((1 deg)^2, (30 m)^2)) mounted on a ``FixedPlatform``
  whose movement controller is ``CandidateMovable``, a subclass of Stone Soup's
  ``MaxSpeedActionableMovable`` whose action generator (``CandidatePositionActionGenerator``, a
  subclass of ``ActionGenerator``) offers exactly the 15 end positions tmakit computed (Stone
  Soup's own generators offer grids or circles, not a given list);
* ``BruteForceSensorManager(platforms={platform}, reward_function=
  UncertaintyRewardFunction(predictor, updater))``; ``choose_actions({track}, t + 0.5 s)`` is
  one decision (each candidate: a deep copy of platform and sensor, the move, an EKF prediction,
  a noiseless detection, an EKF update, the drop in the Frobenius norm of the covariance).

A one-step decision over a planar plan is one compiled call
(:func:`tmakit.planning.planner.decide`: the candidates' kinematics with every limit
checked, ``J`` predicted, ``Gamma``, ``J^{-1}``, the criterion fully computed); the rows
``mean-general`` and ``cloud-general`` are the same decisions on the planner's general path (the
compiled decision set aside), to show what it gains.

Timing: both ``time.perf_counter`` (wall) and ``time.process_time`` (the process's CPU time,
which other jobs on a shared machine inflate less) around each call; the cases are
interleaved within each of ``--repeat`` rounds, in a fresh random order each round (seeded by
``--seed``), so no case always runs right after Stone Soup's 8 ms of Python, whose objects
evict the caches (a rotation would keep the same neighbours).  The ``mean`` case's median is
also printed split by whether it ran right after Stone Soup's call (cold caches) or after
another case.  ``--clock`` chooses the clock of the goals and ratios.  Printed: median and
interquartile range per decision, cost per candidate (decision / 15) and Stone Soup's
per-candidate cost over tmakit's; for H=3 the cost per sequence (/ 3375) and per node of the
search tree (/ (15 + 15^2 + 15^3): each node is one candidate step, its predicted information
and criterion, the work Stone Soup spends per candidate) beside Stone Soup's per-candidate
cost.
``--blas-threads N`` limits BLAS to ``N`` threads (``threadpoolctl``) for the whole run; the
header says what BLAS and how many threads ran.

    PYTHONPATH=src python benchmarks/planning_speed.py [--repeat 200] [--particles 10000]
        [--q 0.1] [--seed 0] [--clock wall|cpu] [--blas-threads N]
"""

from __future__ import annotations

import argparse
import datetime
import math
import time

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, Planner, SensorPlan
from tmakit.sensors import PlatformState, platform_configuration

GOALS_MS = {"mean": 1.0, "mean-general": 1.0, "cloud": 1.0, "cloud-general": 1.0, "H=3": 20.0}
#: The case held to the 100x ratio: Gamma at the mean is the like-for-like comparison with
#: Stone Soup's reward on an EKF track (both linearise the measurement at the mean).
RATIO_CASE = "mean"
RATIO_GOAL = 100.0
TARGET = np.array([-2000.0, 15000.0, 25.0, 0.0])        # x, y, vx, vy (m, m/s)
PRIOR = np.diag([500.0**2, 500.0**2, 10.0**2, 10.0**2])
SIGMAS = (math.radians(1.0), 30.0)                       # azimuth (rad), range (m)
START = PlatformState(position=(0.0, 0.0), heading=0.0, speed=50.0)
SS_ORDER = [0, 2, 1, 3]                                  # tmakit [x, y, vx, vy] -> [x, vx, y, vy]


def candidate_positions() -> np.ndarray:
    """The 15 end positions (C, 2), m, of HURTADO_NEHORAI_2008's actions after one step."""
    config = platform_configuration("hurtado_nehorai_2008")
    step = config.kinematics.step(START, config.actions, config.interval)
    return np.asarray(step.end.position)[:, :2]


def tmakit_cases(q: float, particles: int, seed: int) -> dict[str, tuple[object, ...]]:
    """Planner, platform and belief for each tmakit case."""
    config = platform_configuration("hurtado_nehorai_2008")
    dyn = NearlyConstantVelocity(dim=2, q=q)
    posterior = PosteriorInformation.from_prior(PRIOR, dyn, time=0.0)
    rng = np.random.default_rng(seed)
    cloud = TARGET + rng.standard_normal((particles, 4)) @ np.linalg.cholesky(PRIOR).T
    belief = Belief(posterior, cloud)
    plan = SensorPlan(["bearing", "range"], SIGMAS)
    base = dict(kinematics=config.kinematics, actions=config.actions,
                interval=config.interval, plan=plan)
    return {
        "mean": (Planner(**base, gamma="mean"), START, Belief(posterior, TARGET)),
        "mean-general": (Planner(**base, gamma="mean"), START, Belief(posterior, TARGET)),
        "cloud": (Planner(**base, gamma="cloud"), START, belief),
        "cloud-general": (Planner(**base, gamma="cloud"), START, belief),
        "H=3": (Planner(**base, gamma="cloud", horizon=3), START, belief),
    }


def decision(name: str, planner: Planner, start: PlatformState, belief: Belief):
    """One tmakit decision as a callable (``*-general``: the compiled decision set aside)."""
    if name.endswith("-general"):
        planner._decision["setup"] = None
    return lambda: planner.recommend(start, belief)


def stonesoup_case(q: float, positions: np.ndarray, interval: float):
    """Stone Soup's sensor manager, track and decision time on the same problem."""
    from stonesoup.base import Property
    from stonesoup.models.base import TimeVariantModel
    from stonesoup.models.transition.linear import LinearGaussianTransitionModel
    from stonesoup.movable.action.move_position_action import MovePositionAction
    from stonesoup.movable.max_speed import MaxSpeedActionableMovable
    from stonesoup.platform import FixedPlatform
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.sensor.radar.radar import RadarBearingRange
    from stonesoup.sensormanager import BruteForceSensorManager
    from stonesoup.sensormanager.action import ActionGenerator
    from stonesoup.sensormanager.reward import UncertaintyRewardFunction
    from stonesoup.types.state import GaussianState, State, StateVector
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    dyn = NearlyConstantVelocity(dim=2, q=q)

    class NearlyConstantVelocity2D(LinearGaussianTransitionModel, TimeVariantModel):
        """tmakit's Phi and Q_k (Chen & Sun, §2.1) in Stone Soup's state order."""

        @property
        def ndim_state(self):
            return 4

        def matrix(self, time_interval, **kwargs):
            dt = time_interval.total_seconds()
            return dyn.transition(dt)[np.ix_(SS_ORDER, SS_ORDER)]

        def covar(self, time_interval, **kwargs):
            dt = abs(time_interval.total_seconds())
            return dyn.noise(dt)[np.ix_(SS_ORDER, SS_ORDER)]

    class CandidatePositionActionGenerator(ActionGenerator):
        """Offers a given list of next positions (tmakit's candidate end positions)."""

        candidate_positions: np.ndarray = Property(doc="Candidate positions (C, 2), m")

        @property
        def default_action(self):
            return MovePositionAction(generator=self, end_time=self.end_time,
                                      target_value=self.current_value)

        def __contains__(self, item):
            value = item.target_value if isinstance(item, MovePositionAction) else item
            return any(np.allclose(np.ravel(value), p) for p in self.candidate_positions)

        def __iter__(self):
            for p in self.candidate_positions:
                yield MovePositionAction(generator=self, end_time=self.end_time,
                                         target_value=StateVector(p))

    class CandidateMovable(MaxSpeedActionableMovable):
        """An actionable movable whose next position is one of a given list."""

        generator = CandidatePositionActionGenerator
        _generator_kwargs = frozenset({"candidate_positions"})
        candidate_positions: np.ndarray = Property(doc="Candidate positions (C, 2), m")

    t0 = datetime.datetime(2008, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=interval)
    radar = RadarBearingRange(ndim_state=4, position_mapping=(0, 2),
                              noise_covar=np.diag([SIGMAS[0]**2, SIGMAS[1]**2]))
    movable = CandidateMovable(states=[State(StateVector([0.0, 0.0]), timestamp=t0)],
                               position_mapping=(0, 1), candidate_positions=positions)
    platform = FixedPlatform(movement_controller=movable, sensors=[radar])
    transition = NearlyConstantVelocity2D()
    reward = UncertaintyRewardFunction(ExtendedKalmanPredictor(transition),
                                       ExtendedKalmanUpdater(measurement_model=None))
    manager = BruteForceSensorManager(platforms={platform}, reward_function=reward)
    track = Track([GaussianState(StateVector(TARGET[SS_ORDER]),
                                 PRIOR[np.ix_(SS_ORDER, SS_ORDER)], timestamp=t0)])
    return manager, platform, track, t1


def stonesoup_rewards(manager, platform, track, t1) -> np.ndarray:
    """Stone Soup's reward of each of the 15 candidates, in the generator's order."""
    gens = list(platform.actions(t1))
    sensors = list(platform.sensors)
    return np.array([manager.reward_function({platform: (a,), **{s: () for s in sensors}},
                                             {track}, t1) for a in gens[0]])


def check_same_candidates(manager, platform, t1, positions: np.ndarray) -> None:
    """Refuse to time anything unless Stone Soup is offered exactly tmakit's positions."""
    (gen,) = platform.actions(t1)
    offered = np.array([np.ravel(a.target_value) for a in gen])
    if offered.shape != positions.shape or not np.allclose(offered, positions):
        raise RuntimeError("Stone Soup's candidate positions differ from tmakit's")
    assert len(manager.actionables) == 2   # the platform and its (non-actionable) radar


def summary(samples: list[float]) -> tuple[float, float, float]:
    """Median, 25th and 75th percentile, ms."""
    a = np.asarray(samples) * 1e3
    return float(np.median(a)), float(np.percentile(a, 25)), float(np.percentile(a, 75))


def time_rounds(calls: dict[str, object], repeat: int, rng: np.random.Generator
                ) -> tuple[dict[str, dict[str, list[float]]], dict[str, list[bool]]]:
    """Wall and CPU seconds of every call, ``repeat`` rounds, each in a fresh random order.

    Also returns, per call, whether it ran right after Stone Soup's (on caches Stone Soup's
    8 ms of Python had just evicted).
    """
    names = list(calls)
    times = {clock: {name: [] for name in names} for clock in ("wall", "cpu")}
    after = {name: [] for name in names}
    previous = None
    for _ in range(repeat):
        for k in rng.permutation(len(names)):
            name = names[k]
            w, c = time.perf_counter(), time.process_time()
            calls[name]()
            c, w = time.process_time() - c, time.perf_counter() - w
            times["wall"][name].append(w)
            times["cpu"][name].append(c)
            after[name].append(previous == "stonesoup")
            previous = name
    return times, after


def blas_note() -> str:
    """What BLAS runs and on how many threads."""
    blas = [p for p in threadpool_info() if p.get("user_api") == "blas"]
    return ", ".join(f"{p['internal_api']} {p['num_threads']} thread(s)" for p in blas) or "?"


def print_table(times: dict[str, dict[str, list[float]]], clock: str, n_cand: int,
                names: list[str]) -> None:
    """The table of one clock."""
    ss_med, ss_lo, ss_hi = summary(times[clock]["stonesoup"])
    ss_per = ss_med / n_cand
    print(f"{clock} time, ms: median (interquartile range)")
    head = (f"{'what':<8} {'tmakit':>24} {'goal':>6} {'Stone Soup BruteForce':>24} "
            f"{'tmakit/cand':>12} {'SS/cand':>9} {'ratio':>8}")
    print(head)
    print("-" * len(head))
    for name in names:
        med, lo, hi = summary(times[clock][name])
        per = med / n_cand
        if name == "H=3":   # Stone Soup's brute force decides one step only
            print(f"{name:<8} {med:>9.3f} ({lo:.3f}-{hi:.3f}) {GOALS_MS[name]:>6.1f} "
                  f"{'-':>24} {per:>12.4f} {'-':>9} {'-':>8}")
            continue
        print(f"{name:<8} {med:>9.3f} ({lo:.3f}-{hi:.3f}) {GOALS_MS[name]:>6.1f} "
              f"{ss_med:>9.2f} ({ss_lo:.2f}-{ss_hi:.2f}) {per:>12.4f} {ss_per:>9.3f} "
              f"{ss_per / per:>7.0f}x")


def main() -> None:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=200, help="interleaved rounds (default 200)")
    ap.add_argument("--particles", type=int, default=10_000, help="cloud size (default 10000)")
    ap.add_argument("--q", type=float, default=0.1, help="process noise, m/s^2 per axis")
    ap.add_argument("--seed", type=int, default=0, help="seed of the particle cloud")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="clock of the goals and ratios (both are printed): wall "
                    "(time.perf_counter) or cpu (time.process_time, this process's CPU time)")
    ap.add_argument("--blas-threads", type=int, default=None,
                    help="limit BLAS to this many threads (threadpoolctl; default: as set up)")
    args = ap.parse_args()
    if args.repeat < 1 or args.particles < 1:
        raise SystemExit("--repeat and --particles must be >= 1")
    if args.blas_threads is not None and args.blas_threads < 1:
        raise SystemExit("--blas-threads must be >= 1")
    with threadpool_limits(limits=args.blas_threads, user_api="blas"):
        run(args)


def run(args: argparse.Namespace) -> None:
    """Time the decisions and print the tables."""
    config = platform_configuration("hurtado_nehorai_2008")
    positions = candidate_positions()
    n_cand = positions.shape[0]
    cases = tmakit_cases(args.q, args.particles, args.seed)
    manager, platform, track, t1 = stonesoup_case(args.q, positions, config.interval)
    check_same_candidates(manager, platform, t1, positions)
    calls = {name: decision(name, *case) for name, case in cases.items()}
    calls["stonesoup"] = lambda: manager.choose_actions({track}, t1)
    for call in calls.values():      # warm up (compiled kernels, caches, work arrays)
        call()

    times, after = time_rounds(calls, args.repeat, np.random.default_rng(args.seed))
    print(f"one decision over {n_cand} candidates (HURTADO_NEHORAI_2008, one 0.5 s step); "
          f"azimuth 1 deg + range 30 m; {args.repeat} interleaved rounds; "
          f"cloud = {args.particles} particles; BLAS {blas_note()}")
    for clock in ("wall", "cpu"):
        print_table(times, clock, n_cand, list(cases))
    h3 = summary(times[args.clock]["H=3"])[0]
    ss_per = summary(times[args.clock]["stonesoup"])[0] / n_cand
    n_seq = len(config.actions) ** 3
    n_nodes = sum(len(config.actions) ** d for d in (1, 2, 3))
    per_node = h3 / n_nodes
    print(f"H=3 searches {n_seq} sequences, {n_nodes} nodes (one candidate step each: predicted "
          f"information and criterion; the cloud at depth 1, the mean beyond): "
          f"{1e3 * h3 / n_seq:.2f} us per sequence, {1e3 * per_node:.2f} us per node; Stone Soup "
          f"{ss_per:.3f} ms per candidate step = {ss_per / per_node:.0f}x a tmakit node "
          f"({args.clock})")

    rec = cases["mean"][0].recommend(START, cases["mean"][2])
    rec_cloud = cases["cloud"][0].recommend(START, cases["cloud"][2])
    rewards = stonesoup_rewards(manager, platform, track, t1)
    chosen = manager.choose_actions({track}, t1)[0][platform][0]
    ss_index = int(np.argmin(np.linalg.norm(positions - np.ravel(chosen.target_value),
                                            axis=1)))
    print(f"chosen action: tmakit mean {rec.index}, cloud {rec_cloud.index} (min trace of the "
          f"position bound); Stone Soup {ss_index} (max drop of ||P||_F; rewards "
          f"{rewards.min():.4g}..{rewards.max():.4g})")
    verdicts = []
    for name in cases:
        med = summary(times[args.clock][name])[0]
        verdicts.append(f"{name} {'met' if med <= GOALS_MS[name] else 'MISSED'} "
                        f"({med:.3f} <= {GOALS_MS[name]:g} ms)")
        if name == RATIO_CASE:
            ratio = ss_per / (med / n_cand)
            verdicts.append(f"{name} ratio {'met' if ratio >= RATIO_GOAL else 'MISSED'} "
                            f"({ratio:.0f}x >= {RATIO_GOAL:g}x)")
    print(f"goals ({args.clock}): " + "; ".join(verdicts))
    cold_warm(times[args.clock][RATIO_CASE], after[RATIO_CASE], ss_per, n_cand, args.clock)


def cold_warm(samples: list[float], after: list[bool], ss_per: float, n_cand: int,
              clock: str) -> None:
    """The ratio case's median right after Stone Soup's call and after another call."""
    a = np.asarray(samples) * 1e3
    cold = np.asarray(after)
    parts = []
    for label, mask in (("right after Stone Soup", cold), ("after a tmakit case", ~cold)):
        if mask.any():
            med = float(np.median(a[mask]))
            parts.append(f"{label} {med:.3f} ms ({mask.sum()} calls, "
                         f"{ss_per / (med / n_cand):.0f}x)")
    print(f"{RATIO_CASE} ({clock}): " + "; ".join(parts))


if __name__ == "__main__":
    main()
