"""numba compiles one process at a time across the suite's processes (a lock file they share).

On a new machine numba's on-disk cache is empty: two processes reaching the same kernel together
would both compile it; one at a time, the second loads the first's from the cache. The pytest
workers take the lock (tests/conftest.py), and so do the forks of the documents' ``tma`` server
(tests/forked_tma.py), which finds the file in ``NUMBA_LOCK_VARIABLE``.
"""

from __future__ import annotations

import fcntl
import os
import threading
from collections.abc import Callable
from pathlib import Path

NUMBA_LOCK_VARIABLE = "TMAKIT_TESTS_NUMBA_LOCK"


def compile_one_at_a_time(lock_path: Path) -> Callable[[], None]:
    """Make numba's compiles take the lock at ``lock_path``; give the function that undoes it."""
    from numba.core.dispatcher import Dispatcher

    held: dict[int, object] = {}  # the file opened by each process (a fork opens its own:
    depth = threading.local()     # flock's owner is the open file, which a fork would share)
    compile_here = Dispatcher.compile

    def compile_locked(self, sig):
        # A kernel's compile compiles the kernels it calls: the lock is taken once.
        outer = not getattr(depth, "n", 0)
        if outer:
            lock = held.get(os.getpid())
            if lock is None:
                lock = held[os.getpid()] = open(lock_path, "a")
            fcntl.flock(lock, fcntl.LOCK_EX)
        depth.n = getattr(depth, "n", 0) + 1
        try:
            return compile_here(self, sig)  # loads from the on-disk cache if there
        finally:
            depth.n -= 1
            if outer:
                fcntl.flock(held[os.getpid()], fcntl.LOCK_UN)

    def undo() -> None:
        Dispatcher.compile = compile_here
        for lock in held.values():
            lock.close()

    Dispatcher.compile = compile_locked
    return undo
