"""Passive planning in a seeded Monte Carlo: bearings-only final position RMSE, same tracker.

The ``bearings-only-2d`` geometry of ``planning_horizon_warning.py``: 8 m/s, <= 9 deg/s, 1 Hz
bearings with 1 deg noise, 600 s, q = 0.  Each run draws the tracker's prior mean from
N(truth, P0) (P0: 5 km, 10 m/s per axis) and the bearing noise; the SAME draws (common random
numbers) serve every path, and the tracker (a regularised particle filter, ``--particles``,
its own seeded stream) is the same.  Paths:

* fixed: the scenario's zig-zag, one 90 deg turn at 300 s (45 -> -45 deg), straight;
* adaptive, closed loop: the mission planner (ten 60 s legs; re-planned at every leg from the
  tracker and the bound along the flown path; Hurtado & Nehorai (2008), section 4.2) with the
  target given to the planner as

  - ``estimate``: the tracker's mean (Gamma at the estimate, the paper's eq. 13);
  - ``hypotheses``: three range hypotheses, the 1/6, 1/2, 5/6 range quantiles of the
    tracker's particles, each carried through its own recursion, a path scored by the mean of
    their final bounds (``MissionPlanner(hypotheses=True)``): the first legs are flown before
    the range is known, so the path is planned for every plausible range;
  - ``ranges``: as ``hypotheses``, each hypothesis also with its own ``J`` along the path
    flown so far (the flown legs evaluated at it), not the one ``J`` at the estimates;
  - ``pooled``: the same three states as one cloud (Gamma averaged over them, the "cloud"
    form): the nearest dominates through 1/r^2;
  - ``truth`` (diagnosis only, not a planner a user has): the true target;

  and the H = 2 planner with the straight continuation (5 heading changes per 10 s).

Printed per path: final (t = 600 s) position RMSE over the runs (with its bootstrap 90 %
interval), its ratio to the best fixed pattern, the median final error, the bound at the true
target along the path each run flew (RMS over runs) and the tracker's efficiency (RMSE over
that bound).  ``--cases`` picks paths by name (zigzag, one-turn, straight, estimate,
hypotheses, ranges, pooled, truth, h2); ``--jobs`` spreads the runs over processes (same numbers).

    PYTHONPATH=src python benchmarks/planning_passive_mc.py [--runs 20] [--seed 1]
        [--particles 4000] [--jobs 1] [--wait 0] [--cases zigzag,one-turn,straight,ranges]

Measured (50 runs, seed 1): zig-zag 75.4 m, ranges 53.8 m (0.71x); see docs/planning.md.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from collections.abc import Callable, Iterator

import numpy as np
from planning_horizon_warning import ACTIONS, DYN, END, INTERVAL, KIN, PLAN, PRIOR, START, TRUTH0

import tmakit as tk
from tmakit.bounds import PosteriorInformation
from tmakit.data import MeasurementSet
from tmakit.filters import FILTERS
from tmakit.planning import Belief, Continuation, Planner, SensorPlan
from tmakit.planning.candidates import step_information
from tmakit.planning.mission import MissionPlanner
from tmakit.sensors import Actions

SIGMA = math.radians(1.0)
#: What the planners predict per 10 s step: the ten 1 deg bearings thinned to one of the same
#: information (1 deg / sqrt(10)) at mid-step; the trackers get every bearing.  The mission
#: planner's path on it scores 36.5 m at the truth under the full plan, against 36.7 m planned
#: on the full plan, in a third of the time.
THIN = SensorPlan("bearing", SIGMA / math.sqrt(10.0), times=(5.0,))
QUANTILES = np.array([1.0, 3.0, 5.0]) / 6.0
FIXED = ("zigzag", "one-turn", "straight")
LABELS = {"zigzag": "fixed: zig-zag of bearings-only-2d",
          "one-turn": "fixed: one turn at 300 s (45 -> -45 deg)",
          "straight": "fixed: straight",
          "estimate": "mission planner, Gamma at the estimate",
          "hypotheses": "mission planner, 3 range hypotheses",
          "ranges": "mission planner, 3 ranges, own J each",
          "pooled": "mission planner, 3 ranges pooled (cloud)",
          "truth": "mission planner given the truth (diagnosis)",
          "h2": "H = 2 + straight continuation"}


def truth(t: float) -> np.ndarray:
    """The true target state at ``t`` (s)."""
    return DYN.transition(t) @ TRUTH0


def bearing_rows(t: float, sensor: np.ndarray, target: np.ndarray, noise: float
                 ) -> MeasurementSet:
    """One simulated bearing (deg in the set) of the target from the sensor state."""
    value = math.atan2(target[0] - sensor[0], target[1] - sensor[1]) + SIGMA * noise
    value = (value + math.pi) % (2 * math.pi) - math.pi
    return MeasurementSet([t], ["observer"], ["bearing"], [math.degrees(value)], [1.0],
                          sensor[None, :])


class Run:
    """One run's draws (the prior mean, the bearing noise, the tracker's seed) and its loop."""

    def __init__(self, seed: np.random.SeedSequence, particles: int) -> None:
        r_prior, r_noise, r_pf = (np.random.default_rng(s) for s in seed.spawn(3))
        self.mean0 = TRUTH0 + np.linalg.cholesky(PRIOR) @ r_prior.standard_normal(4)
        self.noise = r_noise.standard_normal(int(END))
        self.pf_seed = int(r_pf.integers(2**63))
        self.particles = particles
        self.tracker = FILTERS["pf"](self.mean0, PRIOR, 0.0, particles=self.particles,
                                     rng=self.pf_seed)
        self.sensor: list[np.ndarray] = []

    def measure(self, track, t0: float, t1: float) -> None:
        """Feed the tracker the bearings in (t0, t1] from ``track`` (a SensorTrack)."""
        for t in np.arange(t0 + 1.0, t1 + 0.5):
            sensor = track.states([t])[0]
            self.sensor.append(sensor)
            self.tracker.predict(t)
            self.tracker.update(bearing_rows(t, sensor, truth(t), self.noise[int(t) - 1]))

    def result(self) -> tuple[float, float]:
        """Final position error (m) and the bound at the truth along the flown path (m)."""
        err = float(np.hypot(*(self.tracker.state[:2] - truth(END)[:2])))
        return err, flown_bound(np.array(self.sensor))


def flown_bound(sensor: np.ndarray) -> float:
    """Final position bound (m) at the true target along flown sensor states (600, 6)."""
    k = PLAN.measurement_times(INTERVAL).size
    post = PosteriorInformation.from_prior(PRIOR, DYN, 0.0)
    info = post.information
    for j in range(sensor.shape[0] // k):
        belief = Belief(post, truth(j * INTERVAL))
        info = step_information(belief, info, PLAN, sensor[None, j * k:(j + 1) * k],
                                INTERVAL, "mean")[0]
        post = type(post)(info, DYN, (j + 1) * INTERVAL)
    return float(np.sqrt(np.trace(np.linalg.inv(info)[:2, :2])))


def fixed_path(name: str):
    """The fixed pattern ``name`` flown from the start (a PlatformTrack)."""
    if name == "zigzag":
        return tk.load_scenario("bearings-only-2d").sensors["observer"]
    turn = [0.0] * 30 + [-90.0] + [0.0] * 29 if name == "one-turn" else [0.0] * 60
    return KIN.fly(START, Actions(np.radians(turn)), INTERVAL)


def planning_belief(run: Run, belief: Belief, platform, mode: str) -> Belief:
    """The target the planner is given: the estimate, range hypotheses or the truth."""
    if mode == "truth":
        return Belief(belief.posterior, truth(belief.time))
    if mode == "estimate":
        return Belief(belief.posterior, run.tracker.state)
    pf = run.tracker
    rng = np.random.default_rng(run.pf_seed % 2**32 + int(belief.time))
    cloud = pf.particles[rng.choice(pf.n_particles, 1000, p=pf.weights)]
    rng_ = np.hypot(*(cloud[:, :2] - platform.position[:2]).T)
    order = np.argsort(rng_)
    return Belief(belief.posterior, cloud[order[(QUANTILES * order.size).astype(int)]])


def hold(run: Run, wait: float) -> tuple[object, Belief]:
    """Fly straight for the first ``wait`` s (bearings to the tracker, ``J`` along it)."""
    post = PosteriorInformation.from_prior(PRIOR, DYN, 0.0)
    if wait <= 0:
        return START, Belief(post, run.mean0)
    track = KIN.fly(START, Actions(np.zeros(round(wait / INTERVAL))), INTERVAL)
    run.measure(track, 0.0, track.end_time)
    info, belief = post.information[None], Belief(post, run.mean0)
    for k in range(round(wait / INTERVAL)):     # J with Gamma at the estimate, as advance()
        t = k * INTERVAL
        info = step_information(belief, info, THIN,
                                track.states(t + THIN.measurement_times(INTERVAL))[None],
                                INTERVAL, "mean", (run.mean0[None] @ DYN.transition(t).T,
                                                   np.ones(1)))
    return track.end, Belief(PosteriorInformation(info[0], DYN, track.end_time),
                             run.tracker.state)


def mission_run(run: Run, mp: MissionPlanner, mode: str, wait: float) -> tuple[float, float]:
    """Closed loop: re-plan the remaining legs at each leg from the tracker.

    The first decision is taken after ``wait`` s of straight flight (bearings first).
    """
    platform, belief = hold(run, wait)
    plan, flown = None, []
    while belief.time < END - 1e-6:
        belief = planning_belief(run, belief, platform, mode)
        info = None
        if mode == "ranges" and flown and wait <= 0:
            past = MissionPlanner(KIN, THIN, INTERVAL, mp.leg_duration, belief.time,
                                  hypotheses=True)
            back = belief.states @ DYN.transition(-belief.time).T
            info = past.evaluate(START, Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0),
                                               back), np.array(flown)[None])[0]
        plan = mp.recommend(platform, belief, previous=plan, information=info)
        flown.append(plan.headings[0])
        track = KIN.fly(platform, mp.first_leg(platform, plan), INTERVAL)
        run.measure(track, belief.time, track.end_time)
        platform, belief = mp.advance(platform, belief, plan, run.tracker.state)
    return run.result()


def horizon_run(run: Run, planner: Planner) -> tuple[float, float]:
    """Closed loop: the H-step planner every 10 s from the tracker's estimate."""
    platform = START
    belief = Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0), run.mean0)
    while belief.time < END - 1e-6:
        rec = planner.recommend(platform, belief)
        track = KIN.fly(platform, Actions(rec.action.heading_change[None]), INTERVAL)
        run.measure(track, belief.time, track.end_time)
        belief = planner.advance(belief, rec, run.tracker.state)
        platform = rec.step.end
    return run.result()


