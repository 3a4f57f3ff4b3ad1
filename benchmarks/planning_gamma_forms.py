"""The two forms of Gamma compared in the closed loop (issue 11, item 3).

Hurtado & Nehorai (2008), section 4.2, replace ``Gamma_{k+1} = E_x[Xi]`` by ``Xi`` at the
predicted mean ("mean", the paper's suboptimal choice); tmakit also computes the expectation over
every particle ("cloud").  This runs the reproduction's adaptive case (Example 1, the derived
radar) with each form, same seeds (common random numbers), and prints the final RMSE, the final
bound along the flown path, the minimum range and the mean decision time.

Usage::

    python benchmarks/planning_gamma_forms.py [--runs 10] [--particles 2000] [--steps 600]
"""

from __future__ import annotations

import argparse
import dataclasses

from tmakit.montecarlo.closed_loop import closed_loop_study
from tmakit.reproduce import hurtado2008 as h


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--particles", type=int, default=2000)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    base = {c.name: c for c in h.cases("derived", args.particles, args.steps)}["adaptive"]
    cases = []
    for gamma in ("mean", "cloud"):
        planner = dataclasses.replace(base.policy, gamma=gamma)
        cases.append(dataclasses.replace(base, name=f"adaptive, gamma={gamma}", policy=planner))
    study = closed_loop_study(cases, runs=args.runs, seed=args.seed, progress=False)
    print(f"adaptive case of tma reproduce hurtado2008 (derived radar), {args.runs} runs, "
          f"{args.particles} particles, same seeds")
    print(f"{'gamma':8s} {'final RMSE (m)':>15s} {'final PCRB (m)':>16s} "
          f"{'min range (m)':>14s} {'decision (ms)':>14s}")
    rows = {}
    for case in cases:
        s = study.summary(case.name)
        rows[case.name] = s
        print(f"{case.policy.gamma:8s} {s['final_rmse_m']:15.2f} {s['final_pcrb_m']:16.2f} "
              f"{s['min_range_m']:14.0f} {s['mean_decision_ms']:14.2f}")
    mean, cloud = (rows[c.name] for c in cases)
    print(f"cloud / mean: RMSE {cloud['final_rmse_m'] / mean['final_rmse_m']:.3f}, PCRB "
          f"{cloud['final_pcrb_m'] / mean['final_pcrb_m']:.3f}, decision time "
          f"{cloud['mean_decision_ms'] / mean['mean_decision_ms']:.2f}x")


if __name__ == "__main__":
    main()
