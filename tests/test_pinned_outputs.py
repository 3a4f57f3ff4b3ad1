"""Deterministic outputs pinned before the architecture rebuild: they must not change.

The issue that rebuilt the house (issue 10) promised "no change in any result": every
reproduction, bound, seeded estimate and seeded track below equals the output recorded in
``tests/pinned/expected.json`` to 1e-9 relative.  Regenerate only on purpose, with
``python tests/pinned/make_pinned.py``, and say why in the commit.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

PINNED_DIR = Path(__file__).parent / "pinned"
sys.path.insert(0, str(PINNED_DIR))
from commands import PINNED  # noqa: E402
from runner import run_pinned  # noqa: E402

EXPECTED = json.loads((PINNED_DIR / "expected.json").read_text())
REL = 1e-9


def differences(got: object, want: object, where: str = "") -> list[str]:
    """Every place where ``got`` and ``want`` differ beyond ``REL`` relative (numbers) or at all."""
    if isinstance(want, dict):
        if not isinstance(got, dict):
            return [f"{where}: {type(got).__name__} instead of an object"]
        # New keys may be added; none may go.
        missing = [f"{where}.{k}: missing" for k in want if k not in got]
        return missing + [d for k in want if k in got
                          for d in differences(got[k], want[k], f"{where}.{k}")]
    if isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            return [f"{where}: length {len(got) if isinstance(got, list) else '-'} != {len(want)}"]
        return [d for i, (g, w) in enumerate(zip(got, want, strict=True))
                for d in differences(g, w, f"{where}[{i}]")]
    if isinstance(want, bool) or not isinstance(want, int | float):
        return [] if got == want else [f"{where}: {got!r} != {want!r}"]
    if not isinstance(got, int | float) or isinstance(got, bool):
        return [f"{where}: {got!r} != {want!r}"]
    if math.isnan(want):
        return [] if math.isnan(got) else [f"{where}: {got!r} != nan"]
    if got == want or abs(got - want) <= REL * max(abs(got), abs(want)):
        return []
    return [f"{where}: {got!r} != {want!r}"]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("pinned")


@pytest.mark.parametrize(("name", "setup", "command"), PINNED, ids=[p[0] for p in PINNED])
def test_output_unchanged(workdir, name, setup, command):
    got = run_pinned(workdir, setup, command)
    found = differences(got, EXPECTED[name], name)
    assert not found, "\n".join(found[:20])


def test_the_comparison_catches_a_change():
    want = {"a": [1.0, 2.0], "b": "x"}
    assert not differences({"a": [1.0, 2.0 * (1 + 1e-12)], "b": "x", "new": 1}, want)
    assert differences({"a": [1.0, 2.0 * (1 + 1e-8)], "b": "x"}, want)
    assert differences({"a": [1.0], "b": "x"}, want)
    assert differences({"a": [1.0, 2.0]}, want)
