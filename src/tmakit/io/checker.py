"""From a raw table to a checked :class:`~tmakit.data.MeasurementSet`.

The columns a file has against what its rows need (numbers coerced by pandera), every cell's rule,
and the rules across rows; all problems are reported together.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Collection
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS
from ..rules import (
    FINITE,
    LATITUDE,
    LONGITUDE,
    POSITION,
    SIGMA_POSITIVE,
    SIGMA_RESOLVED,
    TIME,
    VELOCITY,
    check_set,
    far_times,
    geo_within,
    metadata_problems,
    sigma_resolved,
    state_within_reach,
    time_within_limit,
)
from .contract import (
    GEO_COLUMNS,
    NUMERIC_COLUMNS,
    Problems,
    RawTable,
    between_sensor_kinds,
    blank_mask,
    is_blank,
    number_text,
    reference_kinds,
    reference_kinds_text,
    text_column,
)
from .errors import MeasurementFileError
from .positions import Layout, fdoa_carriers, ref_sensor_state, sensor_state

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["check_cells", "check_columns", "check_order", "check_table", "read_numbers"]


def check_table(path: str | os.PathLike[str], raw: RawTable,
                origin: tuple[float, float, float] | None = None) -> MeasurementSet:
    """Check a raw table against the contract of ``docs/file-format.md`` and build the set."""
    frame, n = raw.frame, len(raw.frame)
    problems = Problems(raw)
    has = set(frame.columns).__contains__
    sensor = (text_column(frame["sensor"]) if has("sensor")
              else np.full(n, "", dtype=object))
    kind = (_stripped(text_column(frame["kind"])) if has("kind")
            else np.full(n, "", dtype=object))
    is_rd = np.isin(kind, reference_kinds())

    layout = check_columns(frame.columns, [k for k in KINDS if np.any(kind == k)], problems)
    num = read_numbers(frame, problems)
    ref_name = (_stripped(text_column(frame["ref_sensor"])) if has("ref_sensor") else None)
    ref_given = check_cells(frame, num, kind, is_rd, problems, ref_name)
    tonal = _tonal(frame, kind, problems) if has("tonal") else None
    check_order(num, sensor, kind, problems, tonal)
    state, origin_metadata = sensor_state(num, layout, origin, problems)
    time_ref = num["time_ref"] if "time_ref" in num else np.full(n, np.nan)
    earlier = is_rd & ~np.isin(kind, between_sensor_kinds())  # tdoa, fdoa: given, checked
    named = (is_rd & ~earlier & ~ref_given & (ref_name != "") if ref_name is not None
             else np.zeros(n, dtype=bool))
    ref_state = ref_sensor_state(num, state, sensor, earlier, ref_given | (is_rd & ~earlier),
                                 layout, problems, ref_name, named)
    meta_carrier = fdoa_carriers(num, kind, raw.metadata, problems)
    if not layout.has_ref and np.any(is_rd & ~earlier & ~named):
        problems.missing("ref_sensor_x", "; tdoa and fdoa rows give their reference sensor's "
                                         "state, or name it in a ref_sensor column")

    problems.file.extend(metadata_problems(raw.metadata))  # the keys the library reads
    found = problems.sorted()
    if found:
        raise MeasurementFileError(Path(path), found)
    meta: dict[str, Any] = dict(raw.metadata)
    meta.update(origin_metadata)
    meta.update(meta_carrier)
    out = MeasurementSet(num["time"], np.asarray(sensor.tolist(), dtype=str),
                         np.asarray(kind.tolist(), dtype=str), num["value"],
                         num["sigma"], state, time_ref, ref_state, meta, check=tonal is None)
    if tonal is not None:
        out = out.with_tonal(tonal)
        check_set(out)
    return out


def _tonal(frame: Any, kind: NDArray[np.object_], problems: Problems) -> NDArray[np.str_]:
    """Read the ``tonal`` column: a label on each frequency row, empty on the others."""
    text = np.array([("" if c is None or c != c else str(c)).strip()
                     for c in frame["tonal"].tolist()], dtype=str)
    for row in np.flatnonzero((text != "") != (kind == "frequency"))[:20].tolist():
        problems.cell(row, "tonal", "a tonal label on a frequency row, empty on any other",
                      repr(text[row]))
    return text


def _stripped(text: NDArray[np.object_]) -> NDArray[np.object_]:
    """Strip each cell, once per distinct text (the cells then share their str objects)."""
    import pandas as pd

    codes, uniques = pd.factorize(text)
    return np.array([str(u).strip() for u in uniques] + [""], dtype=object)[codes]


def check_columns(columns: Collection[str], kinds: list[str], problems: Problems) -> Layout:
    """Record missing or conflicting columns, given the kinds present in the file."""
    has = set(columns).__contains__
    for c in ("time", "sensor", "kind", "value", "sigma"):
        if not has(c):
            problems.missing(c)
    geodetic = _check_position(has, problems)
    has_velocity = _check_velocity(has, kinds, problems)
    if any(k in kinds for k in reference_kinds()) and not has("time_ref"):
        problems.missing("time_ref", f"; needed by the {reference_kinds_text()} rows")
    ref = [c for c in REF_STATE_COLUMNS if has(c)]
    if ref:
        for c in ("ref_sensor_x", "ref_sensor_y"):
            if not has(c):
                problems.missing(c, f" ({', '.join(ref)} {'is' if len(ref) == 1 else 'are'}"
                                    " given)")
    return Layout(geodetic, has_velocity, bool(ref))


def _check_position(has: Callable[[str], bool], problems: Problems) -> bool:
    """ENU or geodetic positions, not both; True for geodetic."""
    enu = [c for c in ("sensor_x", "sensor_y", "sensor_z") if has(c)]
    geo = [c for c in GEO_COLUMNS if has(c)]
    geodetic = bool(geo) and not enu
    if enu and geo:
        problems.file.append(
            f"columns {', '.join(enu)} and {', '.join(geo)} both give the sensor position: "
            "give either sensor_x, sensor_y (and sensor_z) in ENU metres or sensor_lat, "
            "sensor_lon (and sensor_alt), not both")
    elif geodetic:
        for c in ("sensor_lat", "sensor_lon"):
            if not has(c):
                problems.missing(c, " (the file gives positions as latitude/longitude)")
    else:
        for c in ("sensor_x", "sensor_y"):
            if not has(c):
                problems.missing(c, "; or give sensor_lat and sensor_lon (degrees) instead")
    return geodetic


def _check_velocity(has: Callable[[str], bool], kinds: list[str], problems: Problems) -> bool:
    """Velocity columns needed by the kinds, or given in pairs; True if both are given."""
    velocity_kinds = [k for k in kinds if KINDS[k].uses_velocity]
    has_vx, has_vy = has("sensor_vx"), has("sensor_vy")
    if velocity_kinds:
        for c in ("sensor_vx", "sensor_vy"):
            if not has(c):
                problems.missing(c, f"; needed by the kind{'s' if len(velocity_kinds) > 1 else ''}"
                                    f" {', '.join(velocity_kinds)} in this file")
    elif has_vx != has_vy:
        given, absent = (("sensor_vx", "sensor_vy") if has_vx else ("sensor_vy", "sensor_vx"))
        problems.missing(absent, f" ({given} is given)")
    return bool(has_vx and has_vy)


Numbers = dict[str, NDArray[np.float64]]
RowCheck = Callable[[NDArray[Any], NDArray[np.intp]], NDArray[np.bool_]]


def value_ranges() -> list[tuple[str, Callable[[ArrayLike], NDArray[np.bool_]], str]]:
    """Return the value ranges checked per kind, from each kind's hook (``value_range``)."""
    return [(k, cls.check_values, cls.value_range.describe(cls.file_unit))
            for k, cls in KINDS.items() if cls.value_range is not None]


