"""Kill a writer at a random moment: shared by tests/test_faults.py and benchmarks/.

A child process writes a measurement set of ``rows`` rows to ``target`` (with ``force`` over
an old file, or to a new name) and is killed with SIGKILL or SIGTERM after a random delay.
:func:`kill_once` then checks the target is absent, the old file or the complete new file,
and that the next write into the folder leaves no temporary file.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

WRITER = """
import sys, time
import numpy as np
import tmakit as tk
n, path, force = int(sys.argv[1]), sys.argv[2], sys.argv[3] == "1"
t = np.arange(n, dtype=float)
meas = tk.MeasurementSet(t, np.full(n, "s"), np.full(n, "bearing"), (t % 360.0),
                         np.ones(n), np.zeros((n, 6)))
print("ready", flush=True)
tk.write_measurements(meas, path, force=force)
print("done", flush=True)
"""


def expected_rows(path: Path) -> int:
    import tmakit as tk

    return len(tk.read_measurements(path))


def start_writer(rows: int, target: Path, force: bool) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(rows), str(target),
                             "1" if force else "0"], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"  # imports done: the write starts now
    return proc


def kill_once(folder: Path, suffix: str, rows: int, delay: float, sig: int,
              overwrite: bool) -> str:
    """Kill one writer after ``delay`` s; return 'absent', 'old', 'new' or a failure."""
    import tmakit as tk

    target = folder / f"obs{suffix}"
    for p in folder.iterdir():
        p.unlink()
    old_rows = 0
    if overwrite:
        t = np.arange(5.0)
        tk.write_measurements(tk.MeasurementSet(t, ["s"] * 5, ["bearing"] * 5, t, np.ones(5),
                                                np.zeros((5, 6))), target)
        old_rows = 5
    proc = start_writer(rows, target, overwrite)
    time.sleep(delay)
    proc.send_signal(sig)
    proc.wait()
    if not target.exists():
        state = "absent"
    else:
        try:
            n = expected_rows(target)
        except Exception as e:  # a partial file is the failure counted
            return f"partial target ({type(e).__name__})"
        state = {old_rows: "old", rows: "new"}.get(n, f"wrong rows ({n})")
    # the next write into the folder removes what the killed writer left
    t = np.arange(3.0)
    tk.write_measurements(tk.MeasurementSet(t, ["s"] * 3, ["bearing"] * 3, t, np.ones(3),
                                            np.zeros((3, 6))), folder / f"next{suffix}")
    left = [p.name for p in folder.iterdir() if p.name.endswith(".tmp")
            or ".tmp." in p.name]
    if left:
        return f"temp left: {left}"
    return state


SIGNALS = {"SIGKILL": signal.SIGKILL, "SIGTERM": signal.SIGTERM}
__all__ = ["SIGNALS", "kill_once", "os"]
