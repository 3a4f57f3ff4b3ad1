"""Measurement files: a :class:`~tmakit.data.MeasurementSet` as CSV or Parquet.

The contract (columns, units, rules) is in ``docs/file-format.md``.  Reading checks every
cell and reports *all* problems at once in a :class:`MeasurementFileError` whose lines name
the row, the line of the CSV file and the column::

    obs.csv: 2 problems in the measurement file:
      - row 3 (line 6), column 'sigma': expected a noise standard deviation > 0, found -1
      - row 7 (line 10), column 'kind': expected one of the kinds bearing, ..., found 'bearng'

The column checks are a `pandera <https://pandera.readthedocs.io>`_ schema (validated lazily,
its failure cases turned into the messages above); the checks that need several rows (time
order per sensor, duplicates, the sensor position at ``time_ref``) are plain pandas/numpy.
pandas, pyarrow and pandera are imported on first use, so ``import tmakit`` stays light.

Writing is atomic (a temporary file in the same folder, then :func:`os.replace`) and refuses
to overwrite an existing file unless ``force=True``.  Floats are written with the shortest
representation that parses back to the same number, so files round-trip exactly.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import secrets
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [
    "COLUMN_ORDER",
    "FORMAT_LINE",
    "MeasurementFileError",
    "read_measurements",
    "write_measurements",
]

#: First line of every CSV file tmakit writes.
FORMAT_LINE = "# tmakit measurements v1"
#: Prefix of tmakit's keys in the Arrow schema metadata of Parquet files.
PARQUET_METADATA_PREFIX = "tmakit:"
#: Column order of written files (the ``ref_sensor_*`` columns follow when the set has
#: range differences).
COLUMN_ORDER = ("time", "sensor", "kind", "value", "sigma", *SENSOR_STATE_COLUMNS,
                "time_ref")
CSV_SUFFIXES = (".csv",)
PARQUET_SUFFIXES = (".parquet", ".pq")
#: At most this many problems are listed in a :class:`MeasurementFileError` message.
MAX_LISTED_PROBLEMS = 25

_GEO_COLUMNS = ("sensor_lat", "sensor_lon", "sensor_alt")
_NUMERIC_COLUMNS = ("time", "value", "sigma", *SENSOR_STATE_COLUMNS, *_GEO_COLUMNS,
                    "time_ref", *REF_STATE_COLUMNS)
_RANGE_DIFFERENCE = "range_difference"

_AXES = {"x": "east (m, ENU)", "y": "north (m, ENU)", "z": "up (m, ENU)",
         "vx": "velocity east (m/s, ENU)", "vy": "velocity north (m/s, ENU)",
         "vz": "velocity up (m/s, ENU)"}
#: What each column of the contract is for (used in "column 'C' is missing: ..." problems).
COLUMN_PURPOSE: dict[str, str] = {
    "time": "time of the measurement (s)",
    "sensor": "id of the sensor that made the measurement (text)",
    "kind": f"measurement kind, one of {', '.join(KINDS)}",
    "value": "measured value in the unit of its kind (deg, deg/s, m, m/s, Hz or dBm)",
    "sigma": "noise standard deviation, in the unit of value",
    **{c: f"sensor {_AXES[c.removeprefix('sensor_')]} at time" for c in SENSOR_STATE_COLUMNS},
    "sensor_lat": "sensor latitude (degrees, WGS-84)",
    "sensor_lon": "sensor longitude (degrees, WGS-84)",
    "sensor_alt": "sensor altitude (m, WGS-84)",
    "time_ref": "time of the earlier sample of a range difference (s)",
    **{c: f"sensor {_AXES[c.removeprefix('ref_sensor_')]} at time_ref"
       for c in REF_STATE_COLUMNS},
}


class MeasurementFileError(ValueError):
    """A measurement file that breaks the contract of ``docs/file-format.md``.

    ``path`` is the file, ``problems`` one line per problem (``row R (line L), column 'C':
    expected ..., found ...``).  The message starts with the path and lists the problems
    (at most :data:`MAX_LISTED_PROBLEMS` of them).
    """

    def __init__(self, path: str | os.PathLike[str], problems: Iterable[str]) -> None:
        self.path = Path(path)
        self.problems = [str(p) for p in problems]
        super().__init__(self._message())

    def _message(self) -> str:
        n = len(self.problems)
        if n == 0:
            return f"{self.path}: not a valid measurement file"
        head = f"{self.path}: {n} problem{'s' if n != 1 else ''} in the measurement file:"
        lines = [head, *(f"  - {p}" for p in self.problems[:MAX_LISTED_PROBLEMS])]
        if n > MAX_LISTED_PROBLEMS:
            rest = n - MAX_LISTED_PROBLEMS
            lines.append(f"  ... and {rest} more problem{'s' if rest != 1 else ''}")
        return "\n".join(lines)

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.path, self.problems))


# ---------------------------------------------------------------------------------------
# small helpers


def _file_format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix in CSV_SUFFIXES:
        return "csv"
    if suffix in PARQUET_SUFFIXES:
        return "parquet"
    shown = f"'{path.suffix}'" if path.suffix else "no suffix"
    raise MeasurementFileError(path, [
        f"unsupported file type ({shown}): measurement files end in "
        f"{', '.join(CSV_SUFFIXES + PARQUET_SUFFIXES)} (CSV or Parquet)"])


def _num(x: float) -> str:
    """A number for messages: shortest exact representation, no trailing '.0'."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _is_blank(v: Any) -> bool:
    if v is None:
        return True
    if isinstance(v, str):
        return v.strip() == ""
    try:
        return bool(v != v)  # NaN and pandas NA-likes
    except (TypeError, ValueError):
        return False


