"""Keep freed memory for the next run: the allocator settings of a Monte Carlo process.

A chunk's batched solve allocates and frees many temporaries of 0.1–10 MB (runs x starts x
rows).  glibc's allocator serves each one above its mmap threshold (128 KiB at first) with
fresh pages from the kernel and gives heap memory above its trim threshold back at once, so
every iteration pays page faults for memory it just freed.  Dask's nanny makes it worse: it
starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which fixes both thresholds low (a
chunk of gu2007 runs took 2.5x the CPU time of the same chunk in a plain process).  Raising
both thresholds to 32 MiB keeps the freed blocks in the heap for the next iteration: a chunk of
50 gu2007 runs took 0.053 s of CPU instead of 0.073 s (medians of three processes run
interleaved on the shared 2-core machine), and 0.06 s instead of 0.19-0.23 s under Dask's
setting.  The price is up to 32 MiB of freed memory kept by the process.  Other platforms (and C
libraries without ``mallopt``) are left as they are.

It is a setting of the whole process, so the library makes it only in processes of its own:
the ``tma`` command, the worker processes of ``monte_carlo(workers=N)`` and the worker
processes of a Dask cluster it sends chunks to (never a worker inside the caller's process).
A Python user who wants it in their own process calls :func:`keep_freed_memory`.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["HEAP_KEEP", "keep_freed_memory"]

#: Bytes of freed memory kept by the allocator, and the size below which blocks come from the
#: heap (glibc's largest mmap threshold on 64-bit systems).
HEAP_KEEP = 32 * 1024 * 1024
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_done = False


def keep_freed_memory() -> bool:
    """Raise glibc's trim and mmap thresholds to :data:`HEAP_KEEP`, once per process.

    Opt-in: tmakit calls it only in processes of its own (module docstring).

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
