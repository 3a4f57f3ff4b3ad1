"""The benchmarks' own simulations (``sample_logs``, ...) are importable from every test.

Tests marked ``long`` (a document's session, mypy, a study of tens of seconds) are collected
first, in their order: pytest-xdist deals its first quarter of the tests round-robin to the
workers, so the long ones start at once, side by side, instead of one of them ending the run
on a worker while the other waits.

pytest-xdist's workers compile numba's kernels one at a time (a lock file they share): on a new
machine numba's on-disk cache is empty, and two workers reaching the same kernel together would
both compile it; one at a time, the second loads the first's from the cache.
"""

import fcntl
import os
import sys
import threading
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("long") is None)  # stable


@pytest.fixture(scope="session", autouse=True)
def _numba_compiles_one_worker_at_a_time(tmp_path_factory):
    if "PYTEST_XDIST_WORKER" not in os.environ:  # one process: nothing to share
        yield
        return
    from numba.core.dispatcher import Dispatcher

    lock = open(tmp_path_factory.getbasetemp().parent / "numba-compile.lock", "a")
    depth = threading.local()
    compile_here = Dispatcher.compile

    def compile_one_at_a_time(self, sig):
        # A kernel's compile compiles the kernels it calls: the lock is taken once.
        outer = not getattr(depth, "n", 0)
        if outer:
            fcntl.flock(lock, fcntl.LOCK_EX)
        depth.n = getattr(depth, "n", 0) + 1
        try:
            return compile_here(self, sig)  # loads from the on-disk cache if there
        finally:
            depth.n -= 1
            if outer:
                fcntl.flock(lock, fcntl.LOCK_UN)

    Dispatcher.compile = compile_one_at_a_time
    yield
    Dispatcher.compile = compile_here
    lock.close()
