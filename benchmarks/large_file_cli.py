"""`tma estimate` on a large file beside the library's own read + estimate, as processes.

    python benchmarks/large_file_cli.py [--rows 10000000] [--repeat 3] [--file big.csv]

Writes a bearings-only CSV of ``rows`` rows in a temporary folder (the file of
``memory_large_csv.py``: a CV target seen from a sensor on a zig-zag, seeded), unless
``--file`` names one already written, then runs, alternating, ``repeat`` times each:

* the command: ``tma estimate FILE --motion cv2d`` (the installed ``tma`` beside this Python);
* the library: ``python -c`` reading the file with ``tmakit.read_measurements`` and fitting it
  with ``tmakit.estimate(meas, "cv2d")``, printing the summary.

Each run is a fresh process, measured from outside as ``/usr/bin/time`` does (``os.wait4``):
wall time, CPU time (user + system) and peak resident memory (``ru_maxrss``).  This script
imports no numerical library, so a child's peak is its own (a child counts its parent's pages
until it runs the command).  Printed: the medians [interquartile range] of each, the medians of
the ratios of the pairs (command / library), and the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

LIBRARY = ("import sys, tmakit as tk; meas = tk.read_measurements(sys.argv[1]); "
           "print(tk.estimate(meas, 'cv2d').summary())")


def run(cmd: list[str]) -> tuple[float, float, float, int]:
    """Run ``cmd``; give its wall and CPU seconds, peak RSS (MiB) and exit status."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024, proc.returncode


def write_file(path: Path, rows: int) -> None:
    """Write the benchmark file in a child process (this one stays small)."""
    code = (f"import sys; sys.path.insert(0, {str(HERE)!r}); from pathlib import Path; "
            f"from memory_large_csv import write_csv; write_csv(Path({str(path)!r}), {rows})")
    subprocess.run([sys.executable, "-c", code], check=True)


def quartiles(values: list[float]) -> tuple[float, float, float]:
    """Median and interquartile range (the quartiles of the ``inclusive`` method)."""
    if len(values) < 2:
        return values[0], values[0], values[0]
    q1, q2, q3 = statistics.quantiles(values, n=4, method="inclusive")
    return q2, q1, q3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--file", type=Path, default=None,
                    help="a file written by an earlier run (else one is written and removed)")
    args = ap.parse_args()
    tma = shutil.which("tma", path=str(Path(sys.executable).parent)) or shutil.which("tma")
    if tma is None:
        sys.exit("no `tma` command beside this Python: pip install -e .")
    with tempfile.TemporaryDirectory() as folder:
        path = args.file
        if path is None:
            path = Path(folder) / "big.csv"
            t0 = time.perf_counter()
            write_file(path, args.rows)
            print(f"wrote {args.rows:,} rows ({path.stat().st_size / 2**20:.0f} MiB) in "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
        commands = {"tma estimate": [tma, "estimate", str(path), "--motion", "cv2d"],
                    "library": [sys.executable, "-c", LIBRARY, str(path)]}
        print(f"load average before: {os.getloadavg()[0]:.2f}", flush=True)
        got: dict[str, list[tuple[float, float, float, int]]] = {k: [] for k in commands}
        for cmd in commands.values():
            run(cmd)  # warm-up: the file in the page cache, the byte code compiled
        for _ in range(args.repeat):
            for name, cmd in commands.items():
                got[name].append(run(cmd))
        print(f"load average after: {os.getloadavg()[0]:.2f}")
    print(f"{'':14s} {'wall (s)':>24s} {'CPU (s)':>24s} {'peak RSS (MiB)':>26s}  exit")
    for name, runs in got.items():
        cells = [quartiles([r[i] for r in runs]) for i in range(3)]
        print(f"{name:14s} " + " ".join(f"{m:9.2f} [{a:.2f}-{b:.2f}]".rjust(24 if i < 2 else 26)
                                        for i, (m, a, b) in enumerate(cells))
              + f"  {sorted({r[3] for r in runs})}")
    pairs = list(zip(got["tma estimate"], got["library"], strict=True))
    ratios = [statistics.median(c[i] / lib[i] for c, lib in pairs) for i in range(3)]
    print(f"{'tma / library':14s} " + " ".join(f"{r:9.3f}".rjust(24 if i < 2 else 26)
                                               for i, r in enumerate(ratios))
          + "  (medians of the pairs' ratios; goal <= 1.10)")


if __name__ == "__main__":
    main()
