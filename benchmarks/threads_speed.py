"""BLAS threads: the particle filter with 10^5 particles per step, default threads against
one thread (``threadpoolctl``), side by side; and the results' equality across thread counts.

The problem is bearings-only-2d (600 bearings); the filter runs its first ``--steps`` updates
from a prior N(truth + offset, P0), seeded.  Medians [interquartile range] of interleaved
repeats, per step.

    PYTHONPATH=src python benchmarks/threads_speed.py [--particles 100000] [--steps 20]
        [--repeat 5]
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_problems import fmt, interleaved
from threadpoolctl import threadpool_limits

import tmakit as tk
from tmakit.filters import ParticleFilter


def pf_rows(particles, steps, repeat):
    """PF per-step time with default BLAS threads and with one; equal tracks."""
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(0))
    meas = meas.take(np.argsort(meas.time)[:steps])
    mean0 = scn.target_states([0.0])[0][[0, 1, 3, 4]] + np.array([500.0, -300.0, 1.0, -1.0])
    p0 = np.diag([1000.0**2, 1000.0**2, 4.0**2, 4.0**2])

    def run():
        return ParticleFilter(mean0, p0, 0.0, q=0.01, particles=particles, rng=3).run(meas)

    def single():
        with threadpool_limits(1, user_api="blas"):
            return run()

    same = np.array_equal(run().states, single().states)
    stats = interleaved({"default": run, "one thread": single}, repeat)
    per = {k: tuple(v / steps for v in s) for k, s in stats.items()}
    return [(f"PF {particles} particles per step, default BLAS threads",
             fmt(per["default"], 1e3), f"one thread {fmt(per['one thread'], 1e3)}",
             per["default"][0] / per["one thread"][0],
             f"default/one (goal <= 1.2); tracks identical: {same}")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--particles", type=int, default=100_000)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    for what, ours, peer, ratio, note in pf_rows(args.particles, args.steps, args.repeat):
        print(f"{what:50s} {ours:26s} {peer:36s} {ratio:7.2f}  {note}")


if __name__ == "__main__":
    main()
