"""Fault figure: writers of 1e6-row measurement files killed at random moments.

    python benchmarks/fault_kills.py [--kills 100] [--rows 1000000] [--seed 1]

Half the kills write CSV, half Parquet; half overwrite an old file with force, half write a
new one; the signal alternates SIGKILL / SIGTERM.  Each delay is uniform over the measured
duration of one uninterrupted write.  Prints the outcomes (absent / old / new are correct;
anything else, a partial target or a temporary file left after the next write, is a failure).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from faults import SIGNALS, kill_once, start_writer


def write_time(folder: Path, suffix: str, rows: int) -> float:
    target = folder / f"timing{suffix}"
    proc = start_writer(rows, target, True)
    start = time.perf_counter()
    proc.wait()
    elapsed = time.perf_counter() - start
    target.unlink()
    return elapsed


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kills", type=int, default=100)
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    counts: Counter[tuple[str, str]] = Counter()
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        durations = {s: write_time(folder, s, a.rows) for s in (".csv", ".parquet")}
        print("uninterrupted write: " + ", ".join(f"{s} {t:.2f} s" for s, t in
                                                  durations.items()))
        for k in range(a.kills):
            suffix = (".csv", ".parquet")[k % 2]
            overwrite = (k // 2) % 2 == 1
            sig = ("SIGKILL", "SIGTERM")[(k // 4) % 2]
            delay = float(rng.uniform(0.0, durations[suffix]))
            state = kill_once(folder, suffix, a.rows, delay, SIGNALS[sig], overwrite)
            counts[(suffix, state)] += 1
    good = {"absent", "old", "new"}
    print(f"{a.kills} kills of {a.rows:,}-row writes (seed {a.seed})")
    print("| format | outcome | count |\n|---|---|---|")
    for (suffix, state), n in sorted(counts.items()):
        print(f"| {suffix} | {state} | {n} |")
    bad = sum(n for (_, state), n in counts.items() if state not in good)
    print(f"partial targets or temporary files left: {bad}")


if __name__ == "__main__":
    main()
