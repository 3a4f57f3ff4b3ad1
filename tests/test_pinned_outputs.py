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
# A flat list of more numbers than this is a per-step series of one quantity (a track's NIS,
# log-likelihood): its entries share one scale.  State vectors pinned here have at most 12.
SERIES = 12


def peak(value: object) -> float:
    """The largest finite absolute number anywhere in ``value`` (0 if there is none)."""
    if isinstance(value, list):
        return max((peak(v) for v in value), default=0.0)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return 0.0
    return abs(value)


def magnitude(values: object) -> list[float] | None:
    """Per-column magnitudes of a table: the peak of each position over all rows.

    ``[[1, -30], [2, 4]]`` gives ``[2, 30]``; for a list of matrices, position ``i`` is row
    ``i`` of every matrix.  Anything that is not a list of equal-length lists gives ``None``.
    """
    if (isinstance(values, list) and values and all(isinstance(v, list) for v in values)
            and len({len(v) for v in values}) == 1):
        return [max(peak(row[i]) for row in values) for i in range(len(values[0]))]
    return None


def differences(got: object, want: object, where: str = "", scale: float = 0.0) -> list[str]:
    """Every place where ``got`` and ``want`` differ beyond ``REL`` relative (numbers) or at all.

    A number is compared relative to the larger of itself and ``scale``, the largest magnitude
    of the same quantity over the rows of its table (the same column of a track's estimates,
    the same entry of its covariances, the whole of a per-step series).  A value crossing zero
    mid-track (a velocity component of 0.007 m/s in a track whose speeds are several m/s) then
    keeps the precision of its quantity rather than of its own tiny size: floating-point
    summation order differs between BLAS builds by a few ulps of the quantity's scale.
    """
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
        columns = magnitude(want)
        if columns is None and len(want) > SERIES:
            scale = max(scale, peak(want))
        return [d for i, (g, w) in enumerate(zip(got, want, strict=True))
                for d in differences_in_row(g, w, f"{where}[{i}]", columns, scale)]
    if isinstance(want, bool) or not isinstance(want, int | float):
        return [] if got == want else [f"{where}: {got!r} != {want!r}"]
    if not isinstance(got, int | float) or isinstance(got, bool):
        return [f"{where}: {got!r} != {want!r}"]
    if math.isnan(want):
        return [] if math.isnan(got) else [f"{where}: {got!r} != nan"]
    if got == want or abs(got - want) <= REL * max(abs(got), abs(want), scale):
        return []
    if where.endswith("p_value") and got > 0.0 and want > 0.0:
        # A far tail probability amplifies its statistic's rounding (ln p is about -chi2 / 2):
        # compared as its logarithm, relative to that, i.e. as the statistic itself.
        low, high = math.log(got), math.log(want)
        if abs(low - high) <= REL * max(abs(low), abs(high), 1.0):
            return []
    return [f"{where}: {got!r} != {want!r}"]


def differences_in_row(got: object, want: object, where: str, columns: list[float] | None,
                       scale: float) -> list[str]:
    """Compare one row of a table, each position with its column's magnitude as the scale."""
    if columns is None or not isinstance(want, list) or not isinstance(got, list):
        return differences(got, want, where, scale)
    if len(got) != len(want):
        return [f"{where}: length {len(got)} != {len(want)}"]
    return [d for j, (g, w) in enumerate(zip(got, want, strict=True))
            for d in differences(g, w, f"{where}[{j}]",
                                 max(scale, columns[j]))]


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


def test_a_near_zero_entry_is_compared_at_its_column_scale():
    # vx of 0.007 m/s in a track whose vx reaches 5 m/s: a 2e-11 drift is floating-point noise,
    # but 1e-7 is a change.
    want = {"estimate": [[1000.0, 5.0], [1001.0, 0.007]]}
    assert not differences({"estimate": [[1000.0, 5.0], [1001.0, 0.007 + 2e-11]]}, want)
    assert differences({"estimate": [[1000.0, 5.0], [1001.0, 0.007 + 1e-7]]}, want)
    # A column of its own: positions do not widen the velocity's tolerance.
    assert differences({"estimate": [[1000.0, 5.0], [1001.0 * (1 + 1e-8), 0.007]]}, want)
    # A per-step series shares one scale; a short state vector does not.
    series = [1.0] * 20 + [7.9e-9]
    assert not differences([*series[:-1], 7.9e-9 + 1e-16], series)
    assert differences([*series[:-1], 7.9e-9 + 1e-8], series)
    assert differences([1000.0, 0.007 + 1e-10], [1000.0, 0.007])


def test_a_far_tail_probability_is_compared_through_its_statistic():
    # p = 7.7e-8 (chi2 about 33): 1.5e-9 relative in p is 1e-10 in the statistic, rounding
    # (one CPU's against another's); 1e-6 relative in p is a change.
    want = {"p_value": 7.71948994018242e-08}
    assert not differences({"p_value": 7.719489928892834e-08}, want)
    assert differences({"p_value": 7.71948994018242e-08 * (1 + 1e-6)}, want)
    assert differences({"q": 7.719489928892834e-08}, {"q": 7.71948994018242e-08})
