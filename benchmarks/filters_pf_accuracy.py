"""Particle filters compared at equal accuracy as well as at equal particle count.

Problem: scenario ``bearings-only-2d`` (600 bearings, 1 Hz, 1°, zig-zagging observer), the
same as ``filters_speed_stonesoup.py``: process noise ``q`` = 0.01 m/s^2 per axis, prior
``P0 = diag(500^2, 500^2, 5^2, 5^2)`` (m, m/s).  Run ``r`` draws new measurement noise and a
prior mean ``m0 ~ N(x_true(0), P0)`` from ``numpy.random.default_rng([seed, r])``; every filter
and every particle count sees the same runs.  Accuracy = final position RMSE over the runs
(m, at 600 s).

Filters (the peers as in ``filters_speed_stonesoup.py``: the same data, ``Q_k``, detections
with the moving observer as ``translation_offset``, resampling when the effective sample size
is below N/2, systematic resampling):

* ``tmakit``: :class:`tmakit.filters.ParticleFilter` (regularised SIR);
* ``stonesoup``: Stone Soup's ``ParticlePredictor`` + ``ParticleUpdater`` (plain SIR);
* ``stonesoup+mcmc`` (``--regularised``): the same with Stone Soup's ``MCMCRegulariser``.

Two tables:

* equal count: RMSE and per-step time of each filter at each N;
* equal accuracy: for each peer count N_p, the peer's RMSE there is the target; tmakit's count
  is the smallest of its ladder whose RMSE is at most that target, and the times per step are
  compared at those two counts ("not reached" if no tmakit count on the ladder does).

With few runs an RMSE carries a Monte Carlo error of about RMSE / sqrt(2 runs): the counts
needed are coarse (a ladder of doubling counts), not exact.

Time per step: the filter's whole run (tmakit: ``filter.run(meas)``; Stone Soup: its
predict/hypothesis/update loop over detections built beforehand) / 600, median over the runs
[interquartile range]; ``--clock cpu`` (default) is the process CPU time, less disturbed by
other work on a shared machine than ``--clock wall``.

    PYTHONPATH=src python benchmarks/filters_pf_accuracy.py [--runs 8] [--seed 0]
        [--tmakit 50 100 250 1000 4000] [--peer 250 1000 4000] [--regularised]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_problems import fmt

import tmakit as tk
from tmakit.filters import ParticleFilter

Q = 0.01
P0 = np.diag([500.0**2, 500.0**2, 5.0**2, 5.0**2])
CLOCKS = {"cpu": time.process_time, "wall": time.perf_counter}


def runs_data(runs, seed):
    """Per run: measurements, prior mean, final true position ``[x, y]`` (m)."""
    scn = tk.load_scenario("bearings-only-2d")
    truth0 = scn.target_states([0.0])[0][[0, 1, 3, 4]]
    out = []
    for r in range(runs):
        rng = np.random.default_rng([seed, r])
        meas = scn.simulate(rng)
        mean0 = truth0 + np.linalg.cholesky(P0) @ rng.standard_normal(4)
        end = scn.target_states([float(meas.time.max())])[0][[0, 1]]
        out.append((meas, mean0, end))
    return out


def tmakit_pf(meas, mean0, particles, seed, clock):
    """(seconds per step, final [x, y]) of tmakit's particle filter."""
    filt = ParticleFilter(mean0, P0, 0.0, q=Q, particles=particles, rng=seed)
    t0 = clock()
    track = filt.run(meas)
    return (clock() - t0) / len(track), track.states[-1, :2]


def stonesoup_pf(meas, mean0, particles, seed, clock, regularise):
    """(seconds per step, final [x, y]) of Stone Soup's particle filter."""
    from filters_speed_stonesoup import stonesoup_problem, stonesoup_run

    problem = stonesoup_problem(meas, mean0, P0, Q)
    return stonesoup_run("pf", problem, particles, seed, regularise, clock=clock)


