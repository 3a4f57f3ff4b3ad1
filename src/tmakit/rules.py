"""The one set of rules a measurement set obeys, wherever it comes from.

Reader, constructor, simulator and writers refuse with the same words: each cell rule is a
``(column, expected, test)`` triple; the metadata keys the library reads are checked by
:func:`metadata_problems`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from functools import lru_cache, partial
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .core.arrays import finite_range
from .core.units import REACH_M, SPEED_OF_LIGHT, TIME_LIMIT_S
from .measurements import KINDS
from .measurements.base import ValueRange

__all__ = ["FINITE", "GEO_RANGES", "LATITUDE", "LONGITUDE", "OUTLIER_SPANS", "POSITION",
           "SIGMA_FLOOR", "SIGMA_POSITIVE", "SIGMA_RESOLVED", "TIME", "VELOCITY", "CellRule",
           "broken_rows", "cell_rules", "check_set", "column_problems", "decreasing_times",
           "duplicate_rows", "far_times", "geo_within", "metadata_problems", "raise_problems",
           "sigma_ceiling", "sigma_ceiling_text", "sigma_resolved", "state_within_reach",
           "time_problem"]

#: What a time must be (s).
TIME = (f"a time within [-{TIME_LIMIT_S:g}, {TIME_LIMIT_S:g}] s of the time origin (317 years; "
        "epoch milliseconds or nanoseconds must be given as seconds)")
#: A time farther than this many spans of the other times (at least :data:`_MIN_SPAN_S`)
#: from them is refused (:func:`far_times`): a typo, another unit or another clock.
OUTLIER_SPANS = 100.0
_MIN_SPAN_S = 100.0


def far_times(time: NDArray[np.float64]) -> tuple[NDArray[np.bool_], str]:
    """Find the times that lie far outside the span of the others (a typo, another unit)."""
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(time)
        t = time if finite.all() else time[finite]
        n = t.size
        if n < 4 or float(t.max()) - float(t.min()) <= OUTLIER_SPANS * _MIN_SPAN_S:
            return np.zeros(time.shape, dtype=bool), ""
        i25, i75 = (n - 1) // 4, n - 1 - (n - 1) // 4
        if bool((t[1:] >= t[:-1]).all()):  # in order already (one sensor): no copy
            low, high = float(t[i25]), float(t[i75])
        else:
            part = np.partition(t, (i25, i75))
            low, high = float(part[i25]), float(part[i75])
        reach = OUTLIER_SPANS * max(high - low, _MIN_SPAN_S)
        far = finite & ((time < low - reach) | (time > high + reach))
    if not far.any():
        return far, ""
    return far, (f"a time within {OUTLIER_SPANS:g} spans of the bulk of the times (their "
                 f"central half lies within {low:.10g} .. {high:.10g} s; a typo, another "
                 "unit or another clock)")


def time_problem(time: float, times: NDArray[np.float64] | None, what: str) -> str | None:
    """Say why a time asked for (an answer's, a reference time) cannot be used, or None."""
    if not math.isfinite(time):
        return f"{what} {time}: expected a finite time (s)"
    span = None if times is None else finite_range(np.asarray(times, dtype=float))
    if span is None:
        return None
    low, high = span
    reach = OUTLIER_SPANS * max(high - low, 1.0)
    if low - reach <= time <= high + reach:
        return None
    far = time - high if time > high else low - time
    return (f"{what} {time:.15g}: {far:.6g} s from the measurements (t = {low:.15g} ... "
            f"{high:.15g} s), more than {reach:.6g} s ({OUTLIER_SPANS:g} spans of the data); "
            f"the positions at a time that far depend on the velocities {far:.3g} times over")


#: What a numeric cell must be.
FINITE = "a finite number"
#: What a noise standard deviation must be.
SIGMA_POSITIVE = "a noise standard deviation > 0 (in the unit of value)"
#: What a sensor position must be (m).
POSITION = f"a position within [-{REACH_M:g}, {REACH_M:g}] m of the origin"
#: What a sensor velocity must be (m/s).
VELOCITY = f"a velocity within [-{SPEED_OF_LIGHT:.0f}, {SPEED_OF_LIGHT:.0f}] m/s (light's speed)"
#: The smallest sigma, relative to its value's size (``max(|value|, 1)`` in the file unit): a
#: standard deviation below it is finer than the numbers can carry (1e-300 makes weights of
#: 1e600) and is a unit mistake or garbage.
SIGMA_FLOOR = 1e-12
#: What a sigma must be beside its value.
SIGMA_RESOLVED = (f"a noise standard deviation of at least {SIGMA_FLOOR:g} times the value's "
                  "size (max(|value|, 1) in the unit of value)")
#: What a latitude must be (deg).
LATITUDE = "a latitude within [-90, 90] deg"
#: What a longitude must be (deg).
LONGITUDE = "a longitude within [-180, 360] deg"
#: The ranges of latitude and longitude (deg), by column.
GEO_RANGES = {"sensor_lat": (-90.0, 90.0), "sensor_lon": (-180.0, 360.0)}

_SHOWN = 10  # problems listed in a constructor's message


def _where(rows: NDArray[np.intp], column: str, expected: str, found: NDArray[Any]) -> list[str]:
    return [f"row {int(r) + 1}, column '{column}': expected {expected}, found {float(found[k])!r}"
            for k, r in enumerate(rows[:_SHOWN])]


_REACH = np.array([REACH_M] * 3 + [SPEED_OF_LIGHT] * 3)  # each state column's reach
_LARGEST = float(np.finfo(float).max)  # a cell no larger is finite


class CellRule(NamedTuple):
    """A cell's rule: column (None: the row), what it must be, what it reads, the test, ...

    ``kind``: the code of the kind whose rows alone the rule applies to (None: every row);
    ``clear``: no cell of a magnitude at most this breaks the rule (None: no such bound).
    """

    column: str | None
    expected: str
    reads: tuple[str, ...]
    broken: Callable[..., NDArray[np.bool_]]
    kind: int | None = None
    clear: float | None = None


def _non_finite(v: NDArray[np.float64]) -> NDArray[np.bool_]:
    return ~np.isfinite(v)


def _beyond(limit: float) -> Callable[[NDArray[np.float64]], NDArray[np.bool_]]:
    """Test a finite cell beyond ``±limit`` (a non-finite one breaks FINITE)."""
    def test(v: NDArray[np.float64]) -> NDArray[np.bool_]:
        size = np.abs(v)
        out = size > limit
        if out.any():
            out &= size != np.inf
        return out
    return test


def _off_the_earth(v: NDArray[np.float64], column: str) -> NDArray[np.bool_]:
    return np.isfinite(v) & ~geo_within(v, column)


@lru_cache(maxsize=1)
def _value_rules() -> tuple[CellRule, ...]:
    """Each kind's rule of its values' range."""
    return tuple(CellRule("value", str(cls.describe_values()), ("value",),
                          lambda v, cls=cls: np.isfinite(v) & ~cls.check_values(v), code,
                          _within_both(cls.value_range))
                 for code, cls in enumerate(KINDS.values()) if cls.value_range is not None)


def _within_both(values: ValueRange) -> float | None:
    """Give the largest ``c`` whose ``[-c, c]`` lies in ``values`` (None: no such ``c`` > 0)."""
    low = -math.inf if values.low is None else values.low
    high = math.inf if values.high is None else values.high
    c = min(-low, high)
    inside = (-c > low or values.low_inclusive) and (c < high or values.high_inclusive)
    return c if inside and 0 < c < math.inf else None


def sigma_ceiling(kind: str) -> float | None:
    """Give the largest sigma a kind's rows may state (file unit), or None (no limit).

    An angle on the circle (a wrapped kind): half a turn (180 deg), past which the noise
    covers the whole circle; another kind with a range of values bounded on both sides: that
    range's width.
    """
    cls = KINDS[kind]
    if cls.wrap_period is not None:
        return cls.wrap_period / cls.file_scale / 2.0
    values = cls.value_range
    if values is not None and values.low is not None and values.high is not None:
        return values.high - values.low
    return None


def sigma_ceiling_text(kind: str) -> str:
    """Say what a kind's sigma must be: at most :func:`sigma_ceiling`, and why."""
    cls, limit = KINDS[kind], sigma_ceiling(kind)
    unit = "dB" if cls.file_unit.startswith("dB") else cls.file_unit
    why = ("half a turn: the noise then covers the circle" if cls.wrap_period is not None
           else "the width of its range of values: the noise then covers every value")
    noun = f"a {kind}" if cls.value_range is None else cls.value_range.noun
    return f"a noise standard deviation of at most {limit:g} {unit} for {noun} ({why})"


def _sigma_ceiling_rules() -> list[CellRule]:
    """Each bounded kind's rule: a sigma no larger than :func:`sigma_ceiling`."""
    return [CellRule("sigma", sigma_ceiling_text(kind), ("sigma",),
                     lambda s, limit=limit: s > limit, code, limit)
            for code, kind in enumerate(KINDS) if (limit := sigma_ceiling(kind)) is not None]


def _sigma_unresolved(kind: NDArray[np.integer], value: NDArray[np.float64],
                      sigma: NDArray[np.float64]) -> NDArray[np.bool_]:
    broken = (sigma > 0) & ~sigma_resolved(value, sigma)
    if broken.any():  # no value, or one out of its range: its sigma is moot
        rows = np.flatnonzero(broken)
        kind, value = kind[rows], value[rows]
        moot = ~np.isfinite(value)
        for rule in _value_rules():
            mine = kind == rule.kind
            moot[mine] |= rule.broken(value[mine])
        broken[rows] = ~moot
    return broken


@lru_cache(maxsize=1)
def cell_rules() -> tuple[CellRule, ...]:
    """Give the rules of a measurement set's or file's cells, in the order they are told.

    The file checker (``tmakit.io.checker``: with the line, the cell as written) and
    :func:`column_problems` (a set's rows) report them; a rule applies where the columns it
    reads are given (``kind_code``: -1 for no kind), and a cell breaks one rule at most.
    """
    ranged = [("time", TIME, TIME_LIMIT_S)]
    ranged += [(c, POSITION if j < 3 else VELOCITY, float(_REACH[j]))
               for j, c in [*enumerate(STATE_COLUMNS), (2, "sensor_alt")]]
    finite = [CellRule(c, FINITE, (c,), _non_finite, clear=_LARGEST)
              for c in ("time", "value", "sigma", *(c for c, _, _ in ranged[1:]), *GEO_RANGES)]
    rules = finite[:3]
    for c, what, limit in ranged:
        rules += [r for r in finite[3:] if r.column == c]
        rules.append(CellRule(c, what, (c,), _beyond(limit), clear=limit))
    for c, what in (("sensor_lat", LATITUDE), ("sensor_lon", LONGITUDE)):
        low, high = GEO_RANGES[c]
        rules += [r for r in finite[3:] if r.column == c]
        rules.append(CellRule(c, what, (c,), partial(_off_the_earth, column=c),
                              clear=min(-low, high)))
    rules.append(CellRule("sigma", SIGMA_POSITIVE, ("sigma",), lambda s: np.isfinite(s) & ~(s > 0)))
    rules += _sigma_ceiling_rules()
    for code, cls in enumerate(KINDS.values()):
        if cls.sensor_at_origin:
            rules.append(CellRule(None, "the ENU origin (0, 0, 0) as the sensor position of an "
                                  f"{cls.kind} row", STATE_COLUMNS[:3],
                                  lambda x, y, z: (np.abs(x) > 1e-3) | (np.abs(y) > 1e-3)
                                  | (np.abs(z) > 1e-3), code))
        rules += [r for r in _value_rules() if r.kind == code]
    return (*rules, CellRule("sigma", SIGMA_RESOLVED, ("kind_code", "value", "sigma"),
                             _sigma_unresolved))


def broken_rows(columns: Mapping[str, NDArray[Any]], block: int = 1 << 15
                ) -> list[tuple[CellRule, NDArray[np.intp]]]:
    """Give each rule of :func:`cell_rules` that some row of ``columns`` breaks, and those rows.

    A rule applies where the columns it reads are given; a kind's rule where ``kind_code`` is
    given too, to that kind's rows.  Every rule is tested on one block of rows before the next
    block (the block stays in the cache; no mask of every row is held), unless the largest
    magnitude of its column in the block is within the rule's ``clear``.
    """
    applied = _rules_reading(frozenset(columns))
    found: dict[int, list[NDArray[np.intp]]] = {}
    n = next(iter(columns.values())).shape[0]
    with np.errstate(invalid="ignore"):
        for lo in range(0, n, block):
            cells = {c: v[lo:lo + block] for c, v in columns.items()}
            every = _Rows(cells, None)
            views: dict[int | None, _Rows] = {None: every}
            views.update((code, every if mine is None else _Rows(cells, mine))
                         for code, mine in _rows_by_kind(cells.get("kind_code")).items())
            for kind, of in views.items():
                for i, rule in applied.get(kind, ()):
                    if rule.clear is not None and of.size(rule.reads[0]) <= rule.clear:
                        continue
                    broken = rule.broken(*[of[c] for c in rule.reads])
                    if broken.any():
                        at = broken.nonzero()[0]
                        found.setdefault(i, []).append((at if of.rows is None else of.rows[at])
                                                       + lo)
    rules = cell_rules()
    return [(rules[i], np.concatenate(rows)) for i, rows in sorted(found.items())]


class _Rows(dict[str, NDArray[Any]]):
    """The columns of some rows of a block (None: all), each indexed on first use."""

    def __init__(self, cells: Mapping[str, NDArray[Any]], rows: NDArray[np.intp] | None
                 ) -> None:
        super().__init__(cells if rows is None else {})
        self.cells, self.rows, self.sizes = cells, rows, dict[str, float]()

    def __missing__(self, column: str) -> NDArray[Any]:
        self[column] = self.cells[column] if self.rows is None else self.cells[column][self.rows]
        return self[column]

    def size(self, column: str) -> float:
        """Give the largest magnitude in ``column`` (NaN if one is NaN)."""
        if column not in self.sizes:
            self.sizes[column] = float(np.abs(self[column]).max())
        return self.sizes[column]


@lru_cache(maxsize=64)
def _rules_reading(names: frozenset[str]) -> dict[int | None, tuple[tuple[int, CellRule], ...]]:
    """Give the rules that apply to the columns ``names`` by kind, each with its place."""
    by_kind: dict[int | None, list[tuple[int, CellRule]]] = {}
    for i, r in enumerate(cell_rules()):
        if all(c in names for c in r.reads) and (r.kind is None or "kind_code" in names):
            by_kind.setdefault(r.kind, []).append((i, r))
    return {kind: tuple(rules) for kind, rules in by_kind.items()}


def _rows_by_kind(kind: NDArray[np.integer] | None) -> dict[int, NDArray[np.intp] | None]:
    """Give the rows of each kind code present (None: every row is of that kind)."""
    if kind is None or kind.shape[0] == 0:
        return {}
    low, high = int(kind.min()), int(kind.max())
    if low == high:
        return {low: None}
    counts = np.bincount(kind - low)
    return {code + low: (kind == code + low).nonzero()[0] for code in counts.nonzero()[0].tolist()}


def column_problems(time: NDArray[np.float64], sensor_code: NDArray[np.integer],
                    kind: NDArray[np.integer], value: NDArray[np.float64],
                    sigma: NDArray[np.float64], sensor_state: NDArray[np.float64],
                    time_ref: NDArray[np.float64], order: bool = True,
                    stream_code: NDArray[np.integer] | None = None) -> list[str]:
    """Check the columns of a measurement set against the rules of the file format."""
    columns = {"time": time, "value": value, "sigma": sigma, "kind_code": kind,
               **{name: sensor_state[:, j] for j, name in enumerate(STATE_COLUMNS)}}
    found: list[str] = []
    for rule, bad in broken_rows(columns):
        if rule.column is None:
            found += [f"row {int(r) + 1}: expected {rule.expected}" for r in bad[:_SHOWN]]
        else:
            found += _where(bad, rule.column, rule.expected, columns[rule.column][bad])
    bad = np.flatnonzero(np.isinf(time_ref))
    found += _where(bad, "time_ref", FINITE, time_ref[bad])
    if order:
        found += [f"row {row + 1}, column 'time': expected a time >= {float(time[prev])!r} s, "
                  f"the time of the previous row of its sensor (row {prev + 1}), found "
                  f"{float(time[row])!r}"
                  for prev, row in decreasing_times(time, sensor_code)[:_SHOWN]]
        far, expected = far_times(time)
        found += _where(np.flatnonzero(far), "time", expected, time[far])
        pairs = duplicate_rows(time, sensor_code if stream_code is None else stream_code, kind,
                               time_ref)
        found += [f"row {row + 1}, column 'time': expected one row per (sensor, kind, time, "
                  f"time_ref), found {float(time[row])!r}, a duplicate of row {first + 1}"
                  for row, first in pairs[:_SHOWN]]
    return found


#: The sensor state's columns, in order.
STATE_COLUMNS = ("sensor_x", "sensor_y", "sensor_z", "sensor_vx", "sensor_vy", "sensor_vz")


def state_within_reach(values: NDArray[np.float64], column: int | None = None
                       ) -> NDArray[np.bool_]:
    """Tell where a state column lies within reach: positions, velocities.

    ``column`` None: ``values`` holds a state's first columns, ``(n, d)``.
    """
    limits = _REACH[:values.shape[-1]] if column is None else _REACH[column]
    return np.abs(values) <= limits


def geo_within(values: NDArray[np.float64], column: str) -> NDArray[np.bool_]:
    """Tell where latitudes (``sensor_lat``) or longitudes (``sensor_lon``) are in range."""
    low, high = GEO_RANGES[column]
    return (values >= low) & (values <= high)


def sigma_resolved(value: NDArray[np.float64], sigma: NDArray[np.float64]
                   ) -> NDArray[np.bool_]:
    """Tell where a sigma is at least :data:`SIGMA_FLOOR` of its value's size."""
    return sigma >= SIGMA_FLOOR * np.maximum(np.abs(value), 1.0)


def duplicate_rows(time: NDArray[np.float64], sensor_code: NDArray[np.integer],
                   kind_code: NDArray[np.integer], time_ref: NDArray[np.float64]
                   ) -> list[tuple[int, int]]:
    """Find the rows that repeat an earlier row's (sensor, kind, time, time_ref)."""
    n = sensor_code.shape[0]
    if n < 2:
        return []
    one = int(sensor_code.min()) == int(sensor_code.max())
    order = None if one else np.argsort(sensor_code, kind="stable")
    t = time if order is None else time[order]
    s = sensor_code if order is None else sensor_code[order]
    shared = (t[1:] == t[:-1]) & (s[1:] == s[:-1])  # a row at the sensor and time of the last
    in_order = bool(((t[1:] >= t[:-1]) | (s[1:] != s[:-1])).all())
    if in_order and shared.any():  # two rows alone at a sensor and time, of two kinds: no twins
        k = kind_code if order is None else kind_code[order]
        alone = shared.copy()
        alone[1:] &= ~shared[:-1]
        alone[:-1] &= ~shared[1:]
        shared &= ~(alone & (k[1:] != k[:-1]))
    same = shared.nonzero()[0]
    if same.shape[0] == 0 and in_order:
        return []
    if not in_order:  # a sensor's rows out of time order (refused anyway): sort them all
        rows = np.arange(n)
    else:  # the rows beside one of their sensor at their time
        near = np.zeros(n, dtype=bool)
        near[same], near[same + 1] = True, True
        rows = np.flatnonzero(near) if order is None else order[near]
    ref = time_ref[rows]
    keys = (sensor_code[rows], time[rows], kind_code[rows], np.where(np.isnan(ref), -np.inf, ref))
    by = np.lexsort((rows, *keys[::-1]))
    r, twin = rows[by], np.ones(rows.shape[0] - 1, dtype=bool)
    for key in keys:
        key = key[by]
        twin &= key[1:] == key[:-1]
    at = twin.nonzero()[0] + 1  # the places in r that repeat the one before
    if at.shape[0] == 0:
        return []
    place = np.arange(r.shape[0])
    first = np.maximum.accumulate(np.where(np.concatenate(([True], ~twin)), place, 0))
    return sorted(zip(r[at].tolist(), r[first[at]].tolist(), strict=True))


def decreasing_times(time: NDArray[np.float64], sensor_code: NDArray[np.integer]
                     ) -> list[tuple[int, int]]:
    """Find the rows whose time is below the previous row's of their sensor: (previous, row)."""
    if time.shape[0] < 2:
        return []
    if int(sensor_code.min()) == int(sensor_code.max()):  # one sensor: no sort, no copies
        back = np.flatnonzero(time[1:] < time[:-1])
        return [(int(i), int(i) + 1) for i in back]
    order = np.argsort(sensor_code, kind="stable")  # by sensor, file order within
    t, s = time[order], sensor_code[order]
    back = np.flatnonzero((s[1:] == s[:-1]) & (t[1:] < t[:-1]))
    return [(int(order[i]), int(order[i + 1])) for i in back]


def _json_numbers(text: str, key: str) -> str | None:
    try:
        values = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        return f"metadata '{key}': expected a JSON object of numbers by name, found {text!r:.80}"
    if not isinstance(values, dict) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in values.values()):
        return (f"metadata '{key}': expected a JSON object of finite numbers by name, found "
                f"{text!r:.80}")
    return None


