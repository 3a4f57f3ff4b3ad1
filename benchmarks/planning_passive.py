"""Passive planning (issue 11, item 8), by the bound at the truth: adaptive paths against fixed.

(a) **Bearings-only TMA from a ship** at constant speed (8 m/s) with a turn-rate limit
    (9 deg/s), the ``bearings-only-2d`` geometry (1 Hz bearings, 1 deg, 600 s; prior 5 km /
    10 m/s per axis, q = 0).  Fixed patterns an operator would fly: straight on 45 deg; one
    90 deg turn at mid-time (either way); the scenario's zig-zag.  Adaptive: the mission
    planner (ten 60 s legs, any heading, re-planned at each leg), and the H-step planner
    (H = 2, heading changes 0, +-45, +-90 deg per 10 s, straight continuation to 600 s).
(b) **The gu2007 UAV** (50 m/s; RF power, SNR 40 dB, and Doppler frequency, 1.9 Hz, at 1 Hz
    for 120 s; emitter from (3200, 3200) m at (-21.65, -12.5) m/s) against the paper's path
    of three arcs (the scenario's, Gu et al. (2007), section 5), same speed and duration; a
    turn-rate limit of 3 deg/s (a standard-rate turn; the arcs turn at most 2.4 deg/s); prior
    2 km / 20 m/s per axis, q = 0.  The nuisance parameters (the power constant C and the
    carrier f_s) are taken as KNOWN here (the PCRB recursion is over the target state only),
    so the bounds are below the paper's CRLB tables, which estimate them; adaptive: the
    mission planner (six 20 s legs) and the H-step planner (H = 2, heading changes 0, +-5,
    +-10, +-15 deg per 5 s, straight continuation).

Every bound is the PCRB recursion (Hurtado & Nehorai (2008), eq. 10) along the flown path, at
the true target, one measurement time at a time (:class:`tmakit.bounds.PosteriorInformation`),
the same for fixed and adaptive paths.

    PYTHONPATH=src python benchmarks/planning_passive.py
"""

from __future__ import annotations

import math
import time

import numpy as np
from planning_horizon_warning import (
    ACTIONS,
    DYN,
    END,
    INTERVAL,
    KIN,
    PLAN,
    PRIOR,
    START,
    TRUTH0,
    belief0,
)

import tmakit as tk
from tmakit.bounds import PosteriorInformation
from tmakit.core.units import snr_to_sigma_db
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.observation import MeasurementGroup
from tmakit.planning import Belief, Continuation, Planner, SensorPlan
from tmakit.planning.mission import MissionPlanner
from tmakit.sensors import Actions, PlatformKinematics, PlatformState


def bound_along(states, times: np.ndarray, prior: np.ndarray, x0: np.ndarray,
                dyn: NearlyConstantVelocity, plan: SensorPlan) -> float:
    """Final position bound (m) of the recursion along a sensor path ``states(t) -> (k, 6)``."""
    post = PosteriorInformation.from_prior(prior, dyn, 0.0, x0)
    for t in times:
        post = post.predict_to(t)
        group = MeasurementGroup.planned(list(plan.kinds), plan.sigmas, t, 2,
                                         options=plan.options, nuisance=plan.nuisance)
        post = post.update(post.expected_information(states([t]), group)[0])
    return float(post.position_rms)


def min_range(states, times: np.ndarray, x0: np.ndarray) -> float:
    """Smallest sensor-to-target distance (m) over ``times`` (constant-velocity truth)."""
    target = x0[:2] + times[:, None] * x0[2:]
    return float(np.min(np.hypot(*(states(times)[:, :2] - target).T)))


def fly_receding(planner: Planner, belief: Belief, platform: PlatformState, end: float,
                 x0: np.ndarray, dyn: NearlyConstantVelocity):
    """Fly the H-step planner to ``end``; return the flown track and the ms per decision."""
    steps, took = [], []
    while belief.time < end - 1e-6:
        t0 = time.perf_counter()
        rec = planner.recommend(platform, belief)
        took.append(1e3 * (time.perf_counter() - t0))
        t1 = belief.time + planner.interval
        belief = planner.advance(belief, rec, dyn.transition(t1) @ x0)
        steps.append(rec.step)
        platform = rec.step.end
    return planner.kinematics.fly(steps[0].start, Actions(
        np.array([float(s.turn_rate) * s.interval for s in steps])), planner.interval), took


def fly_mission(mp: MissionPlanner, belief: Belief, platform: PlatformState,
                x0: np.ndarray, dyn: NearlyConstantVelocity):
    """Fly the mission planner, re-planned at each leg; return the track and seconds taken."""
    start, plan, acts, t0 = platform, None, [], time.perf_counter()
    while belief.time < mp.end_time - 1e-6:
        plan = mp.recommend(platform, belief, previous=plan)
        leg = mp.first_leg(platform, plan)
        acts.append(leg)
        t1 = belief.time + len(leg) * mp.step
        platform, belief = mp.advance(platform, belief, plan, dyn.transition(t1) @ x0)
    actions = Actions(np.concatenate([a.heading_change for a in acts]), 0.0,
                      np.concatenate([a.speed_change for a in acts]))
    return mp.kinematics.fly(start, actions, mp.step), time.perf_counter() - t0