def case_fn(name: str, wait: float) -> Callable[[Run], tuple[float, float]]:
    """The closed loop of one path."""
    if name in FIXED:
        path = fixed_path(name)

        def fixed(run: Run) -> tuple[float, float]:
            run.measure(path, 0.0, END)
            return run.result()
        return fixed
    if name == "h2":
        hz = Planner(KIN, ACTIONS, INTERVAL, THIN, horizon=2,
                     continuation=Continuation(END, "straight"))
        return lambda r: horizon_run(r, hz)
    mp = MissionPlanner(KIN, THIN, INTERVAL, 60.0, END, headings=12, sweeps=2, refine=1,
                        gamma="cloud" if name == "pooled" else "mean",
                        hypotheses=name in ("hypotheses", "ranges"))
    return lambda r: mission_run(r, mp, name, wait)


def one(job: tuple[str, np.random.SeedSequence, int, float]) -> tuple[float, float, float]:
    """Run one case on one run's draws; error (m), flown bound (m), seconds."""
    name, seed, particles, wait = job
    t0 = time.process_time()
    err, bound = case_fn(name, wait)(Run(seed, particles))
    return err, bound, time.process_time() - t0


def progress(results: Iterator[tuple[float, float, float]], jobs: list
             ) -> Iterator[tuple[float, float, float]]:
    """Pass the results on, each also printed to stderr."""
    for (name, *_), res in zip(jobs, results, strict=True):
        print(f"{name}: error {res[0]:.1f} m, bound {res[1]:.1f} m, {res[2]:.1f} s",
              file=sys.stderr, flush=True)
        yield res


