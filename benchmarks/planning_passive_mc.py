"""Passive planning in a seeded Monte Carlo: bearings-only final position RMSE, same tracker.

The ``bearings-only-2d`` geometry of ``planning_passive.py`` (a): 8 m/s, <= 9 deg/s, 1 Hz
bearings with 1 deg noise, 600 s, q = 0.  Each run draws the tracker's prior mean from
N(truth, P0) (P0: 5 km, 10 m/s per axis) and the bearing noise; the SAME draws (common random
numbers) serve every path, and the tracker (a particle filter, ``--particles``, regularised,
its own seeded stream) is the same.  Paths:

* fixed: the scenario's zig-zag, one 90 deg turn at 300 s (45 -> -45 deg), straight;
* adaptive, closed loop: the mission planner (ten 60 s legs; re-planned at every leg from the
  tracker's estimate and the bound along the flown path, Gamma at the estimate, Hurtado &
  Nehorai (2008), section 4.2); the H = 2 planner with the straight continuation (5 heading
  changes per 10 s).

Printed: final (t = 600 s) position RMSE over the runs (with its bootstrap 90 % interval),
its ratio to the best fixed pattern, and the median final error.  (The closed-loop engine of
``tmakit.planning.closed_loop`` measures once per decision; this script runs its own loop
because the bearings come ten per decision.)

    PYTHONPATH=src python benchmarks/planning_passive_mc.py [--runs 20] [--seed 1]
        [--particles 4000]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from planning_horizon_warning import ACTIONS, DYN, END, INTERVAL, KIN, PLAN, PRIOR, START, TRUTH0

import tmakit as tk
from tmakit.bounds import PosteriorInformation
from tmakit.data import MeasurementSet
from tmakit.filters import FILTERS
from tmakit.planning import Belief, Planner
from tmakit.planning.horizon import Continuation
from tmakit.planning.mission import MissionPlanner
from tmakit.sensors import Actions

SIGMA = math.radians(1.0)


def bearing_rows(t: float, sensor: np.ndarray, target: np.ndarray, noise: float
                 ) -> MeasurementSet:
    """One simulated bearing (deg in the set) of the target from the sensor state."""
    value = math.atan2(target[0] - sensor[0], target[1] - sensor[1]) + SIGMA * noise
    value = (value + math.pi) % (2 * math.pi) - math.pi
    return MeasurementSet([t], ["observer"], ["bearing"], [math.degrees(value)], [1.0],
                          sensor[None, :])


class Run:
    """One run's draws: the prior mean, the bearing noise, the tracker's seed."""

    def __init__(self, seed: np.random.SeedSequence, particles: int) -> None:
        r_prior, r_noise, r_pf = (np.random.default_rng(s) for s in seed.spawn(3))
        self.mean0 = TRUTH0 + np.linalg.cholesky(PRIOR) @ r_prior.standard_normal(4)
        self.noise = r_noise.standard_normal(int(END))
        self.pf_seed = int(r_pf.integers(2**63))
        self.particles = particles

    def tracker(self):
        """A fresh particle filter from the run's prior."""
        return FILTERS["pf"](self.mean0, PRIOR, 0.0, particles=self.particles,
                             rng=self.pf_seed)

    def measure(self, tracker, track, t0: float, t1: float) -> None:
        """Feed the tracker the bearings in (t0, t1] from ``track`` (a SensorTrack)."""
        for t in np.arange(t0 + 1.0, t1 + 0.5):
            sensor = track.states([t])[0]
            tracker.predict(t)
            tracker.update(bearing_rows(t, sensor, DYN.transition(t) @ TRUTH0,
                                        self.noise[int(t) - 1]))


def error(tracker) -> float:
    """Final position error, m."""
    return float(np.hypot(*(tracker.state[:2] - (DYN.transition(END) @ TRUTH0)[:2])))


def fixed_run(run: Run, track) -> float:
    """Track along a fixed path."""
    pf = run.tracker()
    run.measure(pf, track, 0.0, END)
    return error(pf)


def mission_run(run: Run, mp: MissionPlanner) -> float:
    """Closed loop: re-plan the remaining legs at each leg from the tracker's estimate."""
    pf, platform, plan = run.tracker(), START, None
    belief = Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0), pf.state)
    while belief.time < END - 1e-6:
        plan = mp.recommend(platform, belief, previous=plan)
        leg = mp.first_leg(platform, plan)
        track = KIN.fly(platform, leg, INTERVAL)
        run.measure(pf, track, belief.time, track.end_time)
        platform, belief = mp.advance(platform, belief, plan, pf.state)
    return error(pf)


def horizon_run(run: Run, planner: Planner) -> float:
    """Closed loop: the H-step planner every 10 s from the tracker's estimate."""
    pf, platform = run.tracker(), START
    belief = Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0), pf.state)
    while belief.time < END - 1e-6:
        rec = planner.recommend(platform, belief)
        track = KIN.fly(platform, Actions(rec.action.heading_change[None]), INTERVAL)
        run.measure(pf, track, belief.time, track.end_time)
        belief = planner.advance(belief, rec, pf.state)
        platform = rec.step.end
    return error(pf)


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
    args = ap.parse_args()
    scn = tk.load_scenario("bearings-only-2d")
    one_turn = KIN.fly(START, Actions(np.radians([0.0] * 30 + [-90.0] + [0.0] * 29)), INTERVAL)
    straight = KIN.fly(START, Actions(np.zeros(60)), INTERVAL)
    mp = MissionPlanner(KIN, PLAN, INTERVAL, 60.0, END, headings=12, sweeps=2, refine=1)
    hz = Planner(KIN, ACTIONS, INTERVAL, PLAN, horizon=2,
                 continuation=Continuation(END, "straight"))
    cases = [("fixed: zig-zag of bearings-only-2d", lambda r: fixed_run(r, scn.sensors[
                 "observer"])),
             ("fixed: one turn at 300 s (45 -> -45 deg)", lambda r: fixed_run(r, one_turn)),
             ("fixed: straight", lambda r: fixed_run(r, straight)),
             ("adaptive: mission planner, 60 s legs (closed loop)", lambda r: mission_run(r, mp)),
             ("adaptive: H = 2 + straight continuation (closed loop)",
              lambda r: horizon_run(r, hz))]
    runs = [Run(s, args.particles) for s in np.random.SeedSequence(args.seed).spawn(args.runs)]
    boot = np.random.default_rng(args.seed)
    print(f"bearings-only-2d, {args.runs} runs (seed {args.seed}), particle filter with "
          f"{args.particles} particles; prior N(truth, 5 km / 10 m/s)")
    print(f"{'path':<56}{'RMSE (m)':>10}{'90 % interval':>18}{'x best fixed':>14}"
          f"{'median (m)':>12}{'s/run':>8}")
    best = None
    for k, (label, fn) in enumerate(cases):
        t0 = time.perf_counter()
        err = np.array([fn(r) for r in runs])
        took = (time.perf_counter() - t0) / len(runs)
        rmse, lo, hi = rmse_interval(err, boot)
        if k < 3:
            best = rmse if best is None else min(best, rmse)
        print(f"{label:<56}{rmse:10.1f}{f'{lo:.0f}-{hi:.0f}':>18}{rmse / best:14.2f}"
              f"{np.median(err):12.1f}{took:8.1f}", flush=True)


if __name__ == "__main__":
    main()
