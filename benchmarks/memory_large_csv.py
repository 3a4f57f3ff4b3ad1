"""Memory figure: peak RSS of `tma show` and `tma estimate --motion cv2d` on a large CSV.

    python benchmarks/memory_large_csv.py [--rows 10000000]

Writes a bearings-only CSV of ``rows`` rows (a CV target seen from a sensor on a zig-zag, 1 deg
noise, seeded), then runs each command in a fresh process and reports its peak resident
memory (``ru_maxrss`` of the child), the file size and their ratio, and the wall time.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,sensor_vz"


def write_csv(path: Path, rows: int, seed: int = 1) -> None:
    rng = np.random.default_rng(seed)
    with open(path, "w") as f:
        f.write(HEADER + "\n")
        block = 1_000_000
        for lo in range(0, rows, block):
            k = np.arange(lo, min(rows, lo + block), dtype=float)
            t = 0.01 * k
            sx = 5.0 * t
            sy = 800.0 * np.floor(t / 60.0) % 1600.0
            tx, ty = 4000.0 - 6.0 * t, 9000.0 - 3.0 * t
            b = (np.degrees(np.arctan2(tx - sx, ty - sy)) + rng.normal(0, 1, k.size)) % 360
            table = np.column_stack([t, b, sx, sy])
            lines = [f"{r[0]:.2f},ship,bearing,{r[1]:.6f},1,{r[2]:.3f},{r[3]:.1f},0,5,0,0"
                     for r in table]
            f.write("\n".join(lines) + "\n")


def peak_of(args: list[str]) -> tuple[int, float, float]:
    """Run a command in a child; return its exit code, peak RSS (MB) and wall time (s)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.perf_counter()
    proc = subprocess.run(args, capture_output=True, text=True)
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if peak <= before:  # ru_maxrss of children is the max over all children so far
        print("  (peak not above an earlier child's; reported as at most that)")
    if proc.returncode not in (0, 1):
        print(proc.stderr[-500:])
    return proc.returncode, peak / 1024, wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=10_000_000)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "big.csv"
        write_csv(path, a.rows)
        size = path.stat().st_size / 2**20
        print(f"{a.rows:,} rows, {size:.0f} MB")
        cmd = [sys.executable, "-m", "tmakit.cli"]
        for label, args in (("tma show", [*cmd, "show", str(path)]),
                            ("tma estimate --motion cv2d",
                             [*cmd, "estimate", str(path), "--motion", "cv2d"])):
            code, peak, wall = peak_of(args)
            print(f"{label}: exit {code}, peak RSS {peak:.0f} MB ({peak / size:.1f}x the "
                  f"file), {wall:.1f} s")


if __name__ == "__main__":
    main()
