"""Monte Carlo throughput: ML with no initial guess on gu2007 (C and f_s unknown), many runs,
in this process, in a pool of worker processes and on a local Dask cluster of as many workers.

One process and the pool are measured interleaved (``--repeat`` rounds, each running both), so
that a shared machine's load falls on both; the Dask cluster after them, in its own phase: its
scheduler runs in this process (an event loop with heartbeats), and while it is up it took a
quarter of this process's time from the one-process runs (10.2 s against 7.3 s for 10,000
runs on a 2.1 GHz Xeon).  The figures are medians with interquartile ranges.
One process's CPU time is printed too (what an idle machine's wall time would be).  The
tables of all three are compared run for run (same seed, same chunks: identical).

    python benchmarks/montecarlo_speed.py [--runs 10000] [--seed 0] [--workers 2] [--repeat 3]
        [--chunk 50] [--no-dask]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_problems import fmt

import tmakit as tk
from tmakit.montecarlo import monte_carlo


def _stat(values):
    return (float(np.median(values)), float(np.percentile(values, 25)),
            float(np.percentile(values, 75)))


def measure(runs, workers=2, repeat=3, seed=0, chunk=None, dask=True):
    """Time one process and ``workers`` processes interleaved, then ``workers`` Dask workers.

    Returns
    -------
    dict
        ``wall`` (per executor, a list of s), ``cpu`` (one process's CPU s per round),
        ``same`` (whether every executor gave the one-process table), ``result`` (one
        process's last result).
    """
    scn = tk.load_scenario("gu2007")
    monte_carlo(scn, runs=min(runs, 50), seed=seed, progress=False)  # warm the imports
    wall = {"one": [], "pool": [], "dask": []}
    cpu, tables, res = [], {}, None

    def run(name, **kw):
        t0 = time.perf_counter()
        out = monte_carlo(scn, runs=runs, seed=seed, progress=False, chunk=chunk, **kw)
        wall[name].append(time.perf_counter() - t0)
        tables[name] = out.table
        return out

    for _ in range(repeat):
        c0 = time.process_time()
        res = run("one")
        cpu.append(time.process_time() - c0)
        run("pool", workers=workers)
    if dask:  # its own phase: the cluster's scheduler runs in this process (see the docstring)
        from distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        client.run(lambda: __import__("tmakit.montecarlo"))  # warm the workers' imports
        try:
            for _ in range(repeat):
                run("dask", dask=client)
        finally:
            client.close()
            cluster.close()
    same = all(t.equals(tables["one"]) for t in tables.values())
    return {"wall": {k: v for k, v in wall.items() if v}, "cpu": cpu, "same": same,
            "result": res}


def rows(runs, workers=2, repeat=3, seed=0, chunk=None, dask=True):
    """The Monte Carlo rows of ``run_all.py``: (what, ours, peer, ratio, note)."""
    m = measure(runs, workers, repeat, seed, chunk, dask)
    one, cpu = _stat(m["wall"]["one"]), _stat(m["cpu"])
    label = f"Monte Carlo gu2007 no guess, {runs} runs"
    goal = 10.0 * runs / 10_000
    out = [(f"{label}, one process", fmt(one, 1.0, "s"), f"goal <= {goal:g} s", one[0],
            f"CPU {fmt(cpu, 1.0, 's')}; converged {m['result'].convergence_rate:.1%}")]
    for name, what in (("pool", "processes"), ("dask", "Dask workers")):
        if name in m["wall"]:
            got = _stat(m["wall"][name])
            out.append((f"{label}, {workers} {what}", fmt(got, 1.0, "s"),
                        f"one process {fmt(one, 1.0, 's')}", one[0] / got[0],
                        f"one/{workers} {what} (goal > 1); same table: {m['same']}"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--chunk", type=int, default=None, help="runs per task (default 50)")
    parser.add_argument("--no-dask", action="store_true", help="no Dask cluster")
    args = parser.parse_args()
    for what, ours, peer, ratio, note in rows(args.runs, args.workers, args.repeat, args.seed,
                                              args.chunk, not args.no_dask):
        print(f"{what:58s} {ours:26s} {peer:30s} {ratio:6.2f}  {note}", flush=True)


if __name__ == "__main__":
    main()
