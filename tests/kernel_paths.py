"""Run a computation on a module's compiled kernels and on its NumPy path, for tests."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any


def both_paths(module: ModuleType, fn: Callable[[], Any]) -> tuple[Any, Any]:
    """Run ``fn`` with ``module``'s compiled kernels, then on its NumPy path; give both.

    ``module`` has ``available()`` and ``use_compiled(enabled)`` (the optional-kernel
    modules); its setting is restored afterwards.
    """
    assert module.available()
    fast = fn()
    before = module.use_compiled(False)
    try:
        assert not module.available()
        slow = fn()
    finally:
        module.use_compiled(before)
    return fast, slow