def _number(text: str, key: str, low: float = -math.inf, high: float = math.inf,
            unit: str = "") -> str | None:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and low <= v <= high):
        limits = "" if math.isinf(low) else f" within [{low:g}, {high:g}]"
        return f"metadata '{key}': expected a finite number{limits}{unit}, found {text!r:.80}"
    return None


def metadata_problems(metadata: Mapping[str, str]) -> list[str]:
    """Check the metadata keys the library reads; other keys are free text."""
    json_found, motion_found = _parsed_problems(tuple(metadata.get(key) for key in _PARSED))
    found: list[str | None] = list(json_found)
    checks = {"ref_time": (-math.inf, math.inf, " (s)"), "origin_lat": (-90, 90, " deg"),
              "origin_lon": (-180, 360, " deg"), "origin_alt": (-math.inf, math.inf, " (m)")}
    for key, (low, high, unit) in checks.items():
        if key in metadata and metadata[key] != "":
            found.append(_number(metadata[key], key, low, high, unit))
    seed = metadata.get("seed", "")
    if seed and seed != "None" and not (seed.isdigit() and seed.isascii()):
        found.append(f"metadata 'seed': expected a whole number >= 0, found {seed!r:.80}")
    found += motion_found
    return [f for f in found if f]


_PARSED = ("truth", "nuisance", "motion")  # the keys whose check parses text (JSON, a name)


