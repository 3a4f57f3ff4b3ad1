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
