"""The benchmarks' own simulations (``sample_logs``, ...) are importable from every test.

Tests marked ``long`` (a document's session, mypy, a study of tens of seconds) are collected
first, in their order: pytest-xdist deals its first quarter of the tests round-robin to the
workers, so the long ones start at once, side by side, instead of one of them ending the run
on a worker while the other waits.
"""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("long") is None)  # stable