def read_numbers(frame: pd.DataFrame, problems: Problems) -> Numbers:
    """Numeric columns as float64 (NaN for empty cells), via pandera's coercion."""
    import pandas as pd
    import pandera.pandas as pa

    present = [c for c in NUMERIC_COLUMNS if c in frame.columns]
    if all(frame[c].dtype == np.float64 for c in present):  # nothing to coerce (nor copy twice)
        return {c: frame[c].to_numpy(dtype=np.float64, copy=True) for c in present}
    cols = {}
    for c in present:
        s = frame[c]
        if not (pd.api.types.is_numeric_dtype(s) or pd.api.types.is_bool_dtype(s)):
            blank = blank_mask(s)
            s = s.astype(object)
            s[blank] = np.nan
        cols[c] = s
    table = pd.DataFrame(cols, index=pd.RangeIndex(len(frame)))
    schema = pa.DataFrameSchema(
        {c: pa.Column("float64", coerce=True, nullable=True) for c in present})
    try:
        table = schema.validate(table, lazy=True)
    except pa.errors.SchemaErrors as err:
        fc = err.failure_cases
        whole: set[str] = set()
        for column, index in zip(fc["column"], fc["index"], strict=True):
            if column in cols and index is not None and not is_blank(index):
                row = int(index)
                problems.cell(row, str(column), "a number")
                table.loc[row, column] = np.nan
            elif column in cols:  # the column as a whole (lists, structs): not numbers
                whole.add(str(column))
        for column in sorted(whole):
            problems.file.append(f"column '{column}': expected numbers, found values of type "
                                 f"{frame[column].dtype}")
            table[column] = np.nan
        table = schema.validate(table, lazy=True)
    return {c: table[c].to_numpy(dtype=np.float64, copy=True) for c in present}


