"""Keep freed memory for the next run: the allocator settings of a Monte Carlo process.

Raising glibc's mmap and trim thresholds to 32 MiB keeps a chunk's freed temporaries in the heap
instead of paying page faults for them again.  It is a process-wide setting, so the library makes
it only in processes of its own (``tma``, its worker processes, Dask workers it sends chunks to);
a Python user calls :func:`keep_freed_memory`.
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