def _show(v: Any) -> str:
    """A cell value for "found ..." in messages."""
    if v is None or (isinstance(v, str) and v.strip() == ""):
        return "an empty cell"
    if isinstance(v, str):
        try:
            float(v)
        except ValueError:
            return repr(v)
        return v.strip()
    if isinstance(v, (bool, np.bool_)):
        return repr(bool(v))
    if isinstance(v, (float, int, np.floating, np.integer)):
        if isinstance(v, (float, np.floating)) and math.isnan(v):
            return "an empty cell (NaN)"
        return _num(float(v))
    try:
        if v != v:
            return "an empty cell"
    except (TypeError, ValueError):
        pass
    return repr(v)


# ---------------------------------------------------------------------------------------
# loading the raw table


@dataclass
class _RawTable:
    """A file's table as read, before checking: text cells for CSV, typed for Parquet."""

    frame: pd.DataFrame
    metadata: dict[str, str]
    #: Line of each data row in the CSV file (1-based), or None (Parquet).
    lines: NDArray[np.int64] | None


def _load_csv(path: Path) -> _RawTable:
    import pandas as pd

    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise MeasurementFileError(path, [f"not a UTF-8 text file ({e})"]) from None

    # Leading '# key: value' comment lines (and blank lines) before the header.
    metadata: dict[str, str] = {}
    consumed = 0
    pre_lines = 0
    for line in io.StringIO(text, newline=""):
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            break
        consumed += len(line)
        pre_lines += 1
        if stripped.startswith("#"):
            key, sep, value = stripped[1:].partition(":")
            if sep and key.strip():
                metadata[key.strip()] = value.strip()
    body = text[consumed:]

    # Records and their lines (csv module: knows quoted fields that span lines).
    reader = csv.reader(io.StringIO(body, newline=""))
    header = next(reader, None)
    if header is None:
        raise MeasurementFileError(path, [
            "the file has no header line; expected the columns "
            f"{', '.join(COLUMN_ORDER[:5])}, ..."])
    header_line = pre_lines + reader.line_num
    names = [h.strip() for h in header]
    problems = [f"line {header_line}: column {name!r} appears more than once in the header"
                for i, name in enumerate(names) if name in names[:i]]
    problems += [f"line {header_line}: column {i + 1} of the header has no name"
                 for i, name in enumerate(names) if not name]
    lines: list[int] = []
    while True:
        start = reader.line_num
        try:
            record = next(reader)
        except StopIteration:
            break
        except csv.Error as e:
            problems.append(f"line {pre_lines + start + 1}: cannot read the CSV record ({e})")
            break
        if not record:
            continue  # a blank line, skipped by pandas too
        lines.append(pre_lines + start + 1)
        if len(record) != len(header):
            problems.append(
                f"row {len(lines)} (line {lines[-1]}): expected {len(header)} fields (one per "
                f"header column), found {len(record)}")
    if problems:
        raise MeasurementFileError(path, problems)

    try:
        frame = pd.read_csv(io.StringIO(body), dtype=str, na_filter=False,
                            keep_default_na=False, index_col=False, skip_blank_lines=True)
    except (pd.errors.ParserError, ValueError) as e:
        raise MeasurementFileError(path, [f"cannot read the CSV table ({e})"]) from None
    frame.columns = names
    frame = frame.reset_index(drop=True)
    line_numbers = np.asarray(lines, dtype=np.int64) if len(lines) == len(frame) else None
    return _RawTable(frame, metadata, line_numbers)