class _Cells:
    """A file's columns, each cell checked rule by rule (the first rule it breaks is recorded)."""

    def __init__(self, values: dict[str, NDArray[Any]], problems: Problems) -> None:
        self.values, self.problems = values, problems
        self.rows = np.arange(len(problems.raw.frame))

    def check(self, column: str, ok: RowCheck, what: str | Callable[[int], str],
              ignore_na: bool = True) -> None:
        """Record ``what`` was expected at each cell of ``column`` where ``ok`` fails."""
        v = self.values[column]
        with np.errstate(invalid="ignore"):
            bad = ~np.asarray(ok(v, self.rows), dtype=bool)
        if ignore_na and v.dtype == np.float64:  # empty cells pass
            bad &= ~np.isnan(v)
        for row in np.flatnonzero(bad).tolist():
            self.problems.cell(row, column, what(row) if callable(what) else what)

    def number(self, column: str) -> None:
        """Record each empty or non-finite cell of a column that needs a number."""
        self.check(column, lambda v, r: ~np.isnan(v), "a number", ignore_na=False)
        self.check(column, lambda v, r: np.isfinite(v), FINITE)


def check_cells(frame: pd.DataFrame, num: Numbers, kind: NDArray[np.object_],
                is_rd: NDArray[np.bool_], problems: Problems,
                ref_name: NDArray[np.object_] | None = None) -> NDArray[np.bool_]:
    """Check every cell against the per-cell rules; record one problem per failing cell."""
    text = {c: text_column(frame[c]) for c in ("sensor", "kind", "ref_sensor")
            if c in frame.columns}
    cells = _Cells({**num, **text}, problems)
    _basic_checks(cells, num, kind)
    ref_given = np.zeros(len(frame), dtype=bool)
    for c in REF_STATE_COLUMNS:
        if c in num:
            ref_given |= ~np.isnan(num[c])
    ref_given &= is_rd
    if "kind" not in frame.columns:
        return ref_given
    if "time_ref" in num:
        _time_ref_checks(cells, num, kind, is_rd)
    named = np.zeros(len(frame), dtype=bool) if ref_name is None else ref_name != ""
    for c in REF_STATE_COLUMNS:
        if c in num:
            _ref_state_checks(cells, c, kind, is_rd, ref_given, named)
    if ref_name is not None:
        _ref_name_checks(cells, kind)
    if "carrier" in num:
        cells.check("carrier", lambda v, r: (v > 0) & np.isfinite(v),
                    "a carrier frequency > 0 (Hz)")
        cells.check("carrier", lambda v, r: np.isnan(v) | (kind[r] == "fdoa"),
                    lambda row: "an empty cell: only fdoa rows have a carrier (this row is "
                                f"{kind[row] or 'of no kind'})", ignore_na=False)
    return ref_given


