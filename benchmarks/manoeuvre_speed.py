"""CPU time of the hoerst2010 manoeuvre estimate beside an earlier commit, in one process.

    PYTHONPATH=src python benchmarks/manoeuvre_speed.py --base fbbd762 --runs 1 2 3 4 5

The base commit's ``src/tmakit`` is exported to a temporary folder and imported under another
name (``tmakit_base``), so that both trees run in the same process, interleaved data set by
data set: the earlier code and this tree.  Each estimate is ``M = 0 .. 3`` on the
seeded runs of ``benchmarks/montecarlo_hoerst2010.py`` (``SeedSequence(0)``), timed by
``time.process_time`` (BLAS on one thread; one untimed warm-up estimate first, which imports
numba and loads the kernels).  The order of the variants turns: ``--repeat`` estimates of
each per run, forwards and backwards, the first variant changing run by run.  In a fixed order
the later variants gain: two copies of the same code alternated old, new, old, new measured
new 7 % faster (medians of 4 runs; 1.00x forwards and backwards).  Printed:
every run's times (medians over the repeats) and ratios, whether the chosen order and held
accelerations agree, and the medians with the ratios' interquartile range.  On a loaded machine
the ratios hold better than the times.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import importlib
import io
import re
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def export_base(commit: str, folder: Path) -> None:
    """Export ``src/tmakit`` of ``commit`` into ``folder/tmakit_base``, renamed throughout."""
    blob = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "src/tmakit"],
                          check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
        tar.extractall(folder, filter="data")
    (folder / "src" / "tmakit").rename(folder / "tmakit_base")
    for path in (folder / "tmakit_base").rglob("*.py"):
        text = path.read_text()
        path.write_text(re.sub(r"\btmakit\b", "tmakit_base", text))


def main() -> None:
    """Time the two trees interleaved and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="fbbd762", help="the earlier commit (default fbbd762)")
    ap.add_argument("--runs", type=int, nargs="+", default=[1, 2, 3, 4, 5],
                    help="run numbers (1-based) of the 200 seeded runs")
    ap.add_argument("--repeat", type=int, default=2,
                    help="estimates of each variant per run, the order turned (default 2)")
    args = ap.parse_args()
    import tmakit as tk
    from tmakit.batch.curvilinear import estimate_manoeuvres as new_estimate

    with tempfile.TemporaryDirectory() as tmp:
        export_base(args.base, Path(tmp))
        sys.path.insert(0, tmp)
        old_estimate = importlib.import_module("tmakit_base.batch.curvilinear"
                                               ).estimate_manoeuvres
        scn = tk.load_scenario("hoerst2010")
        seeds = np.random.SeedSequence(0).generate_state(max(args.runs))

        def data(i: int) -> tk.MeasurementSet:
            return scn.simulate(rng=np.random.default_rng(int(seeds[i - 1])))

        warm = data(args.runs[0])
        new_estimate(warm, 1)
        old_estimate(warm, 1)
        rows = []
        variants = (old_estimate, new_estimate)
        for i in args.runs:
            meas = data(i)
            spent: list[list[float]] = [[], []]
            chosen: list[tuple] = [(), ()]
            for k in range(args.repeat):
                order = [(len(rows) + j) % 2 for j in range(2)]  # turned run by run
                for v in order if k % 2 == 0 else order[::-1]:  # and back and forth
                    t0 = time.process_time()
                    res = variants[v](meas, 3)
                    spent[v].append(time.process_time() - t0)
                    chosen[v] = (res.manoeuvres, sorted(res.held))
            times = [float(np.median(x)) for x in spent]
            rows.append(times)
            old, new = times
            print(f"run {i}: base {old:.2f} s, this tree {new:.2f} s ({old / new:.2f}x); same "
                  f"order and held: {chosen[0] == chosen[1]}", flush=True)
    t = np.array(rows)
    r = t[:, 0] / t[:, 1]
    med = np.median(t, axis=0)
    print(f"median CPU: base {med[0]:.2f} s, this tree {med[1]:.2f} s; base / this tree "
          f"{np.median(r):.2f}x (IQR {np.percentile(r, 25):.2f}..{np.percentile(r, 75):.2f})")


if __name__ == "__main__":
    main()
