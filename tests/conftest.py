"""The benchmarks' own simulations (``sample_logs``, ...) are importable from every test.

Tests marked ``long`` (a document's session, mypy, a study of tens of seconds) are collected
first, in their order: pytest-xdist deals its first quarter of the tests round-robin to the
workers, so the long ones start at once, side by side, instead of one of them ending the run
on a worker while the other waits.

pytest-xdist's workers, and the forks of the documents' ``tma`` server, compile numba's kernels
one at a time (tests/numba_lock.py).
"""

import os
import sys
from pathlib import Path

import pytest
from numba_lock import NUMBA_LOCK_VARIABLE, compile_one_at_a_time

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("long") is None)  # stable


@pytest.fixture(scope="session", autouse=True)
def _numba_compiles_one_process_at_a_time(tmp_path_factory):
    if "PYTEST_XDIST_WORKER" not in os.environ:  # one process: nothing to share
        yield
        return
    lock = tmp_path_factory.getbasetemp().parent / "numba-compile.lock"
    undo = compile_one_at_a_time(lock)
    os.environ[NUMBA_LOCK_VARIABLE] = str(lock)  # for the documents' tma server's forks
    yield
    del os.environ[NUMBA_LOCK_VARIABLE]
    undo()
