"""Fault injection: writers killed at random moments never leave a partial target.

Each kill (SIGKILL or SIGTERM, at a seeded random delay into the write) must leave the target
absent, the old file (a killed ``--force`` overwrite) or the complete new file, and the next
write into the folder must leave no temporary file.  benchmarks/fault_kills.py runs 100 kills
of 1e6-row writes; here a few small ones.
"""

from __future__ import annotations

import numpy as np
import pytest
from faults import SIGNALS, kill_once


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize("overwrite", [False, True])
def test_a_killed_writer_leaves_no_partial_target_and_no_temporary_file(tmp_path, suffix,
                                                                        overwrite):
    rng = np.random.default_rng(13 + len(suffix) + overwrite)
    for sig in ("SIGKILL", "SIGTERM"):
        state = kill_once(tmp_path, suffix, 20_000, float(rng.uniform(0.0, 0.4)),
                          SIGNALS[sig], overwrite)
        assert state in (("old", "new") if overwrite else ("absent", "new")), (sig, state)


def test_sigterm_ends_tma_with_143_keeping_finished_runs_and_no_temporary_file(tmp_path):
    import os
    import re
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "runs.csv"
    proc = subprocess.Popen([sys.executable, "-m", "tmakit.cli", "montecarlo", "gu2007",
                             "--runs", "100000", "--chunk", "20", "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=os.environ.copy())
    assert proc.stderr is not None
    # Wait until the progress bar shows two chunks of 20 runs done (however long the first
    # chunk takes: a cold numba cache compiles the Monte Carlo kernel first), then a little.
    seen, done = "", 0
    while done < 40:
        c = proc.stderr.read(1)
        assert c, "tma montecarlo ended before two chunks were done: " + seen[-2000:]
        seen += c
        counts = re.findall(r"(\d+)/100000", seen[-200:])
        done = int(counts[-1]) if counts else 0
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if ".tmp" in p.name]
    import pandas as pd

    table = pd.read_csv(tmp_path / "runs.partial.csv")  # the finished runs, whole chunks
    assert len(table) > 0 and len(table) % 20 == 0
    assert list(table["run"]) == list(range(len(table)))
