"""Angles-only 3-D from the first bearing: the Cartesian EKF against modified spherical.

The scenario is ``benchmarks/angles_only_3d.toml`` (an aircraft at 8 km altitude about 26 km
away, a weaving airborne observer at 3 km; bearing and elevation at 1 Hz, 1 deg, 240 s).  Run
``i`` simulates its measurements with ``numpy.random.default_rng([seed, i])``; every filter
starts at the first bearing from the same :class:`tmakit.BearingPrior` (``--range-prior``,
``--speed-prior``, the default height prior 0..12 km) and the same process noise
(``--q-density``), and none is told the truth:

* ``ekf``: the Cartesian EKF from the prior's mean and covariance;
* ``mpekf``: the EKF in modified spherical coordinates (Stallard 1991; Mallick et al. 2012),
  from the prior's moments in those coordinates;
* ``gsf`` (not by default): the range-parameterised Gaussian sum, for reference.

Printed per filter: the 3-D position RMS error over the runs at a few times and averaged
over all rows, the share of (run, row) pairs with the truth inside the reported 95 %
horizontal position ellipse (chi-squared, 2 dof) and inside the 95 % 3-D position ellipsoid
(3 dof), tracks lost (final error > 5x the final RMS of the best filter), CPU s per run.

    PYTHONPATH=src python benchmarks/modified_spherical.py [--runs 100] [--seed 0]
        [--filters ekf mpekf gsf] [--q-density Q] [--range-prior 5000:60000]
        [--speed-prior 300]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.scenario import truth_states

SCENARIO = Path(__file__).with_name("angles_only_3d.toml")
CHI2_95 = {2: 5.991464547107979, 3: 7.814727903251178}
TIMES = (0.0, 60.0, 90.0, 120.0, 180.0, 240.0)


def inside(d: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Whether each error ``d`` (K, m) lies inside the 95 % ellipsoid of ``cov`` (K, m, m)."""
    m2 = np.einsum("ki,ki->k", d, np.linalg.solve(cov, d[..., None])[..., 0])
    return m2 <= CHI2_95[d.shape[1]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--filters", nargs="+", default=["ekf", "mpekf"])
    ap.add_argument("--q-density", type=float, default=1e-2,
                    help="the filters' q~ (m^2/s^3; the truth flies straight)")
    ap.add_argument("--range-prior", default="5000:60000", help="MIN:MAX horizontal range (m)")
    ap.add_argument("--speed-prior", type=float, default=300.0, help="largest speed (m/s)")
    args = ap.parse_args()
    lo, hi = (float(v) for v in args.range_prior.split(":"))
    prior = tk.BearingPrior(lo, hi, args.speed_prior, given=("range", "speed"))
    scn = tk.load_scenario(SCENARIO)
    err2: dict[str, list[np.ndarray]] = {f: [] for f in args.filters}
    hits: dict[str, dict[int, list[np.ndarray]]] = {f: {2: [], 3: []} for f in args.filters}
    clock = dict.fromkeys(args.filters, 0.0)
    times = None
    for i in range(args.runs):
        meas = scn.simulate(rng=np.random.default_rng([args.seed, i]))
        for f in args.filters:
            t0 = time.process_time()
            tr = tk.track(meas, f, dim=3, bearing_prior=prior, q_density=args.q_density)
            clock[f] += time.process_time() - t0
            times = tr.times
            d = tr.states[:, :3] - truth_states(meas, tr.times, 3)[:, :3]
            err2[f].append(np.sum(d**2, axis=1))
            for m in (2, 3):
                hits[f][m].append(inside(d[:, :m], tr.covariances[:, :m, :m]))
    assert times is not None
    rows = [int(np.searchsorted(times, t, side="right")) - 1 for t in TIMES]
    final = {f: np.sqrt(np.array(err2[f])[:, -1]) for f in args.filters}
    best = min(float(np.sqrt(np.mean(v**2))) for v in final.values())
    print(f"== {SCENARIO.name}: {args.runs} runs, seed {args.seed}; prior {prior.describe()}, "
          f"height {prior.height[0]:g}..{prior.height[1]:g} m; q~ = {args.q_density:g} m^2/s^3")
    print("| filter | " + " | ".join(f"RMS at {t:g} s (m)" for t in TIMES)
          + " | mean RMS (m) | in 95 % ellipse (horizontal) | in 95 % ellipsoid (3-D) "
          "| lost | CPU s/run |")
    print("|---" * (len(TIMES) + 7) + "|")
    for f in args.filters:
        e2 = np.array(err2[f])
        rms = np.sqrt(e2.mean(axis=0))
        lost = int(np.sum(final[f] > 5 * best))
        print(f"| {f} | " + " | ".join(f"{rms[k]:.0f}" for k in rows)
              + f" | {float(np.mean(rms)):.0f} | {100 * np.mean(hits[f][2]):.1f} % "
              f"| {100 * np.mean(hits[f][3]):.1f} % | {lost} / {args.runs} "
              f"| {clock[f] / args.runs:.3f} |")


if __name__ == "__main__":
    main()
