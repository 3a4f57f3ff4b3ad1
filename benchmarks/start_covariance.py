"""Batch-start consistency on bearings-only data, linearised vs profile-likelihood covariance.

For seeded runs of a built-in scenario, ``tk.track(meas, "ekf")`` starts from a batch fit over
the shortest good window; this prints the start's NEES against the truth (full state, and
position), the fraction of runs with the truth inside the start's 95 % ellipse, the first output
time and the CPU per track, with the start covariance as the batch fit linearises it ("before")
and widened to the profile likelihood (``likelihood_covariance``, "after"), in one process.

    python benchmarks/start_covariance.py --scenario hoerst2010 --runs 50
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.stats import chi2

import tmakit as tk
from tmakit.scenario.files import load_scenario
from tmakit.tracking import initiators
from tmakit.tracking.errors import TrackingError


def run(name: str, seeds: range, widen: bool) -> dict[str, np.ndarray]:
    """Start NEES (full, position), first output time and CPU per seeded run."""
    scn = load_scenario(name)
    keep = initiators.likelihood_covariance
    if not widen:
        initiators.likelihood_covariance = lambda result, *a, **k: (result.covariance, ())
    out: dict[str, list[float]] = {k: [] for k in ("nees", "pos", "t0", "cpu", "failed", "seed")}
    try:
        for s in seeds:
            meas = scn.simulate(rng=s)
            c0 = time.process_time()
            try:
                tr = tk.track(meas, "ekf")
            except TrackingError:
                out["failed"].append(s)
                continue
            out["cpu"].append(time.process_time() - c0)
            x, p = tr.states[0], tr.covariances[0]
            d = len(x) // 2
            true = scn.target_states([tr.times[0]])[0]
            e = x - np.concatenate([true[:d], true[3:3 + d]])
            out["nees"].append(float(e @ np.linalg.solve(p, e)))
            out["pos"].append(float(e[:d] @ np.linalg.solve(p[:d, :d], e[:d])))
            out["t0"].append(float(tr.times[0]))
            out["seed"].append(s)
    finally:
        initiators.likelihood_covariance = keep
    return {k: np.array(v) for k, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="hoerst2010")
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--first-seed", type=int, default=0)
    args = ap.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.runs)
    for label, widen in (("before", False), ("after", True)):
        r = run(args.scenario, seeds, widen)
        n = len(r["nees"])
        d = 2  # (the built-in bearings-only scenarios are 2-D)
        full, pos = chi2.ppf(0.95, 2 * d), chi2.ppf(0.95, d)
        print(f"{args.scenario} {label}: {n} starts ({len(r['failed'])} failed) | start NEES "
              f"median {np.median(r['nees']):.3g}, 90th pct {np.percentile(r['nees'], 90):.3g}, "
              f"max {np.max(r['nees']):.3g} | truth inside 95 % state ellipsoid "
              f"{np.mean(r['nees'] <= full):.0%}, position ellipse {np.mean(r['pos'] <= pos):.0%}"
              f" | first output median {np.median(r['t0']):g} s | CPU per track mean "
              f"{np.mean(r['cpu']):.3f} s")
        worst = int(np.argmax(r["nees"]))
        print(f"   worst NEES {r['nees'][worst]:.3g} (position {r['pos'][worst]:.3g}) at seed "
              f"{int(r['seed'][worst])}")


if __name__ == "__main__":
    main()