@lru_cache(maxsize=256)
def _parsed_problems(texts: tuple[str | None, ...]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Check the metadata of :data:`_PARSED` (None: absent), once per distinct text."""
    truth, nuisance, motion = texts
    json_found = tuple(p for key, text in (("truth", truth), ("nuisance", nuisance))
                       if text is not None and (p := _json_numbers(text, key)))
    if motion is None:
        return json_found, ()
    from .motion import motion_from_name

    try:
        motion_from_name(motion, 0.0)
    except ValueError as e:
        return json_found, (f"metadata 'motion': {e}",)
    return json_found, ()


def raise_problems(found: list[str], what: str = "measurement set") -> None:
    """Raise one ``ValueError`` listing ``found`` (nothing when it is empty)."""
    if found:
        more = f"\n  ... and {len(found) - 3 * _SHOWN} more" if len(found) > 3 * _SHOWN else ""
        raise ValueError(f"invalid {what}: " + "\n  ".join(found[:3 * _SHOWN]) + more)


def check_set(meas: Any, order: bool = True) -> None:
    """Refuse a measurement set that breaks a rule (columns and metadata)."""
    # the rules on the file-unit cells, whose values the messages quote
    found = column_problems(meas.time, meas.sensor_code, meas.kind_code, meas.value,
                            meas.sigma, meas.sensor_state, meas.time_ref, order,
                            getattr(meas, "stream_code", lambda: None)())
    for code in [c for c, name in enumerate(meas.sensor_names) if not str(name).strip()]:
        rows = np.flatnonzero(meas.sensor_code == code)  # (a file refuses an empty sensor cell)
        found += [f"row {int(r) + 1}, column 'sensor': expected a sensor id (text), found "
                  f"{meas.sensor_names[code]!r}" for r in rows[:_SHOWN]]
    raise_problems(found + metadata_problems(meas.metadata))