def _load_parquet(path: Path) -> _RawTable:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError) as e:
        raise MeasurementFileError(path, [f"cannot be read as Parquet ({e})"]) from None
    metadata: dict[str, str] = {}
    for key, value in (table.schema.metadata or {}).items():
        k = key.decode("utf-8", "replace")
        if k.startswith(PARQUET_METADATA_PREFIX):
            metadata[k[len(PARQUET_METADATA_PREFIX):]] = value.decode("utf-8", "replace")
    names = [str(n).strip() for n in table.column_names]
    problems = [f"column {name!r} appears more than once"
                for i, name in enumerate(names) if name in names[:i]]
    if problems:
        raise MeasurementFileError(path, problems)
    frame = table.to_pandas().reset_index(drop=True)
    frame.columns = names
    return _RawTable(frame, metadata, None)


# ---------------------------------------------------------------------------------------
# checking


def _blank_mask(series: pd.Series) -> NDArray[np.bool_]:
    """Empty cells: NaN/None/NA, or text that is only spaces."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):
        return (series.str.strip() == "").fillna(True).to_numpy(dtype=bool)
    return series.map(_is_blank).to_numpy(dtype=bool)


def _text_column(series: pd.Series) -> NDArray[np.object_]:
    """Cells of a text column as Python str ('' for empty), ids like 1 kept as '1'."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):
        return series.fillna("").to_numpy(dtype=object)
    out = np.empty(len(series), dtype=object)
    for i, v in enumerate(series.tolist()):
        out[i] = "" if _is_blank(v) else str(v)
    return out