def rmse_interval(err: np.ndarray, rng: np.random.Generator) -> tuple[float, float, float]:
    """RMSE and its bootstrap 5-95 % interval."""
    boot = np.sqrt(np.mean(rng.choice(err, (2000, err.size)) ** 2, axis=1))
    return float(np.sqrt(np.mean(err**2))), *np.percentile(boot, [5, 95])


def main() -> None:
    """Run the Monte Carlo and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--particles", type=int, default=4000)
    ap.add_argument("--jobs", type=int, default=1, help="processes (same numbers)")
    ap.add_argument("--cases", default="zigzag,one-turn,straight,ranges,hypotheses,estimate")
    ap.add_argument("--wait", type=float, default=0.0,
                    help="s of straight flight before the mission planner's first decision")
    ap.add_argument("--save", help="write the per-run errors and bounds to this .npz")
    args = ap.parse_args()
    names = args.cases.split(",")
    unknown = sorted(set(names) - set(LABELS))
    if unknown:
        ap.error(f"--cases: unknown {unknown}; choose from {sorted(LABELS)}")
    seeds = np.random.SeedSequence(args.seed).spawn(args.runs)
    jobs = [(n, s, args.particles, args.wait) for n in names for s in seeds]
    if args.jobs > 1:
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            out = np.array(list(progress(pool.imap(one, jobs), jobs)))
    else:
        out = np.array(list(progress(map(one, jobs), jobs)))
    out = out.reshape(len(names), args.runs, 3)
    if args.save:
        np.savez(args.save, names=names, errors=out[..., 0], bounds=out[..., 1])
    table(names, out, args)


def table(names: list[str], out: np.ndarray, args: argparse.Namespace) -> None:
    """Print the table from (case, run, [error, bound, s]); same numbers for any --cases."""
    print(f"bearings-only-2d, {args.runs} runs (seed {args.seed}), particle filter with "
          f"{args.particles} particles; prior N(truth, 5 km / 10 m/s); first mission decision "
          f"at {args.wait:g} s")
    print(f"{'path':<46}{'RMSE (m)':>9}{'90 % int.':>11}{'x best fixed':>13}"
          f"{'median':>8}{'bound':>7}{'RMSE/bound':>11}{'cpu s/run':>10}")
    fixed = [np.sqrt(np.mean(out[k, :, 0] ** 2)) for k, n in enumerate(names) if n in FIXED]
    best = min(fixed) if fixed else float("nan")
    for k, name in enumerate(names):
        err, bound, took = out[k].T
        rmse, lo, hi = rmse_interval(err, np.random.default_rng([args.seed,
                                                                 list(LABELS).index(name)]))
        b = float(np.sqrt(np.mean(bound**2)))
        print(f"{LABELS[name]:<46}{rmse:9.1f}{f'{lo:.0f}-{hi:.0f}':>11}{rmse / best:13.2f}"
              f"{np.median(err):8.1f}{b:7.1f}{rmse / b:11.2f}{np.mean(took):10.1f}")


if __name__ == "__main__":
    main()