def print_rows(title: str, rows: list[tuple[str, float, str]], fixed: int) -> None:
    """Print the rows with the ratio to the best of the first ``fixed`` (the fixed paths)."""
    best = min(b for _, b, _ in rows[:fixed])
    print(f"\n{title}")
    print(f"{'path':<62}{'final bound (m)':>16}{'x best fixed':>14}  planning")
    for label, b, note in rows:
        print(f"{label:<62}{b:16.2f}{b / best:14.2f}  {note}")


def bearings_only() -> None:
    """Figure (a)."""
    times = np.arange(1.0, END + 1.0)
    scn = tk.load_scenario("bearings-only-2d")

    def fixed(heads_deg: list[float]) -> float:
        track = KIN.fly(START, Actions(np.radians(heads_deg)), INTERVAL)
        return bound_along(track.states, times, PRIOR, TRUTH0, DYN, PLAN)

    rows = [("straight, 45 deg", fixed([0.0] * 60), ""),
            ("one turn at 300 s, 45 -> -45 deg", fixed([0.0] * 30 + [-90.0] + [0.0] * 29), ""),
            ("one turn at 300 s, 45 -> 135 deg", fixed([0.0] * 30 + [90.0] + [0.0] * 29), ""),
            ("zig-zag of bearings-only-2d (the scenario's path)",
             bound_along(scn.sensors["observer"].states, times, PRIOR, TRUTH0, DYN, PLAN), "")]
    mp = MissionPlanner(KIN, PLAN, INTERVAL, 60.0, END)
    track, took = fly_mission(mp, belief0(), START, TRUTH0, DYN)
    rows.append(("adaptive: mission planner, 60 s legs, re-planned each leg",
                 bound_along(track.states, times, PRIOR, TRUTH0, DYN, PLAN),
                 f"{took:.1f} s for 10 plans"))
    planner = Planner(KIN, ACTIONS, INTERVAL, PLAN, horizon=2,
                      continuation=Continuation(END, "straight"))
    track, ms = fly_receding(planner, belief0(), START, END, TRUTH0, DYN)
    rows.append(("adaptive: H = 2 + straight continuation (5 actions / 10 s)",
                 bound_along(track.states, times, PRIOR, TRUTH0, DYN, PLAN),
                 f"{np.median(ms):.1f} ms/decision"))
    print_rows("(a) bearings-only ship, 8 m/s, <= 9 deg/s, 600 s: final position bound at the "
               "truth", rows, 4)


def gu2007() -> None:
    """Figure (b)."""
    scn = tk.load_scenario("gu2007")
    x0 = np.array([3200.0, 3200.0, -21.65, -12.5])
    dyn = NearlyConstantVelocity(2, 0.0)
    prior = np.diag([2000.0**2] * 2 + [20.0**2] * 2)
    nuisance = {"power_constant_db": 10 * math.log10(1.5766e-4), "carrier": 1.9e9}
    plan = SensorPlan(["power", "frequency"], [snr_to_sigma_db(40.0), 1.9],
                      times=tuple(np.arange(1.0, 6.0)), nuisance=nuisance)
    arcs = scn.sensors["uav"]
    s0 = arcs.states([0.0])[0]
    start = PlatformState.from_velocity(s0[:3], s0[3:])
    kin = PlatformKinematics(min_speed=50.0, max_speed=50.0, max_turn_rate=math.radians(3.0))
    times = np.arange(0.0, 120.0)          # the scenario's 120 samples, t = 0 .. 119 s

    # the measurement at t = 0 is made before the first decision
    group0 = MeasurementGroup.planned(["power", "frequency"], plan.sigmas, 0.0, 2,
                                      nuisance=nuisance)
    post0 = PosteriorInformation.from_prior(prior, dyn, 0.0, x0)
    post0 = post0.update(post0.expected_information(s0[None], group0)[0])
    belief = Belief(PosteriorInformation(post0.information, dyn, 0.0), x0)
    paths = [("the paper's three arcs (gu2007 scenario path)", arcs.states, ""),
             ("straight on the arcs' start heading",
              kin.fly(start, Actions(np.zeros(24)), 5.0).states, "")]
    mp = MissionPlanner(kin, plan, 5.0, 20.0, 119.0 + 1.0)
    track, took = fly_mission(mp, belief, start, x0, dyn)
    paths.append(("adaptive: mission planner, 20 s legs, re-planned each leg", track.states,
                  f"{took:.1f} s for 6 plans"))
    planner = Planner(kin, Actions(np.radians([0.0, 5.0, -5.0, 10.0, -10.0, 15.0, -15.0])), 5.0,
                      plan, horizon=2, continuation=Continuation(120.0, "straight"))
    track, ms = fly_receding(planner, belief, start, 120.0, x0, dyn)
    paths.append(("adaptive: H = 2 + straight continuation (7 actions / 5 s)", track.states,
                  f"{np.median(ms):.1f} ms/decision"))
    rows = [(label, bound_along(states, times, prior, x0, dyn, plan),
             f"min range {min_range(states, times, x0):6.0f} m; {note}")
            for label, states, note in paths]
    print_rows("(b) gu2007 UAV, 50 m/s, <= 3 deg/s, power + Doppler, 120 s (nuisance known): "
               "final position bound at the truth", rows, 2)


if __name__ == "__main__":
    bearings_only()
    gu2007()