class _Checker:
    """Checks one raw table against the contract and builds the MeasurementSet."""

    def __init__(self, path: Path, raw: _RawTable,
                 origin: tuple[float, float, float] | None) -> None:
        self.path = path
        self.raw = raw
        self.frame = raw.frame
        self.n = len(raw.frame)
        self.origin_arg = origin
        self.columns = list(raw.frame.columns)
        self.file_problems: list[str] = []
        self.cell_problems: dict[tuple[int, str], str] = {}

    # -- problem bookkeeping -----------------------------------------------------------
    def where(self, row: int) -> str:
        lines = self.raw.lines
        if lines is None:
            return f"row {row + 1}"
        return f"row {row + 1} (line {lines[row]})"

    def cell(self, row: int, column: str, expected: str, found: str | None = None) -> None:
        """Record a problem at one cell (the first problem of a cell wins)."""
        if (row, column) in self.cell_problems:
            return
        if found is None:
            found = _show(self.frame[column].iat[row]) if column in self.frame else "nothing"
        self.cell_problems[(row, column)] = (
            f"{self.where(row)}, column '{column}': expected {expected}, found {found}")

    def missing(self, column: str, extra: str = "") -> None:
        self.file_problems.append(
            f"column '{column}' is missing: {COLUMN_PURPOSE[column]}{extra}")

    def bad_rows(self, *columns: str) -> NDArray[np.bool_]:
        """Rows with a problem in one of ``columns``."""
        mask = np.zeros(self.n, dtype=bool)
        wanted = set(columns)
        for row, column in self.cell_problems:
            if column in wanted:
                mask[row] = True
        return mask

    def problems(self) -> list[str]:
        order = {c: i for i, c in enumerate(self.columns)}
        cells = sorted(self.cell_problems.items(),
                       key=lambda item: (item[0][0], order.get(item[0][1], len(order))))
        return self.file_problems + [p for _, p in cells]

    # -- the steps -----------------------------------------------------------------------
    def run(self) -> MeasurementSet:
        has = set(self.columns).__contains__
        self.sensor = (_text_column(self.frame["sensor"]) if has("sensor")
                       else np.full(self.n, "", dtype=object))
        self.kind = (np.array([k.strip() for k in _text_column(self.frame["kind"])],
                              dtype=object) if has("kind") else np.full(self.n, "", dtype=object))
        kinds = [k for k in KINDS if np.any(self.kind == k)]
        self.is_rd = self.kind == _RANGE_DIFFERENCE

        self._check_columns(kinds)
        num = self._numbers()
        self._check_cells(num)
        self._check_order(num)
        state = self._sensor_state(num)
        time_ref = num["time_ref"] if "time_ref" in num else np.full(self.n, np.nan)
        ref_state = self._ref_state(num, state, time_ref)

        problems = self.problems()
        if problems:
            raise MeasurementFileError(self.path, problems)
        meta = dict(self.raw.metadata)
        meta.update(self.origin_metadata)
        return MeasurementSet(num["time"], np.asarray(self.sensor.tolist(), dtype=str),
                              np.asarray(self.kind.tolist(), dtype=str), num["value"],
                              num["sigma"], state, time_ref, ref_state, meta)

    def _check_columns(self, kinds: list[str]) -> None:
        has = set(self.columns).__contains__
        for c in ("time", "sensor", "kind", "value", "sigma"):
            if not has(c):
                self.missing(c)

        enu = [c for c in ("sensor_x", "sensor_y", "sensor_z") if has(c)]
        geo = [c for c in _GEO_COLUMNS if has(c)]
        self.geodetic = bool(geo) and not enu
        if enu and geo:
            self.file_problems.append(
                f"columns {', '.join(enu)} and {', '.join(geo)} both give the sensor position: "
                "give either sensor_x, sensor_y (and sensor_z) in ENU metres or sensor_lat, "
                "sensor_lon (and sensor_alt), not both")
        elif self.geodetic:
            for c in ("sensor_lat", "sensor_lon"):
                if not has(c):
                    self.missing(c, " (the file gives positions as latitude/longitude)")
        else:
            for c in ("sensor_x", "sensor_y"):
                if not has(c):
                    self.missing(c, "; or give sensor_lat and sensor_lon (degrees) instead")

        velocity_kinds = [k for k in kinds if KINDS[k].uses_velocity]
        self.has_velocity = has("sensor_vx") and has("sensor_vy")
        if velocity_kinds:
            for c in ("sensor_vx", "sensor_vy"):
                if not has(c):
                    self.missing(c, f"; needed by the kind{'s' if len(velocity_kinds) > 1 else ''}"
                                    f" {', '.join(velocity_kinds)} in this file")
        elif has("sensor_vx") != has("sensor_vy"):
            given, absent = (("sensor_vx", "sensor_vy") if has("sensor_vx")
                             else ("sensor_vy", "sensor_vx"))
            self.missing(absent, f" ({given} is given)")

        if _RANGE_DIFFERENCE in kinds and not has("time_ref"):
            self.missing("time_ref", "; needed by the range_difference rows")
        ref = [c for c in REF_STATE_COLUMNS if has(c)]
        self.has_ref = bool(ref)
        if ref:
            for c in ("ref_sensor_x", "ref_sensor_y"):
                if not has(c):
                    self.missing(c, f" ({', '.join(ref)} {'is' if len(ref) == 1 else 'are'}"
                                    " given)")

    def _numbers(self) -> dict[str, NDArray[np.float64]]:
        """Numeric columns as float64 (NaN for empty cells), via pandera's coercion; cells
        that are not numbers become problems."""
        import pandas as pd
        import pandera.pandas as pa

        present = [c for c in _NUMERIC_COLUMNS if c in self.frame.columns]
        cols = {}
        for c in present:
            s = self.frame[c]
            if not (pd.api.types.is_numeric_dtype(s) or pd.api.types.is_bool_dtype(s)):
                blank = _blank_mask(s)
                s = s.astype(object)
                s[blank] = np.nan
            cols[c] = s
        table = pd.DataFrame(cols, index=pd.RangeIndex(self.n))
        schema = pa.DataFrameSchema(
            {c: pa.Column("float64", coerce=True, nullable=True) for c in present})
        try:
            table = schema.validate(table, lazy=True)
        except pa.errors.SchemaErrors as err:
            fc = err.failure_cases
            for column, index in zip(fc["column"], fc["index"], strict=True):
                if column in cols and index is not None and not _is_blank(index):
                    row = int(index)
                    self.cell(row, str(column), "a number")
                    table.loc[row, column] = np.nan  # type: ignore[index]
            table = schema.validate(table, lazy=True)
        out = {c: table[c].to_numpy(dtype=np.float64, copy=True) for c in present}
        return out

    def _check_cells(self, num: dict[str, NDArray[np.float64]]) -> None:
        """The per-cell rules, as a pandera schema validated lazily."""
        import pandas as pd
        import pandera.pandas as pa

        kind, is_rd, n = self.kind, self.is_rd, self.n
        t = num.get("time", np.full(n, np.nan))
        expected: dict[tuple[str, str], Callable[[int], str]] = {}

        def check(column: str, name: str, ok: Callable[[NDArray[Any], NDArray[np.intp]],
                                                       NDArray[np.bool_]],
                  what: str | Callable[[int], str], ignore_na: bool = True) -> pa.Check:
            expected[(column, name)] = what if callable(what) else (lambda _row: what)

            def fn(s: pd.Series) -> pd.Series:
                rows = s.index.to_numpy(dtype=np.intp)
                return pd.Series(np.asarray(ok(s.to_numpy(), rows), dtype=bool), index=s.index)

            return pa.Check(fn, name=name, ignore_na=ignore_na)

        def finite(column: str) -> pa.Check:
            return check(column, "finite", lambda v, r: np.isfinite(v), "a finite number")

        def for_kind(k: str, ok: Callable[[NDArray[np.float64]], NDArray[np.bool_]],
                     what: str) -> pa.Check:
            return check("value", f"{k}_value", lambda v, r: ok(v) | (kind[r] != k), what)

        columns: dict[str, pa.Column] = {}
        if "sensor" in self.frame.columns:
            columns["sensor"] = pa.Column(None, checks=check(
                "sensor", "sensor_id",
                lambda v, r: np.array([s.strip() != "" for s in v], dtype=bool),
                "a sensor id (text)"))
        if "kind" in self.frame.columns:
            columns["kind"] = pa.Column(None, checks=check(
                "kind", "known_kind", lambda v, r: np.isin(v.astype(str), list(KINDS)),
                f"one of the kinds {', '.join(KINDS)}"))
        for c in ("time", "value", "sigma", *SENSOR_STATE_COLUMNS, *_GEO_COLUMNS):
            if c in num:
                columns[c] = pa.Column("float64", nullable=False, checks=[finite(c)])
        if "value" in columns:
            columns["value"].checks += [
                for_kind("bearing", lambda v: (v >= -360) & (v <= 360),
                         "a bearing within [-360, 360] deg"),
                for_kind("elevation", lambda v: (v >= -90) & (v <= 90),
                         "an elevation within [-90, 90] deg"),
                for_kind("frequency", lambda v: v > 0, "a frequency > 0 Hz"),
                for_kind("range", lambda v: v >= 0, "a range >= 0 m"),
            ]
        if "sigma" in columns:
            columns["sigma"].checks.append(check(
                "sigma", "positive", lambda v, r: v > 0,
                "a noise standard deviation > 0 (in the unit of value)"))
        if "sensor_lat" in columns:
            columns["sensor_lat"].checks.append(check(
                "sensor_lat", "latitude", lambda v, r: (v >= -90) & (v <= 90),
                "a latitude within [-90, 90] deg"))
        if "sensor_lon" in columns:
            columns["sensor_lon"].checks.append(check(
                "sensor_lon", "longitude", lambda v, r: (v >= -180) & (v <= 360),
                "a longitude within [-180, 360] deg"))
        if "time_ref" in num and "kind" in self.frame.columns:
            columns["time_ref"] = pa.Column("float64", nullable=True, checks=[
                check("time_ref", "required", lambda v, r: ~np.isnan(v) | ~is_rd[r],
                      "a time_ref (s) before time: range_difference rows need one",
                      ignore_na=False),
                check("time_ref", "unused", lambda v, r: np.isnan(v) | is_rd[r],
                      lambda row: f"an empty cell: only range_difference rows have a time_ref "
                                  f"(this row is {kind[row] or 'of no kind'})",
                      ignore_na=False),
                finite("time_ref"),
                check("time_ref", "before_time",
                      lambda v, r: ~(v >= t[r]) | ~is_rd[r],
                      lambda row: f"a time_ref before time ({_num(t[row])} s)"),
            ])
        ref_given = np.zeros(n, dtype=bool)
        for c in REF_STATE_COLUMNS:
            if c in num:
                ref_given |= ~np.isnan(num[c])
        self.ref_given = ref_given & is_rd
        for c in REF_STATE_COLUMNS:
            if c in num and "kind" in self.frame.columns:
                columns[c] = pa.Column("float64", nullable=True, checks=[
                    check(c, "unused", lambda v, r: np.isnan(v) | is_rd[r],
                          lambda row: f"an empty cell: only range_difference rows have a "
                                      f"sensor state at time_ref (this row is "
                                      f"{kind[row] or 'of no kind'})", ignore_na=False),
                    check(c, "complete", lambda v, r: ~np.isnan(v) | ~ref_given[r] | ~is_rd[r],
                          "a number (the other ref_sensor_* cells of this row are given; "
                          "give all or none)", ignore_na=False),
                    finite(c),
                ])

        table = pd.DataFrame({c: (num[c] if c in num else _text_column(self.frame[c]))
                              for c in columns}, index=pd.RangeIndex(n))
        schema = pa.DataFrameSchema(columns)
        try:
            schema.validate(table, lazy=True)
        except pa.errors.SchemaErrors as err:
            fc = err.failure_cases
            for column, name, index, case in zip(fc["column"], fc["check"], fc["index"],
                                                 fc["failure_case"], strict=True):
                column = str(column)
                if index is None or _is_blank(index):
                    self.file_problems.append(f"column '{column}': {name}: {case}")
                    continue
                row = int(index)
                if name == "not_nullable":
                    self.cell(row, column, "a number")
                elif (column, name) in expected:
                    self.cell(row, column, expected[(column, name)](row))
                else:  # pragma: no cover - a pandera check we did not define
                    self.cell(row, column, str(name), _show(case))

    def _check_order(self, num: dict[str, NDArray[np.float64]]) -> None:
        """Time order within each sensor, and no (sensor, kind, time, time_ref) twice."""
        import pandas as pd

        if "time" not in num or "sensor" not in self.frame.columns:
            return
        t = num["time"]
        tr = num.get("time_ref", np.full(self.n, np.nan))
        rows = np.flatnonzero(~self.bad_rows("time", "sensor"))
        table = pd.DataFrame({"sensor": self.sensor[rows], "kind": self.kind[rows],
                              "time": t[rows], "time_ref": tr[rows], "row": rows})
        by_sensor = table.groupby("sensor", sort=False)
        prev_row = by_sensor["row"].shift().to_numpy()
        prev_time = by_sensor["time"].shift().to_numpy()
        for i in np.flatnonzero(prev_time > table["time"].to_numpy()):
            row, prev, sensor = int(rows[i]), int(prev_row[i]), self.sensor[rows[i]]
            self.cell(row, "time",
                      f"a time >= {_num(t[prev])} s, the time of the previous row of "
                      f"sensor '{sensor}' ({self.where(prev)})",
                      f"{_num(t[row])} (time decreases for sensor '{sensor}')")

        table = table[~self.bad_rows("kind", "time_ref")[rows]]
        key = ["sensor", "kind", "time", "time_ref"]
        first = table.groupby(key, sort=False, dropna=False)["row"].transform("first")
        for row, prev in zip(table["row"].to_numpy(), first.to_numpy(), strict=True):
            if row == prev:
                continue
            ref = "" if math.isnan(tr[row]) else f", time_ref {_num(tr[row])}"
            self.cell(int(row), "time", "one row per (sensor, kind, time, time_ref)",
                      f"a duplicate of {self.where(int(prev))} (sensor '{self.sensor[row]}', "
                      f"kind '{self.kind[row]}', time {_num(t[row])}{ref})")

    def _origin(self) -> tuple[float, float, float] | None:
        if self.origin_arg is not None:
            try:
                lat, lon, alt = (float(v) for v in self.origin_arg)
            except (TypeError, ValueError):
                self.file_problems.append(
                    f"origin {self.origin_arg!r}: expected (lat, lon, alt) in degrees, "
                    "degrees, metres")
                return None
            origin = (lat, lon, alt)
            self.origin_metadata = {k: repr(v) for k, v in
                                    zip(("origin_lat", "origin_lon", "origin_alt"), origin,
                                        strict=True)}
            return origin
        meta = self.raw.metadata
        if "origin_lat" not in meta and "origin_lon" not in meta:
            self.file_problems.append(
                "sensor positions are given as sensor_lat/sensor_lon but no ENU origin is "
                "known: pass an origin (read_measurements(path, origin=(lat, lon, alt)), or "
                "--origin LAT,LON,ALT on the command line) or add metadata lines "
                "'# origin_lat: ...', '# origin_lon: ...', '# origin_alt: ...'")
            return None
        values = []
        for key in ("origin_lat", "origin_lon", "origin_alt"):
            text = meta.get(key, "0" if key == "origin_alt" else "")
            try:
                values.append(float(text))
            except ValueError:
                if text:
                    unit = "metres" if key == "origin_alt" else "degrees"
                    self.file_problems.append(
                        f"metadata '{key}': expected a number ({unit}), found {text!r}")
                else:
                    self.file_problems.append(
                        f"metadata '{key}' is missing: the ENU origin needs origin_lat and "
                        "origin_lon (and origin_alt)")
                return None
        return values[0], values[1], values[2]

    def _sensor_state(self, num: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
        n = self.n
        zeros = np.zeros(n)
        state = np.full((n, 6), np.nan)
        self.origin_metadata: dict[str, str] = {}
        if self.geodetic:
            if "sensor_lat" in num and "sensor_lon" in num:
                origin = self._origin()
                if origin is not None:
                    from ..geodesy import geodetic_to_enu

                    lat, lon = num["sensor_lat"].copy(), num["sensor_lon"].copy()
                    alt = num.get("sensor_alt", zeros).copy()
                    bad = self.bad_rows(*_GEO_COLUMNS)
                    lat[bad] = lon[bad] = alt[bad] = np.nan  # pymap3d refuses |lat| > 90
                    try:
                        with np.errstate(invalid="ignore"):
                            e, nn, u = geodetic_to_enu(lat, lon, alt, origin)
                        state[:, 0], state[:, 1], state[:, 2] = e, nn, u
                    except ValueError as err:
                        self.file_problems.append(f"origin {origin}: {err}")
        else:
            for i, c in enumerate(("sensor_x", "sensor_y", "sensor_z")):
                state[:, i] = num.get(c, zeros if c == "sensor_z" else np.full(n, np.nan))
        for i, c in enumerate(("sensor_vx", "sensor_vy", "sensor_vz"), start=3):
            state[:, i] = num.get(c, zeros)
        return state

    def _ref_state(self, num: dict[str, NDArray[np.float64]], state: NDArray[np.float64],
                   time_ref: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sensor state at time_ref: from the ref_sensor_* columns, else from the sensor's row
        at that time, else interpolated along the sensor's rows (:class:`RecordedTrack`)."""
        from ..sensors import RecordedTrack

        n = self.n
        ref = np.full((n, 6), np.nan)
        given = getattr(self, "ref_given", np.zeros(n, dtype=bool))
        for i, c in enumerate(REF_STATE_COLUMNS):
            col = num.get(c, np.zeros(n) if i >= 2 else np.full(n, np.nan))
            ref[given, i] = col[given]
        if "time" not in num or "time_ref" not in num:
            return ref
        t = num["time"]
        need = (self.is_rd & ~given & np.isfinite(time_ref)
                & ~self.bad_rows("time", "sensor", "time_ref"))
        if not np.any(need):
            return ref
        state_cols = [c for c in (*SENSOR_STATE_COLUMNS, *_GEO_COLUMNS) if c in num]
        usable = (~self.bad_rows("time", "sensor", *state_cols)
                  & np.all(np.isfinite(state), axis=1))
        for sensor in dict.fromkeys(self.sensor[need]):
            rows = np.flatnonzero(need & (self.sensor == sensor))
            tr = time_ref[rows]
            mine = np.flatnonzero(usable & (self.sensor == sensor))
            # one row per time (the first), in time order
            times, first = np.unique(t[mine], return_index=True)
            first = mine[first]
            found = np.zeros(rows.shape[0], dtype=bool)
            if times.shape[0] > 0:
                at = np.clip(np.searchsorted(times, tr), 0, times.shape[0] - 1)
                found = times[at] == tr
                ref[rows[found]] = state[first[at[found]]]
            inside = ~found & (tr >= times[0]) & (tr <= times[-1]) if times.shape[0] > 1 \
                else np.zeros(rows.shape[0], dtype=bool)
            if np.any(inside):
                velocities = state[first, 3:] if self.has_velocity else None
                track = RecordedTrack(times, state[first, :3], velocities)
                ref[rows[inside]] = track.states(tr[inside])
                if not self.has_velocity:  # like the sensor velocities, absent from the file
                    ref[rows[inside], 3:] = 0.0
            known = (f"its rows span {_num(times[0])} to {_num(times[-1])} s"
                     if times.shape[0] > 0 else "it has no other usable rows")
            for row in rows[~found & ~inside]:
                self.cell(int(row), "time_ref",
                          f"a time at which sensor '{sensor}' has a known position ({known}; "
                          "or give the ref_sensor_* columns)",
                          f"{_num(time_ref[row])} (no sensor position known at time_ref "
                          f"{_num(time_ref[row])} s)")
        return ref


# ---------------------------------------------------------------------------------------
# public API


def read_measurements(path: str | os.PathLike[str],
                      origin: tuple[float, float, float] | None = None) -> MeasurementSet:
    """Read a measurement file (``.csv``, ``.parquet`` or ``.pq``) into a MeasurementSet.

    Every cell is checked against the contract of ``docs/file-format.md``; all problems are
    reported together in one :class:`MeasurementFileError` naming row, line and column.
    Rows stay in file order.  ``origin`` = (lat, lon, alt) is the ENU origin for files that
    give ``sensor_lat``/``sensor_lon``; it wins over ``origin_*`` metadata in the file and
    is recorded in the returned set's metadata.
    """
    path = Path(path)
    fmt = _file_format(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    raw = _load_csv(path) if fmt == "csv" else _load_parquet(path)
    return _Checker(path, raw, origin).run()


def _columns(ms: MeasurementSet) -> dict[str, NDArray[Any]]:
    cols: dict[str, NDArray[Any]] = {
        "time": ms.time, "sensor": ms.sensor, "kind": ms.kind, "value": ms.value,
        "sigma": ms.sigma}
    for i, c in enumerate(SENSOR_STATE_COLUMNS):
        cols[c] = ms.sensor_state[:, i]
    cols["time_ref"] = ms.time_ref
    if np.any(ms.kind == _RANGE_DIFFERENCE):
        for i, c in enumerate(REF_STATE_COLUMNS):
            cols[c] = ms.ref_sensor_state[:, i]
    return cols


def _csv_metadata_line(path: Path, key: str, value: str) -> str:
    if not key or key != key.strip() or any(ch in key for ch in ":\r\n"):
        raise ValueError(f"{path}: metadata key {key!r} cannot be written to a CSV comment "
                         "line (keys are non-empty, without ':', line breaks or surrounding "
                         "spaces)")
    if "\n" in value or "\r" in value:
        raise ValueError(f"{path}: metadata value of {key!r} contains a line break; CSV "
                         "metadata lines hold one line each")
    if value != value.strip():
        raise ValueError(f"{path}: metadata value of {key!r} has leading or trailing spaces, "
                         "which a CSV comment line does not keep")
    return f"# {key}: {value}\n" if value else f"# {key}:\n"


def _write_csv(ms: MeasurementSet, path: Path, f: io.TextIOBase) -> None:
    import pandas as pd

    f.write(FORMAT_LINE + "\n")
    for key, value in ms.metadata.items():
        f.write(_csv_metadata_line(path, key, value))
    frame = pd.DataFrame(_columns(ms))
    frame.to_csv(f, index=False, na_rep="", lineterminator="\n")
    f.flush()
    os.fsync(f.fileno())


def _write_parquet(ms: MeasurementSet, tmp: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays, fields = [], []
    for name, values in _columns(ms).items():
        if name in ("sensor", "kind"):
            arrays.append(pa.array(values.tolist(), type=pa.string()))
            fields.append(pa.field(name, pa.string(), nullable=False))
        else:
            arrays.append(pa.array(values, type=pa.float64()))
            fields.append(pa.field(name, pa.float64()))
    metadata = {b"tmakit": b"measurements v1"}
    metadata.update({(PARQUET_METADATA_PREFIX + k).encode(): v.encode()
                     for k, v in ms.metadata.items()})
    table = pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=metadata))
    pq.write_table(table, tmp)
    with open(tmp, "rb+") as f:
        os.fsync(f.fileno())


def write_measurements(ms: MeasurementSet, path: str | os.PathLike[str],
                       force: bool = False) -> Path:
    """Write a MeasurementSet as CSV or Parquet (by the suffix of ``path``); return the path.

    An existing file is kept (``FileExistsError``) unless ``force``.  The file is written to
    a temporary file in the same folder and then moved into place, so a failure never leaves
    a partial file nor damages an existing one.  Reading the file back gives an equal set
    (:meth:`MeasurementSet.equals`).
    """
    path = Path(path)
    try:
        fmt = _file_format(path)
    except MeasurementFileError:
        raise ValueError(
            f"{path}: cannot write measurements to a '{path.suffix}' file; the name must end "
            f"in {', '.join(CSV_SUFFIXES + PARQUET_SUFFIXES)} (CSV or Parquet)") from None
    with _written_in_place(path, force) as tmp:
        if fmt == "csv":
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                _write_csv(ms, path, f)
        else:
            _write_parquet(ms, tmp)
    return path


def _exists_error(path: Path) -> FileExistsError:
    return FileExistsError(f"{path} already exists; use --force (force=True) to overwrite it")


@contextlib.contextmanager
def _written_in_place(path: Path, force: bool) -> Iterator[Path]:
    """Write ``path`` safely: refuse an existing file (``FileExistsError``) unless ``force``
    and a folder (``IsADirectoryError``); yield a new empty temporary file in the same folder
    for the caller to write, then move it into place (:func:`_move_into_place`).  On any
    failure the temporary file is removed and ``path`` is left as it was."""
    if path.exists() and not force:
        raise _exists_error(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a folder, not a file")
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    try:
        yield tmp
        _move_into_place(tmp, path, force)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def _move_into_place(tmp: Path, path: Path, force: bool) -> None:
    if force:
        os.replace(tmp, path)
        return
    try:  # atomic "create only if absent": a hard link fails if the name exists
        os.link(tmp, path)
    except FileExistsError:
        raise _exists_error(path) from None
    except OSError:  # no hard links on this file system
        if path.exists():
            raise _exists_error(path) from None
        os.replace(tmp, path)
        return
    tmp.unlink()


#: The atomic-write helper under a public name, for the other writers of :mod:`tmakit.io`.
written_in_place = _written_in_place
