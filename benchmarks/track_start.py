"""How the start of `tma track` decides the consistency of the track (docs/tracking.md).

For each start quality (the batch start's position std as a fraction of the range; ``inf``
= any converged, observable window) the bearings-only-2d scenario is simulated ``--runs``
times and tracked from the batch start with one filter; printed per setting: when the track
starts (mean and latest), how many starts the innovation test rejected, the mean NEES over
the track and at its end (4 state components: 4 when consistent; the 95 % band of the mean
over R runs is chi2(4R) / R), and the final position RMS error.

    python benchmarks/track_start.py --runs 40 --seed 100
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.stats import chi2

import tmakit as tk
from tmakit.tracking import truth_states


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--seed", type=int, default=100, help="first simulation seed")
    parser.add_argument("--filter", default="ekf")
    parser.add_argument("--start-std", default="inf,0.3,0.25,0.2",
                        help="comma-separated start qualities to compare")
    parser.add_argument("--q", type=float, default=0.0, help="process noise (m/s^2)")
    parser.add_argument("--no-confirm", action="store_true",
                        help="keep the first qualifying start (no innovation test)")
    args = parser.parse_args()

    scn = tk.load_scenario("bearings-only-2d")
    data = [scn.simulate(rng=args.seed + r) for r in range(args.runs)]
    lo, hi = (chi2.ppf(p, 4 * args.runs) / args.runs for p in (0.025, 0.975))
    print(f"bearings-only-2d, {args.runs} runs (seeds {args.seed}..{args.seed + args.runs - 1}),"
          f" filter {args.filter}, q = {args.q:g} m/s^2"
          + (", no innovation test" if args.no_confirm else "") + "; 95 % band of a mean NEES: "
          f"{lo:.2f} .. {hi:.2f}")
    print(f"{'start std':>10} {'start t (s)':>12} {'latest':>7} {'restarts':>9} "
          f"{'mean NEES':>10} {'final NEES':>11} {'final pos RMS (m)':>18} {'s/run':>6}")
    for text in args.start_std.split(","):
        rel = float(text)
        starts, restarts, mean_nees, final_nees, sq = [], 0, [], [], []
        t0 = time.perf_counter()
        for r, meas in enumerate(data):
            tr = tk.track(meas, args.filter, q=args.q, max_relative_std=rel,
                          confirm=not args.no_confirm, rng=args.seed + r)
            truth = truth_states(meas, tr.times, 2)
            nees = tr.nees(truth)
            starts.append(tr.times[0])
            restarts += len(tr.extra["start"]["rejected"])
            mean_nees.append(float(np.mean(nees[1:])))
            final_nees.append(float(nees[-1]))
            e = tr.errors(truth)[-1, :2]
            sq.append(float(e @ e))
        wall = (time.perf_counter() - t0) / args.runs
        print(f"{rel:>10g} {np.mean(starts):12.1f} {np.max(starts):7.0f} {restarts:9d} "
              f"{np.mean(mean_nees):10.3g} {np.mean(final_nees):11.3g} "
              f"{np.sqrt(np.mean(sq)):18.1f} {wall:6.2f}")


if __name__ == "__main__":
    main()