def _basic_checks(cells: _Cells, num: Numbers, kind: NDArray[np.object_]) -> None:
    """Sensor id, kind, finite numbers, value ranges per kind, sigma > 0, lat/lon ranges."""
    if "sensor" in cells.values:
        cells.check("sensor", lambda v, r: np.array([s.strip() != "" for s in v], dtype=bool),
                    "a sensor id (text)")
    if "kind" in cells.values:
        cells.check("kind", lambda v, r: np.isin(v.astype(str), list(KINDS)),
                    f"one of the kinds {', '.join(KINDS)}")
    for c in ("time", "value", "sigma", *SENSOR_STATE_COLUMNS, *GEO_COLUMNS):
        if c in num:
            cells.number(c)
    if "time" in num:
        cells.check("time", lambda v, r: time_within_limit(v), TIME)
    for j, c in [*enumerate(SENSOR_STATE_COLUMNS), (2, "sensor_alt")]:
        if c in num:
            cells.check(c, partial(_reach, column=j), POSITION if j < 3 else VELOCITY)
    if "value" in num:
        for k, ok, what in value_ranges():
            cells.check("value", _for_kind(kind, k, ok), what)
    if "sigma" in num:
        cells.check("sigma", lambda v, r: v > 0, SIGMA_POSITIVE)
    if "sigma" in num and "value" in num:
        value = num["value"]
        moot = ~np.isfinite(value)  # no value, or one out of its range: sigma is moot
        for k, ok, _ in value_ranges():
            moot |= (kind == k) & ~ok(value)
        cells.check("sigma", lambda v, r: ~(v > 0) | moot[r] | sigma_resolved(value[r], v),
                    SIGMA_RESOLVED)
    if "sensor_lat" in num:
        cells.check("sensor_lat", lambda v, r: geo_within(v, "sensor_lat"), LATITUDE)
    if "sensor_lon" in num:
        cells.check("sensor_lon", lambda v, r: geo_within(v, "sensor_lon"), LONGITUDE)


def _reach(values: NDArray[np.float64], rows: object, column: int) -> NDArray[np.bool_]:
    """Tell where a sensor state column lies within reach (a column check's signature)."""
    return state_within_reach(values, column)


def _for_kind(kind: NDArray[np.object_], k: str,
              ok: Callable[[NDArray[np.float64]], NDArray[np.bool_]]) -> RowCheck:
    """Make a value check that holds on the rows of kind ``k`` only."""
    return lambda v, r: ok(v) | (kind[r] != k)


def _time_ref_checks(cells: _Cells, num: Numbers, kind: NDArray[np.object_],
                     is_rd: NDArray[np.bool_]) -> None:
    """time_ref: present exactly on range-difference rows, finite, before time."""
    t = num.get("time", np.full(is_rd.shape[0], np.nan))
    between = np.isin(kind, between_sensor_kinds())
    cells.check("time_ref", lambda v, r: ~np.isnan(v) | ~is_rd[r],
                f"a time_ref (s) before time: {reference_kinds_text()} rows need one",
                ignore_na=False)
    cells.check("time_ref", lambda v, r: np.isnan(v) | is_rd[r],
                lambda row: f"an empty cell: only {reference_kinds_text()} rows have a "
                            f"time_ref (this row is {kind[row] or 'of no kind'})",
                ignore_na=False)
    cells.check("time_ref", lambda v, r: np.isfinite(v), FINITE)
    cells.check("time_ref", lambda v, r: ~(v >= t[r]) | ~is_rd[r] | between[r],
                lambda row: f"a time_ref before time ({number_text(t[row])} s)")
    cells.check("time_ref", lambda v, r: (v == t[r]) | ~between[r],
                lambda row: f"the row's own time ({number_text(t[row])} s): a {kind[row]} is "
                            "between two sensors at one time")


