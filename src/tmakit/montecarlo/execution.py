"""Where the chunks of a Monte Carlo study run: here, in worker processes, or on a Dask cluster.

Every chunk computes the same runs wherever it runs.  :func:`keep_freed_memory` (glibc's mmap and
trim thresholds, a process-wide setting) is made only in tmakit's own processes.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import math
import multiprocessing
import os
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .runs import run_chunk

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = [
    "COMPILED_CHUNK",
    "HEAP_KEEP",
    "LOCAL_CHUNK",
    "LOOP_CHUNK",
    "cluster",
    "default_chunk",
    "execute",
    "keep_freed_memory",
    "progress_bar",
    "run_dask",
    "run_local",
    "run_pool",
    "whole_number",
]

#: Runs per chunk when running in this process.
LOCAL_CHUNK = 50
#: Runs per chunk of a study whose fits evaluate by the compiled kernel (see
#: :func:`default_chunk`).
COMPILED_CHUNK = 250
#: Runs per chunk for estimators solved run by run (the progress bar moves per chunk).
LOOP_CHUNK = 10


#: Bytes of freed memory kept by the allocator, and the size below which blocks come from the
#: heap (glibc's largest mmap threshold on 64-bit systems).
HEAP_KEEP = 32 * 1024 * 1024
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_done = False


def keep_freed_memory() -> bool:
    """Raise glibc's trim and mmap thresholds to :data:`HEAP_KEEP`, once per process.

    Opt-in: tmakit calls it only in processes of its own.

    Returns
    -------
    bool
        Whether the allocator took the settings (False off Linux or without glibc).
    """
    global _done
    if _done:
        return True
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    _done = bool(mallopt(_M_MMAP_THRESHOLD, HEAP_KEEP)) & bool(
        mallopt(_M_TRIM_THRESHOLD, HEAP_KEEP))
    return _done


def whole_number(value: object, name: str, minimum: int = 1) -> int:
    """Return ``value`` as an int if it is a whole number >= ``minimum``; else ValueError."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ValueError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    return int(value)


class _NoBar:
    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def progress_bar(total: int, enabled: bool, desc: str) -> Any:
    """Open a tqdm progress bar over ``total`` runs, or a silent stand-in."""
    if not enabled:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:
        warnings.warn("progress bar needs tqdm (pip install tqdm); running without one",
                      stacklevel=3)
        return _NoBar()
    return tqdm(total=total, desc=desc, unit="run", smoothing=0.1)


def run_local(tasks: Sequence[Any], bar: Any, fn: Callable[[Any], Any] = run_chunk,
              on_done: Callable[[Any], None] | None = None) -> list[Any]:
    """Run the chunks one after the other in this process."""
    outputs: list[Any] = []
    for task in tasks:
        _finished(fn(task), outputs, bar, on_done)
    return outputs


def _finished(res: Any, outputs: list[Any], bar: Any, on_done: Callable[[Any], None] | None
              ) -> None:
    outputs.append(res)
    if on_done is not None:
        on_done(res)
    bar.update(len(res))


def _single_threaded_worker() -> None:
    """Set up a pool worker, a process of tmakit's own: BLAS on one thread, freed memory kept."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
    keep_freed_memory()


def _pool_context() -> Any:
    """Give the start method of the pool's workers."""
    methods = multiprocessing.get_all_start_methods()
    if sys.platform.startswith("linux") and "fork" in methods:
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context()


def run_pool(tasks: Sequence[Any], workers: int, bar: Any, fn: Callable[[Any], Any] = run_chunk,
             on_done: Callable[[Any], None] | None = None) -> list[Any]:
    """Run the chunks in ``workers`` processes of this machine."""
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    outputs: list[Any] = []
    with ProcessPoolExecutor(max_workers=min(workers, max(1, len(tasks))),
                             mp_context=_pool_context(),
                             initializer=_single_threaded_worker) as pool:
        pending = {pool.submit(fn, task) for task in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    _finished(fut.result(), outputs, bar, on_done)
        except BaseException:
            for fut in pending:
                fut.cancel()  # an error or an interrupt: start nothing more
            raise
    return outputs


@contextlib.contextmanager
def cluster(dask: str | Client | None) -> Iterator[Client | None]:
    """Give the Dask client of ``dask`` (None: none), closing it after if it was opened here."""
    if dask is None:
        yield None
        return
    try:
        from distributed import Client
    except ImportError:
        raise ImportError("dask= needs Dask's distributed scheduler: "
                          "pip install 'dask[distributed]'") from None
    if isinstance(dask, Client):
        yield dask
        return
    if not isinstance(dask, str):
        raise ValueError(f"dask must be a scheduler address (such as 'tcp://host:8786') or a "
                         f"distributed.Client, not {type(dask).__name__}")
    client = Client(dask)
    try:
        yield client
    finally:
        client.close()


def _keep_freed_memory_on(client: Client) -> None:
    """Have the cluster's workers keep freed memory (:func:`keep_freed_memory`), not this one."""
    pids = client.run(os.getpid)
    if os.getpid() not in set(pids.values()):
        client.run(keep_freed_memory)


def run_dask(tasks: Sequence[Any], client: Client, bar: Any,
             fn: Callable[[Any], Any] = run_chunk,
             on_done: Callable[[Any], None] | None = None) -> list[Any]:
    """Run the chunks on a Dask cluster (workers must be able to import tmakit)."""
    from distributed import as_completed

    _keep_freed_memory_on(client)
    futures = client.map(fn, list(tasks), pure=False)
    outputs: list[Any] = []
    try:
        for fut in as_completed(futures):
            _finished(fut.result(), outputs, bar, on_done)
            fut.release()
    except BaseException:
        client.cancel(futures)  # an error or an interrupt: leave nothing running
        raise
    return outputs


def _cpus() -> int:
    """Return the CPUs this process may run on."""
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else (os.cpu_count() or 1)


def execute(tasks: Sequence[Any], client: Client | None, bar_label: str, runs: int,
            progress: bool, on_chunk: Callable[[Any], None] | None = None, workers: int = 1,
            fn: Callable[[Any], Any] = run_chunk) -> tuple[list[Any], float, str]:
    """Run the chunks here, in worker processes or on Dask; return them, the wall time, where."""
    processes = min(workers, len(tasks), _cpus())
    bar = progress_bar(runs, progress, bar_label)
    start = time.perf_counter()
    try:
        if client is not None:
            outputs = run_dask(tasks, client, bar, fn, on_chunk)
        elif processes > 1:
            outputs = run_pool(tasks, processes, bar, fn, on_chunk)
        else:
            outputs = run_local(tasks, bar, fn, on_chunk)
    finally:
        bar.close()
    wall = time.perf_counter() - start
    outputs.sort(key=lambda o: o.first_run)
    executor = (f"dask {getattr(client.scheduler, 'address', '')}" if client is not None
                else f"{processes} processes" if processes > 1 else "local")
    if client is None and processes < workers:
        executor += f", {workers:,} asked: {len(tasks):,} chunks, {_cpus()} CPUs"
    return outputs, wall, executor


def default_chunk(runs: int, estimator: str, client: Client | None,
                  compiled: bool = False) -> int:
    """Return the runs per chunk when none is asked for."""
    most = COMPILED_CHUNK if compiled and estimator == "ml" else LOCAL_CHUNK
    if client is None:
        return most if estimator == "ml" else LOOP_CHUNK
    threads = sum(client.nthreads().values()) or 1
    # About four chunks per worker thread balance the load; large enough chunks keep the
    # batched solves efficient.
    return int(min(most, max(1, math.ceil(runs / (4 * threads)))))
