"""Monte Carlo throughput: ML with no initial guess on gu2007 (C and f_s unknown), many runs,
in this process and on a two-worker local Dask cluster (the machine's 2 cores).

    python benchmarks/montecarlo_speed.py [--runs 10000] [--seed 0] [--workers 2]
"""

from __future__ import annotations

import argparse
import time

import tmakit as tk
from tmakit.montecarlo import monte_carlo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--chunk", type=int, default=250)
    parser.add_argument("--skip-local", action="store_true", help="only the cluster run")
    args = parser.parse_args()
    scn = tk.load_scenario("gu2007")

    def report(label: str, res, wall: float) -> None:
        ratios = " ".join(f"{r['ratio']:.3f}" for r in res.summary_table())
        print(f"{label:<34} {args.runs} runs in {wall:6.1f} s = {args.runs / wall:7.1f} runs/s; "
              f"converged {res.convergence_rate:.2%}; RMSE/CRLB {ratios}")

    if not args.skip_local:
        t0 = time.perf_counter()
        res = monte_carlo(scn, runs=args.runs, seed=args.seed, progress=False,
                          chunk=args.chunk)
        report("one process", res, time.perf_counter() - t0)

    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.run(lambda: __import__("tmakit.montecarlo"))  # warm the workers' imports
        t0 = time.perf_counter()
        res = monte_carlo(scn, runs=args.runs, seed=args.seed, progress=False,
                          chunk=args.chunk, dask=client)
        report(f"local Dask cluster, {args.workers} workers", res, time.perf_counter() - t0)


if __name__ == "__main__":
    main()
