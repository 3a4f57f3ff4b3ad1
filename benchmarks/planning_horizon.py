"""Horizon: what H = 2 and H = 3 gain over H = 1, and what the beam search costs and saves.

Two scenarios, each evaluated at the TRUE target (Gamma at the true state; the bound along the
flown path, J carried by :meth:`tmakit.planning.Planner.advance`):

* **radar** — the ``hurtado2008`` geometry (target from (-2, 15) km East at 25 m/s; radar from
  (0, 0) North at 50 m/s), the toml's sigmas (azimuth 1 deg, range 30 m, range rate 0.5 m/s)
  every 0.5 s for 200 s, the paper's 15 actions (Hurtado & Nehorai (2008), section 5); prior
  500 m / 10 m/s per axis around the truth; process noise q = 0.1 m/s^2 per axis (the paper
  does not give its value).
* **bearings-only** — the ``bearings-only-2d`` geometry of ``planning_horizon_warning.py``
  (heading changes 0, +-45, +-90 deg every 10 s, 1 Hz bearings, 600 s, prior 5 km / 10 m/s,
  q = 0).

For each horizon H (exhaustive search, and the beam of width B), the final position bound,
its ratio to H = 1's, and the median time per decision (with the 10-90 % spread).  For H = 3
with a beam the cost the beam found is compared with the exhaustive search's at every decision
of the exhaustive run ("found / exhaustive": 1 means it found the optimum).

    PYTHONPATH=src python benchmarks/planning_horizon.py
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tmakit.bounds import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, Continuation, Planner, SensorPlan
from tmakit.sensors import Actions, PlatformKinematics, PlatformState, platform_configuration


@dataclass(frozen=True)
class Case:
    """One scenario: how to make a planner, where it starts, the truth, the end time."""

    name: str
    make: Callable[..., Planner]
    start: PlatformState
    belief: Belief
    truth0: np.ndarray
    dyn: NearlyConstantVelocity
    end: float


def radar() -> Case:
    """The hurtado2008 geometry with the paper's 15 actions."""
    cfg = platform_configuration("hurtado_nehorai_2008")
    plan = SensorPlan(["bearing", "range", "range_rate"], [math.radians(1.0), 30.0, 0.5])
    dyn = NearlyConstantVelocity(2, 0.1)
    x0 = np.array([-2000.0, 15000.0, 25.0, 0.0])
    post = PosteriorInformation.from_prior(np.diag([500.0**2] * 2 + [10.0**2] * 2), dyn)

    def make(**kw: object) -> Planner:
        return Planner(cfg.kinematics, cfg.actions, cfg.interval, plan, **kw)

    return Case("radar (hurtado2008, 15 actions, 0.5 s, 200 s)", make,
                PlatformState((0.0, 0.0), 0.0, 50.0), Belief(post, x0), x0, dyn, 200.0)


def bearings() -> Case:
    """The bearings-only-2d geometry, heading changes 0, +-45, +-90 deg every 10 s."""
    kin = PlatformKinematics(min_speed=8.0, max_speed=8.0, max_turn_rate=math.radians(9.0))
    plan = SensorPlan("bearing", math.radians(1.0), times=tuple(np.arange(1.0, 11.0)))
    acts = Actions(np.radians([0.0, 45.0, -45.0, 90.0, -90.0]))
    dyn = NearlyConstantVelocity(2, 0.0)
    x0 = np.array([4000.0, 9000.0, -6.0, -3.0])
    post = PosteriorInformation.from_prior(np.diag([5000.0**2] * 2 + [10.0**2] * 2), dyn)

    def make(**kw: object) -> Planner:
        return Planner(kin, acts, 10.0, plan, **kw)

    return Case("bearings-only (bearings-only-2d, 5 actions, 10 s, 600 s)", make,
                PlatformState((0.0, 0.0), math.radians(45.0), 8.0), Belief(post, x0), x0, dyn,
                600.0)


def run(case: Case, planner: Planner, peer: Planner | None = None
        ) -> tuple[float, np.ndarray, np.ndarray]:
    """Fly the planner's choices; final bound (m), decision times (s), peer/own best cost."""
    belief, platform, took, ratio = case.belief, case.start, [], []
    while belief.time < case.end - 1e-6:
        t0 = time.perf_counter()
        rec = planner.recommend(platform, belief)
        took.append(time.perf_counter() - t0)
        if peer is not None:
            other = peer.recommend(platform, belief)
            ratio.append(float(other.cost.min() / rec.cost.min()))
        t1 = belief.time + planner.interval
        belief = planner.advance(belief, rec, case.dyn.transition(t1) @ case.truth0)
        platform = rec.step.end
    return float(belief.posterior.position_rms), np.array(took), np.array(ratio)


def table(case: Case, rows: list[tuple[str, dict, dict | None]]) -> None:
    """Print one scenario's rows."""
    print(f"\n{case.name}: final position bound at the truth")
    print(f"{'planner':<44}{'bound (m)':>10}{'x H=1':>7}{'ms/decision':>13}{'(10-90 %)':>15}"
          f"{'found/exhaustive':>20}")
    base = None
    for label, kw, peer in rows:
        bound, took, ratio = run(case, case.make(**kw),
                                 None if peer is None else case.make(**peer))
        base = bound if base is None else base
        q10, q50, q90 = 1e3 * np.percentile(took, [10, 50, 90])
        found = "" if not ratio.size else (f"{ratio.max():.4f} max, "
                                           f"{np.mean(ratio > 1 + 1e-9):.0%} >1")
        print(f"{label:<44}{bound:10.2f}{bound / base:7.2f}{q50:13.2f}"
              f"{f'{q10:.1f}-{q90:.1f}':>15}{found:>20}")


def main() -> None:
    """Print both scenarios."""
    r = radar()
    table(r, [("H = 1 (the paper)", {"horizon": 1}, None),
              ("H = 2, exhaustive (225 leaves)", {"horizon": 2}, None),
              ("H = 3, exhaustive (3375 leaves)", {"horizon": 3}, {"horizon": 3, "beam": 15}),
              ("H = 3, beam 15 (465 nodes)", {"horizon": 3, "beam": 15}, None),
              ("H = 3, beam 5 (165 nodes)", {"horizon": 3, "beam": 5}, None)])
    print("  (found/exhaustive on the exhaustive row: the beam-15 search's best cost over the "
          "exhaustive one's, at each of its decisions)")
    b = bearings()
    cont = Continuation(b.end, "straight")
    table(b, [("H = 1", {"horizon": 1}, None),
              ("H = 2, exhaustive (25 leaves)", {"horizon": 2}, None),
              ("H = 3, exhaustive (125 leaves)", {"horizon": 3}, {"horizon": 3, "beam": 5}),
              ("H = 3, beam 5", {"horizon": 3, "beam": 5}, None),
              ("H = 1 + straight continuation to 600 s", {"continuation": cont}, None),
              ("H = 2 + straight continuation", {"horizon": 2, "continuation": cont}, None),
              ("H = 3 + straight continuation", {"horizon": 3, "continuation": cont}, None),
              ("H = 3 + straight continuation, beam 5",
               {"horizon": 3, "continuation": cont, "beam": 5}, None)])


if __name__ == "__main__":
    main()