def ladder(name, counts, data, clock, seed):
    """``{N: (rmse m, (median, q1, q3) s per step)}`` of one filter over the runs."""
    out = {}
    for n in counts:
        errs, times = [], []
        for r, (meas, mean0, end) in enumerate(data):
            if name == "tmakit":
                per, pos = tmakit_pf(meas, mean0, n, seed + r, clock)
            else:
                per, pos = stonesoup_pf(meas, mean0, n, seed + r, clock,
                                        name == "stonesoup+mcmc")
            errs.append(float(np.sum((pos - end) ** 2)))
            times.append(per)
        out[n] = (float(np.sqrt(np.mean(errs))),
                  (float(np.median(times)), float(np.percentile(times, 25)),
                   float(np.percentile(times, 75))))
    return out


def equal_accuracy(ours, peer):
    """Rows ``(N_peer, rmse_peer, N_tmakit or None, rmse_tmakit, t_peer, t_tmakit)``."""
    rows = []
    for n_p, (rmse_p, t_p) in peer.items():
        n_t = next((n for n in sorted(ours) if ours[n][0] <= rmse_p), None)
        rows.append((n_p, rmse_p, n_t, ours[n_t][0] if n_t else float("nan"), t_p,
                     ours[n_t][1] if n_t else None))
    return rows


def measure(runs, seed, ours_counts, peer_counts, regularised, clock="cpu"):
    """Rows (what, tmakit, peer, ratio, note) for ``run_all.py``: equal accuracy per peer N."""
    tick = CLOCKS[clock]
    data = runs_data(runs, seed)
    ours = ladder("tmakit", ours_counts, data, tick, seed)
    peers = ["stonesoup"] + (["stonesoup+mcmc"] if regularised else [])
    rows = []
    for name in peers:
        table = ladder(name, peer_counts, data, tick, seed)
        for n_p, rmse_p, n_t, rmse_t, t_p, t_t in equal_accuracy(ours, table):
            what = f"PF equal accuracy vs {name} N={n_p} ({runs} runs)"
            if n_t is None:
                rows.append((what, "not reached", f"{name} {fmt(t_p, 1e6, 'us')}", float("nan"),
                             f"{name} RMSE {rmse_p:.0f} m; tmakit best "
                             f"{min(v[0] for v in ours.values()):.0f} m"))
                continue
            rows.append((what, f"N={n_t} {fmt(t_t, 1e6, 'us')}",
                         f"{name} {fmt(t_p, 1e6, 'us')}", t_p[0] / t_t[0],
                         f"peer/tmakit; RMSE {name} {rmse_p:.0f} m, tmakit {rmse_t:.0f} m"))
        for n in sorted(set(table) & set(ours)):
            rows.append((f"PF equal count N={n} vs {name} ({runs} runs)",
                         fmt(ours[n][1], 1e6, "us"), f"{name} {fmt(table[n][1], 1e6, 'us')}",
                         table[n][1][0] / ours[n][1][0],
                         f"peer/tmakit; RMSE tmakit {ours[n][0]:.0f} m, {name} "
                         f"{table[n][0]:.0f} m"))
    return rows, ours


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tmakit", type=int, nargs="+", default=[50, 100, 250, 1000, 4000])
    ap.add_argument("--peer", type=int, nargs="+", default=[250, 1000, 4000])
    ap.add_argument("--regularised", action="store_true",
                    help="also Stone Soup with its MCMCRegulariser")
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="cpu")
    args = ap.parse_args()
    try:
        import stonesoup  # noqa: F401
    except ImportError:
        ap.exit(2, "error: Stone Soup is not installed: pip install 'tmakit[bench]' "
                   "(or pip install stonesoup)\n")
    rows, ours = measure(args.runs, args.seed, args.tmakit, args.peer, args.regularised,
                         args.clock)
    print(f"bearings-only-2d, {args.runs} runs, seed {args.seed}, q = {Q} m/s^2, clock "
          f"{args.clock}")
    for n, (rmse, t) in ours.items():
        print(f"tmakit N={n:<6d} RMSE {rmse:8.0f} m   {fmt(t, 1e6, 'us')} per step")
    for what, mine, peer, ratio, note in rows:
        print(f"{what:52s} {mine:28s} {peer:40s} {ratio:6.2f}  {note}")


if __name__ == "__main__":
    main()