def _ref_state_checks(cells: _Cells, c: str, kind: NDArray[np.object_],
                      is_rd: NDArray[np.bool_], ref_given: NDArray[np.bool_],
                      named: NDArray[np.bool_]) -> None:
    """Check a ref_sensor_* column: only on range-difference rows, all or none of a row, finite."""
    between = np.isin(kind, between_sensor_kinds())
    cells.check(c, lambda v, r: ~np.isnan(v) | ~between[r] | named[r],
                lambda row: f"a number: a {kind[row]} row gives its reference sensor's state "
                            "(or names it in ref_sensor)", ignore_na=False)
    cells.check(c, lambda v, r: np.isnan(v) | is_rd[r],
                lambda row: f"an empty cell: only {reference_kinds_text()} rows have a sensor "
                            f"state at time_ref (this row is {kind[row] or 'of no kind'})",
                ignore_na=False)
    cells.check(c, lambda v, r: ~np.isnan(v) | ~ref_given[r] | ~is_rd[r],
                "a number (the other ref_sensor_* cells of this row are given; give all or "
                "none)", ignore_na=False)
    cells.check(c, lambda v, r: np.isfinite(v), FINITE)


def _ref_name_checks(cells: _Cells, kind: NDArray[np.object_]) -> None:
    """Check a ref_sensor name: only on tdoa/fdoa rows, another sensor than the row's."""
    between = np.isin(kind, between_sensor_kinds())
    own = cells.values.get("sensor", np.full(kind.shape[0], "", dtype=object))
    cells.check("ref_sensor", lambda v, r: np.array([x.strip() == "" for x in v]) | between[r],
                lambda row: "an empty cell: only tdoa and fdoa rows name a reference sensor "
                            f"(this row is {kind[row] or 'of no kind'})")
    cells.check("ref_sensor", lambda v, r: np.array([x.strip() != str(o).strip()
                                                     for x, o in zip(v, own[r], strict=True)]),
                lambda row: f"another sensor than the row's own ({own[row]!r})")


def check_order(num: dict[str, NDArray[np.float64]], sensor: NDArray[np.object_],
                kind: NDArray[np.object_], problems: Problems,
                tonal: NDArray[np.str_] | None = None) -> None:
    """Time order within each sensor, no far time, no (sensor, kind, time, time_ref) twice."""
    import pandas as pd

    if "time" not in num or "sensor" not in problems.raw.frame.columns:
        return
    t = num["time"]
    tr = num.get("time_ref", np.full(t.shape[0], np.nan))
    rows = np.flatnonzero(~problems.bad_rows("time", "sensor"))
    far, expected = far_times(np.where(problems.bad_rows("time"), np.nan, t))
    for far_row in np.flatnonzero(far).tolist():
        problems.cell(far_row, "time", expected)
    # codes, not text: equal ids give equal codes, and groupby on integers is light
    table = pd.DataFrame({"sensor": pd.factorize(sensor[rows])[0],
                          "kind": pd.factorize(kind[rows])[0],
                          "time": t[rows], "time_ref": tr[rows], "row": rows,
                          "tonal": 0 if tonal is None else pd.factorize(tonal[rows])[0]})
    by_sensor = table.groupby("sensor", sort=False)
    prev_row = by_sensor["row"].shift().to_numpy()
    prev_time = by_sensor["time"].shift().to_numpy()
    for i in np.flatnonzero(prev_time > table["time"].to_numpy()).tolist():
        row, prev, s = int(rows[i]), int(prev_row[i]), sensor[rows[i]]
        problems.cell(row, "time",
                      f"a time >= {number_text(t[prev])} s, the time of the previous row of "
                      f"sensor '{s}' ({problems.where(prev)})",
                      f"{number_text(t[row])} (time decreases for sensor '{s}')")

    table = table[~problems.bad_rows("kind", "time_ref")[rows]]
    key = ["sensor", "kind", "time", "time_ref", "tonal"]
    first = table.groupby(key, sort=False, dropna=False)["row"].transform("first")
    for row, prev in zip(table["row"].to_numpy(), first.to_numpy(), strict=True):
        if row == prev:
            continue
        ref = "" if math.isnan(tr[row]) else f", time_ref {number_text(tr[row])}"
        problems.cell(int(row), "time", "one row per (sensor, kind, time, time_ref)",
                      f"a duplicate of {problems.where(int(prev))} (sensor '{sensor[row]}', "
                      f"kind '{kind[row]}', time {number_text(t[row])}{ref})")
