"""Memory figure: peak RSS of `tma show` and `tma estimate --motion cv2d` on a large CSV.

    python benchmarks/memory_large_csv.py [--rows 10000000] [--latlon] [--range-differences]
        [--shared-references]

Writes a bearings-only CSV of ``rows`` rows (a CV target seen from a sensor on a zig-zag, 1 deg
noise, seeded; with ``--latlon`` the sensor positions as latitude, longitude and a sea-level
altitude with ``origin_*`` metadata, read as 2-D; with ``--range-differences`` every other
row a range difference to the row before, whose noise is then independent: the spans do not
overlap; with ``--shared-references`` the differences in threes to one reference time,
correlated), then runs each command in a fresh
process and reports its peak resident memory (its VmHWM, Linux), the file size and their
ratio, the bytes per row above what ``tma show`` of the file's first 3 rows takes (the
interpreter and libraries), and the wall time.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,sensor_vz"
GEO_HEADER = "time,sensor,kind,value,sigma,sensor_lat,sensor_lon,sensor_alt,sensor_vx,sensor_vy"
#: ENU origin of the ``--latlon`` file (deg, deg, m) and metres per degree there (approximate:
#: the file's positions only need to be near the ENU ones).
ORIGIN = (43.25, 5.375, 0.0)
M_PER_DEG_LAT, M_PER_DEG_LON = 111_132.0, 111_320.0 * np.cos(np.radians(ORIGIN[0]))


def geo_preamble() -> str:
    """Return the ``--latlon`` file's origin metadata and header lines."""
    return "".join(f"# origin_{k}: {v}\n" for k, v in zip(("lat", "lon", "alt"), ORIGIN,
                                                           strict=True)) + GEO_HEADER + "\n"


def write_csv(path: Path, rows: int, seed: int = 1, latlon: bool = False,
              range_differences: bool = False, shared: bool = False) -> None:
    rng = np.random.default_rng(seed)
    with open(path, "w") as f:
        header = geo_preamble() if latlon else HEADER + "\n"
        f.write(header[:-1] + ",time_ref\n" if range_differences else header)
        block = 1_000_000
        for lo in range(0, rows, block):
            k = np.arange(lo, min(rows, lo + block), dtype=float)
            t = 0.01 * k
            sx = 5.0 * t
            sy = 800.0 * np.floor(t / 60.0) % 1600.0
            tx, ty = 4000.0 - 6.0 * t, 9000.0 - 3.0 * t
            b = (np.degrees(np.arctan2(tx - sx, ty - sy)) + rng.normal(0, 1, k.size)) % 360
            if latlon:
                lat = ORIGIN[0] + sy / M_PER_DEG_LAT
                lon = ORIGIN[1] + sx / M_PER_DEG_LON
                pos = [f"{la:.8f},{lo:.8f},0,5,0" for la, lo in zip(lat, lon, strict=True)]
            else:
                pos = [f"{x:.3f},{y:.1f},0,5,0,0" for x, y in zip(sx, sy, strict=True)]
            if range_differences:
                f.write(range_difference_text(t, b, pos, np.hypot(tx - sx, ty - sy), rng,
                                              shared))
            else:
                f.write("".join(f"{ti:.2f},ship,bearing,{bi:.6f},1,{p}\n"
                                for ti, bi, p in zip(t, b, pos, strict=True)))


def range_difference_text(t: np.ndarray, b: np.ndarray, pos: list[str], r: np.ndarray,
                          rng: np.random.Generator, shared: bool = False) -> str:
    """Write odd rows as range differences (m), even rows as bearings.

    Each difference is to the previous row's time; with ``shared``, the three differences of
    each six rows are to the time of the first of the six (their spans overlap: correlated
    noise, one 3 x 3 block per three).  Blocks of rows start at multiples of 6.
    """
    ref = np.arange(t.size) - 1
    if shared:
        ref = (np.arange(t.size) // 6) * 6
    ref = np.maximum(ref, 0)
    dr = r - r[ref] + rng.normal(0, 1, t.size)
    return "".join(f"{t[i]:.2f},ship,bearing,{b[i]:.6f},1,{pos[i]},\n" if i % 2 == 0 else
                   f"{t[i]:.2f},ship,range_difference,{dr[i]:.3f},1,{pos[i]},{t[ref[i]]:.2f}\n"
                   for i in range(t.size))


def small_file(folder: Path, big: Path) -> Path:
    """Write the large file's preamble, header and first 3 rows (for the libraries' memory).

    The same columns and kinds: a reader or command may import more for some (range
    differences once imported pandas, 39 MB), which is not memory per row.
    """
    path = folder / "small.csv"
    lines = []
    with open(big) as f:
        for line in f:
            lines.append(line)
            if not line.startswith("#") and len(lines) > 3 and not lines[-4].startswith("#"):
                break
    path.write_text("".join(lines))
    return path


#: Runs ``tma ARGS`` and writes the process's own peak RSS (VmHWM, kB) to $TMA_BENCH_HWM at
#: exit (``ru_maxrss`` of a child also counts its parent's peak before the exec).
WRAPPER = """
import atexit, os, runpy, sys
def hwm():
    with open("/proc/self/status") as f:
        kb = next(line.split()[1] for line in f if line.startswith("VmHWM"))
    with open(os.environ["TMA_BENCH_HWM"], "w") as out:
        out.write(kb)
atexit.register(hwm)
sys.argv = ["tma", *sys.argv[1:]]
runpy.run_module("tmakit.cli", run_name="__main__")
"""


def peak_of(args: list[str], folder: Path) -> tuple[int, float, float]:
    """Run ``tma args`` in a child; return its exit code, peak RSS (MB) and wall time (s)."""
    record = folder / "hwm.txt"
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", WRAPPER, *args], capture_output=True,
                          text=True, env={**os.environ, "TMA_BENCH_HWM": str(record)})
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        print(proc.stderr[-500:])
    return proc.returncode, int(record.read_text()) / 1024, wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--latlon", action="store_true",
                    help="sensor positions as latitude/longitude/altitude (read as 2-D)")
    ap.add_argument("--range-differences", action="store_true",
                    help="every other row a range difference to the row before (time_ref)")
    ap.add_argument("--shared-references", action="store_true",
                    help="range differences in threes to one reference time (correlated noise)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "big.csv"
        write_csv(path, a.rows, latlon=a.latlon,
                  range_differences=a.range_differences or a.shared_references,
                  shared=a.shared_references)
        size = path.stat().st_size / 2**20
        print(f"{a.rows:,} rows, {size:.0f} MB ({'lat/lon/alt' if a.latlon else 'ENU'} "
              f"positions{', range differences' if a.range_differences else ''}"
              f"{', range differences sharing references' if a.shared_references else ''})")
        # the interpreter and libraries alone
        _, base, _ = peak_of(["show", str(small_file(Path(d), path))], Path(d))
        print(f"tma show of its first 3 rows: peak RSS {base:.0f} MB (the interpreter and "
              "libraries)")
        for label, args in (("tma show", ["show", str(path)]),
                            ("tma estimate --motion cv2d",
                             ["estimate", str(path), "--motion", "cv2d"])):
            code, peak, wall = peak_of(args, Path(d))
            per_row = (peak - base) * 2**20 / a.rows
            print(f"{label}: exit {code}, peak RSS {peak:.0f} MB ({peak / size:.1f}x the "
                  f"file), {per_row:.0f} bytes per row above the libraries' "
                  f"({per_row / (size * 2**20 / a.rows):.1f}x a row of the file), "
                  f"{wall:.1f} s")


if __name__ == "__main__":
    main()
