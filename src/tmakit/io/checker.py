"""The measurement-file contract, and a raw table checked against it into a MeasurementSet.

The contract (columns, units, rules) is written in ``docs/file-format.md``.  A raw table's columns
are checked against what its rows need (numbers coerced by pandera), every cell by its rule and
the rows across each other; the sensor states come from ENU or latitude/longitude columns, and a
range difference's state at ``time_ref`` from the sensor's own rows (interpolated as
:class:`tmakit.sensors.RecordedTrack` does).  Every problem names row, line and column, and all
are reported together.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS
from ..measurements.codes import KIND_CODES
from ..rules import (
    FINITE,
    broken_rows,
    check_set,
    decreasing_times,
    duplicate_rows,
    far_times,
    metadata_problems,
)
from .errors import MeasurementFileError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["COLUMN_ORDER", "COLUMN_PURPOSE", "FORMAT_LINE", "GEO_COLUMNS", "NUMERIC_COLUMNS",
           "ORIGIN_KEYS", "PARQUET_METADATA_PREFIX", "QUERY_ROWS", "Layout", "Problems",
           "RawTable", "SensorRecord", "between_sensor_kinds", "blank_mask", "check_cells",
           "check_columns", "check_order", "check_table", "fdoa_carriers", "file_columns",
           "geodetic_to_enu_in_place", "is_blank", "kind_code_table", "number_text", "read_numbers",
           "ref_of_sensor", "ref_sensor_state", "reference_kinds", "reference_kinds_text",
           "reference_problems",
           "resolve_origin", "sensor_state", "show", "text_column"]


#: First line of every CSV file tmakit writes.
FORMAT_LINE = "# tmakit measurements v1"
#: Prefix of tmakit's keys in the Arrow schema metadata of Parquet files.
PARQUET_METADATA_PREFIX = "tmakit:"
#: Column order of written files (the ``ref_sensor_*`` columns follow when the set has
#: range differences).
COLUMN_ORDER = ("time", "sensor", "kind", "value", "sigma", *SENSOR_STATE_COLUMNS, "time_ref")
#: Sensor position as latitude (deg), longitude (deg) and altitude (m, WGS-84).
GEO_COLUMNS = ("sensor_lat", "sensor_lon", "sensor_alt")
#: Columns read as numbers (float64, NaN for an empty cell).
NUMERIC_COLUMNS = ("time", "value", "sigma", *SENSOR_STATE_COLUMNS, *GEO_COLUMNS,
                   "time_ref", *REF_STATE_COLUMNS, "carrier")


def reference_kinds() -> tuple[str, ...]:
    """Name the kinds whose rows carry ``time_ref`` and a reference sensor state."""
    return tuple(k for k, cls in KINDS.items() if cls.uses_reference)


def between_sensor_kinds() -> tuple[str, ...]:
    """Name the kinds that are differences between two sensors at one time."""
    return tuple(k for k, cls in KINDS.items() if cls.between_sensors)


def reference_kinds_text() -> str:
    """Name the reference kinds for messages."""
    return " / ".join(reference_kinds())

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
    "time_ref": "time of the earlier sample of a range difference, or the row's own time "
                "for a tdoa or fdoa (s)",
    **{c: f"reference sensor {_AXES[c.removeprefix('ref_sensor_')]} at time_ref"
       for c in REF_STATE_COLUMNS},
    "ref_sensor": "the reference sensor of a tdoa or fdoa row (a sensor id)",
    "carrier": "an fdoa row's carrier (Hz)",
}


def file_columns(ms: MeasurementSet) -> dict[str, NDArray[Any]]:
    """Return the columns to write, in :data:`COLUMN_ORDER` (file units)."""
    cols: dict[str, NDArray[Any]] = {
        "time": ms.time, "sensor": ms.sensor, "kind": ms.kind, "value": ms.value,
        "sigma": ms.sigma}
    for i, c in enumerate(SENSOR_STATE_COLUMNS):
        cols[c] = ms.sensor_state[:, i]
    cols["time_ref"] = ms.time_ref
    if any(np.any(ms.kind_mask(k)) for k in reference_kinds()):
        for i, c in enumerate(REF_STATE_COLUMNS):
            cols[c] = ms.ref_sensor_state[:, i]
    if ms.tonal is not None:  # each frequency row's tonal (its own f0)
        cols["tonal"] = ms.tonal
    return cols


@dataclass
class RawTable:
    """A file's table as read, before checking: text cells for CSV, typed for Parquet."""

    frame: pd.DataFrame  # The cells, one column per header name
    #: The file's metadata (``# key: value`` lines of a CSV file, ``tmakit:`` keys of the Parquet
    #: schema)
    metadata: dict[str, str]
    #: Line of each data row in the CSV file (1-based), or None (Parquet)
    lines: NDArray[np.int64] | None


@dataclass
class Problems:
    """The problems found in one raw table: file-wide ones, and one per cell at most."""

    raw: RawTable
    file: list[str] = field(default_factory=list)  # The file-wide problems
    #: The problem of each (0-based row, column) cell
    cells: dict[tuple[int, str], str] = field(default_factory=dict)

    def where(self, row: int) -> str:
        """Say where a row is: ``row R (line L)`` (``row R`` without line numbers)."""
        lines = self.raw.lines
        if lines is None:
            return f"row {row + 1}"
        return f"row {row + 1} (line {lines[row]})"

    def cell(self, row: int, column: str, expected: str, found: str | None = None) -> None:
        """Record a problem at one cell (the first problem of a cell wins)."""
        if (row, column) in self.cells:
            return
        frame = self.raw.frame
        if found is None:
            found = show(frame[column].iat[row]) if column in frame else "nothing"
        self.cells[(row, column)] = (
            f"{self.where(row)}, column '{column}': expected {expected}, found {found}")

    def missing(self, column: str, extra: str = "") -> None:
        """Record that a column of the contract is missing."""
        self.file.append(f"column '{column}' is missing: {COLUMN_PURPOSE[column]}{extra}")

    def bad_rows(self, *columns: str) -> NDArray[np.bool_]:
        """Mark the rows with a problem in one of ``columns``."""
        mask = np.zeros(len(self.raw.frame), dtype=bool)
        mask[[row for row, column in self.cells if column in columns]] = True
        return mask

    def sorted(self) -> list[str]:
        """List the problems: file-wide first, then cells by row and column order."""
        order = {c: i for i, c in enumerate(self.raw.frame.columns)}
        cells = sorted(self.cells.items(),
                       key=lambda item: (item[0][0], order.get(item[0][1], len(order))))
        return self.file + [p for _, p in cells]


def number_text(x: float) -> str:
    """Format a number for messages: shortest exact representation, no trailing '.0'."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def is_blank(v: Any) -> bool:
    """Whether a cell is empty: ``None``, NaN or NA, or text that is only spaces."""
    if v is None:
        return True
    if isinstance(v, str):
        return v.strip() == ""
    try:
        return bool(v != v)  # NaN and pandas NA-likes
    except (TypeError, ValueError):
        return False


def show(v: Any) -> str:
    """Format a cell value for "found ..." in messages."""
    if is_blank(v):
        return "an empty cell (NaN)" if isinstance(v, float | np.floating) else "an empty cell"
    if isinstance(v, str):
        try:
            float(v)
        except ValueError:
            return repr(v)
        return v.strip()
    if isinstance(v, bool | np.bool_):
        return repr(bool(v))
    if isinstance(v, float | int | np.floating | np.integer):
        return number_text(float(v))
    return repr(v)


def blank_mask(series: pd.Series) -> NDArray[np.bool_]:
    """Empty cells of a column: NaN/None/NA, or text that is only spaces."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):
        return (series.str.strip() == "").fillna(True).to_numpy(dtype=bool)
    return series.map(is_blank).to_numpy(dtype=bool)


def text_column(series: pd.Series) -> NDArray[np.object_]:
    """Cells of a text column as Python str ('' for empty), ids like 1 kept as '1'."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):  # one str object per distinct id, shared
        codes, uniques = pd.factorize(series.fillna(""))
        return np.asarray(uniques, dtype=object)[codes]
    return np.array(["" if is_blank(v) else str(v) for v in series.tolist()], dtype=object)


#: How a caller of the library gives the ENU origin (the command line replaces it with its flag).
ORIGIN_HINT = "origin=(lat, lon, alt) to read_measurements"


Numbers = dict[str, NDArray[np.float64]]
#: Metadata keys of the ENU origin (degrees, degrees, metres).
ORIGIN_KEYS = ("origin_lat", "origin_lon", "origin_alt")
#: Rows converted from latitude/longitude to ENU at a time (bounds the conversion's arrays).
_ENU_ROWS = 1 << 16


@dataclass(frozen=True)
class Layout:
    """How a file gives the sensor state."""

    geodetic: bool  # Positions as ``sensor_lat``/``sensor_lon`` (degrees) instead of ENU metres
    has_velocity: bool  # The file has both ``sensor_vx`` and ``sensor_vy``
    has_ref: bool  # The file has ``ref_sensor_*`` columns


def resolve_origin(origin: Any, metadata: Mapping[str, str], problems: Problems
                   ) -> tuple[tuple[float, float, float] | None, dict[str, str]]:
    """Return the ENU origin (lat, lon in deg, alt in m): the argument, else the file's."""
    if origin is not None:
        try:
            lat, lon, alt = (float(v) for v in origin)
        except (TypeError, ValueError):
            problems.file.append(f"origin {origin!r}: expected (lat, lon, alt) in degrees, "
                                 "degrees, metres")
            return None, {}
        return (lat, lon, alt), {k: repr(v) for k, v in
                                 zip(ORIGIN_KEYS, (lat, lon, alt), strict=True)}
    if "origin_lat" not in metadata and "origin_lon" not in metadata:
        problems.file.append(
            "sensor positions are given as sensor_lat/sensor_lon but no ENU origin is "
            f"known: pass {ORIGIN_HINT} or add metadata lines "
            "'# origin_lat: ...', '# origin_lon: ...', '# origin_alt: ...'")
        return None, {}
    values = []
    for key in ORIGIN_KEYS:
        text = metadata.get(key, "0" if key == "origin_alt" else "")
        try:
            values.append(float(text))
        except ValueError:
            if text:
                unit = "metres" if key == "origin_alt" else "degrees"
                problems.file.append(
                    f"metadata '{key}': expected a number ({unit}), found {text!r}")
            else:
                problems.file.append(
                    f"metadata '{key}' is missing: the ENU origin needs origin_lat and "
                    "origin_lon (and origin_alt)")
            return None, {}
    return (values[0], values[1], values[2]), {}


def sensor_state(num: Numbers, layout: Layout, origin: Any, problems: Problems
                 ) -> tuple[NDArray[np.float64], dict[str, str]]:
    """Each row's sensor ENU state ``(n, 6)`` (m, m/s), NaN where unknown."""
    n = len(problems.raw.frame)
    zeros = np.zeros(n)
    state = np.full((n, 6), np.nan)
    origin_metadata: dict[str, str] = {}
    if layout.geodetic:
        if "sensor_lat" in num and "sensor_lon" in num:
            enu_origin, origin_metadata = resolve_origin(origin, problems.raw.metadata, problems)
            if enu_origin is not None:
                rule = _geodetic_positions(num, enu_origin, state, problems)
                if rule:
                    origin_metadata["dim_rule"] = rule
    else:
        for i, c in enumerate(("sensor_x", "sensor_y", "sensor_z")):
            state[:, i] = num.get(c, zeros if c == "sensor_z" else np.full(n, np.nan))
    for i, c in enumerate(("sensor_vx", "sensor_vy", "sensor_vz"), start=3):
        state[:, i] = num.get(c, zeros)
    return state, origin_metadata


def _geodetic_positions(num: Numbers, origin: tuple[float, float, float],
                        state: NDArray[np.float64], problems: Problems) -> str:
    """Fill ENU positions from lat/lon/alt; return the surface rule's text if it flattened."""
    state[:, 0], state[:, 1] = num["sensor_lat"], num["sensor_lon"]
    state[:, 2] = num.get("sensor_alt", origin[2])
    state[problems.bad_rows(*GEO_COLUMNS), :3] = np.nan  # pymap3d refuses |lat| > 90
    try:
        return geodetic_to_enu_in_place(state, origin,
                                        problems.raw.metadata.get("dim", "").strip() == "3")
    except ValueError as err:
        state[:, :3] = np.nan
        problems.file.append(f"origin {origin}: {err}")
        return ""


def geodetic_to_enu_in_place(state: NDArray[np.float64], origin: tuple[float, float, float],
                             dim3: bool) -> str:
    """Convert ``state[:, :3]`` from lat/lon/alt to ENU in place; return the surface rule's text."""
    from ..core.geodesy import geodetic_to_enu
    from .logs import surface_dim

    n, alt0 = state.shape[0], origin[2]
    worst, spread = alt0, -1.0  # the altitude farthest from the origin's
    for lo in range(0, n, _ENU_ROWS):
        off = np.nan_to_num(np.abs(state[lo:lo + _ENU_ROWS, 2] - alt0), nan=-1.0)
        i = int(np.argmax(off))
        if off[i] > spread:
            worst, spread = float(state[lo + i, 2]), float(off[i])
    dim, rule = surface_dim(np.array([worst]), alt0, 3 if dim3 else None)
    for lo in range(0, n, _ENU_ROWS):
        block = state[lo:lo + _ENU_ROWS]
        alt = block[:, 2] if dim == 3 else np.where(np.isfinite(block[:, 2]), alt0, np.nan)
        with np.errstate(invalid="ignore"):
            e, nn, u = geodetic_to_enu(block[:, 0], block[:, 1], alt, origin)
        block[:, 0], block[:, 1], block[:, 2] = e, nn, (0.0 * u if dim == 2 else u)
    return rule if dim == 2 else ""


def ref_sensor_state(num: Numbers, state: NDArray[np.float64], sensor: NDArray[np.object_],
                     is_rd: NDArray[np.bool_], ref_given: NDArray[np.bool_], layout: Layout,
                     problems: Problems, ref_name: NDArray[np.object_] | None = None,
                     named: NDArray[np.bool_] | None = None) -> NDArray[np.float64]:
    """Give the state at time_ref ``(n, 6)`` of range differences and ``named`` tdoa/fdoa rows."""
    n = state.shape[0]
    ref = np.full((n, 6), np.nan)
    for i, c in enumerate(REF_STATE_COLUMNS):
        col = num.get(c, np.zeros(n) if i >= 2 else np.full(n, np.nan))
        given = ref_given if named is None else ref_given & ~named
        ref[given, i] = col[given]
    if "time" not in num or ("time_ref" not in num and named is None):
        return ref
    time_ref = num.get("time_ref", num["time"])
    need = (is_rd & ~ref_given & np.isfinite(time_ref)
            & ~problems.bad_rows("time", "sensor", "time_ref"))
    if named is not None:
        named = named & ~problems.bad_rows("time", "ref_sensor")
    if not np.any(need) and (named is None or not np.any(named)):
        return ref
    state_cols = [c for c in (*SENSOR_STATE_COLUMNS, *GEO_COLUMNS) if c in num]
    usable = (~problems.bad_rows("time", "sensor", *state_cols)
              & np.all(np.isfinite(state), axis=1))
    if not np.any(usable):  # no position at all (no origin, bad cells): reported already
        return ref
    for s in dict.fromkeys(sensor[need]):
        ref_of_sensor(s, np.flatnonzero(need & (sensor == s)),
                       np.flatnonzero(usable & (sensor == s)), num["time"], time_ref, state,
                       ref, layout.has_velocity, problems)
    if named is not None and ref_name is not None:
        for s in dict.fromkeys(ref_name[named]):
            ref_of_sensor(s, np.flatnonzero(named & (ref_name == s)),
                           np.flatnonzero(usable & (sensor == s)), num["time"], num["time"],
                           state, ref, layout.has_velocity, problems, "ref_sensor")
    return ref


def fdoa_carriers(num: Numbers, kind: NDArray[np.object_], metadata: Mapping[str, str],
                  problems: Problems) -> dict[str, str]:
    """Scale fdoa rows of their own ``carrier`` to the file's one; return the metadata to add."""
    # FDOA is -(f / c) times the range-rate difference: a row at carrier f is the row carrier F
    # would give times F / f (the file's fdoa_carrier, else the first row's)
    if "carrier" not in num:
        return {}
    own = num["carrier"]
    rows = np.flatnonzero((kind == "fdoa") & np.isfinite(own) & (own > 0))
    stated = metadata.get("fdoa_carrier", "").strip()
    try:
        common = float(stated) if stated else (float(own[rows[0]]) if rows.size else None)
    except ValueError:
        return {}  # refused by the metadata's own check
    if common is None:
        return {}
    for row in np.flatnonzero((kind == "fdoa") & np.isnan(own)) if not stated else ():
        problems.cell(int(row), "carrier", "a carrier (Hz): other fdoa rows give theirs and "
                      "the file states no fdoa_carrier")
    scale = common / own[rows]
    for c in ("value", "sigma"):
        if c in num:
            num[c][rows] *= scale
    return {"fdoa_carrier": repr(common)}


def ref_of_sensor(sensor: str, rows: NDArray[np.intp], mine: NDArray[np.intp] | None,
                  t: NDArray[np.float64], time_ref: NDArray[np.float64],
                  state: NDArray[np.float64], ref: NDArray[np.float64], has_velocity: bool,
                  problems: Problems, column: str = "time_ref") -> None:
    """Fill ``ref[rows]`` from the sensor's usable rows ``mine`` (exact time, else interpolated)."""
    record = SensorRecord(t, state, mine, has_velocity)
    missing = record.fill(rows, time_ref, ref)
    if not np.any(missing):
        return
    times = record.times
    known = (f"its rows span {number_text(times[0])} to {number_text(times[-1])} s"
             if times.shape[0] > 0 else "it has no other usable rows")
    for row in rows[missing]:
        at = number_text(time_ref[row])
        if column == "ref_sensor":
            problems.cell(int(row), column, f"a sensor whose position at the row's time is "
                          f"known ('{sensor}': {known}; or give the ref_sensor_* columns)",
                          f"{sensor} (no position of it known at {at} s)")
        else:
            problems.cell(int(row), column,
                          f"a time at which sensor '{sensor}' has a known position ({known}; "
                          "or give the ref_sensor_* columns)",
                          f"{at} (no sensor position known at time_ref {at} s)")


#: Times looked up at a time (bounds the temporaries of a look-up: about 100 bytes each).
QUERY_ROWS = 1 << 16


def _non_decreasing(t: NDArray[np.float64]) -> bool:
    """Tell whether ``t`` never decreases (NaN: no), checked a block at a time."""
    for lo in range(0, max(t.shape[0] - 1, 0), QUERY_ROWS):
        seg = t[lo:lo + QUERY_ROWS + 1]
        if not np.all(seg[1:] >= seg[:-1]):
            return False
    return True


class SensorRecord:
    """A sensor's usable rows ``mine`` (None: all) in time order, to look its state up."""

    def __init__(self, t: NDArray[np.float64], state: NDArray[np.float64],
                 mine: NDArray[np.intp] | None, has_velocity: bool) -> None:
        times = t if mine is None else t[mine]
        self.state, self.has_velocity = state, has_velocity
        # row of the file of each entry of self.times (None: the entry's own index)
        self.index: NDArray[np.intp] | None = mine
        if not _non_decreasing(times):  # one entry per time (the first row), in time order
            times, first = np.unique(times, return_index=True)
            self.index = first if mine is None else mine[first]
        #: The sensor's times (s), non-decreasing (a time may repeat).
        self.times: NDArray[np.float64] = times
        self._spline: Any = None

    def _rows(self, k: NDArray[np.intp]) -> NDArray[np.intp]:
        """Give the file rows of entries ``k`` of :attr:`times`."""
        return k if self.index is None else self.index[k]

    def fill(self, rows: NDArray[np.intp], time_ref: NDArray[np.float64],
             ref: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Fill ``ref[rows]`` with the state at ``time_ref[rows]``; flag rows without one."""
        missing = np.ones(rows.shape[0], dtype=bool)
        m = self.times.shape[0]
        if m == 0:
            return missing
        for lo in range(0, rows.shape[0], QUERY_ROWS):
            r = rows[lo:lo + QUERY_ROWS]
            tr = time_ref[r]
            at = np.searchsorted(self.times, tr)  # the first entry at or after time_ref
            found = self.times[np.minimum(at, m - 1)] == tr
            ref[r[found]] = self.state[self._rows(at[found])]
            inside = ~found & (tr >= self.times[0]) & (tr <= self.times[-1])
            if np.any(inside):
                ref[r[inside]] = self._between(at[inside], tr[inside])
            missing[lo:lo + QUERY_ROWS] = ~found & ~inside
        return missing

    def _between(self, at: NDArray[np.intp], tr: NDArray[np.float64]) -> NDArray[np.float64]:
        """Interpolate at times ``tr`` strictly between entries ``at - 1`` and ``at``."""
        from ..sensors import RecordedTrack

        if self.has_velocity:  # cubic Hermite: each piece from its two rows only
            before = np.searchsorted(self.times, self.times[at - 1])  # first of that time
            k = np.unique(np.concatenate((before, at)))
            rows = self._rows(k)
            return RecordedTrack(self.times[k], self.state[rows, :3],
                                 self.state[rows, 3:]).states(tr)
        if self._spline is None:  # a spline through every distinct time
            t = self.times
            k = np.flatnonzero(np.concatenate(([True], t[1:] != t[:-1])))
            self._spline = RecordedTrack(t[k], self.state[self._rows(k), :3])
        out = self._spline.states(tr)
        out[:, 3:] = 0.0  # like the sensor velocities, absent from the file
        return out


def check_table(path: str | os.PathLike[str], raw: RawTable,
                origin: tuple[float, float, float] | None = None) -> MeasurementSet:
    """Check a raw table against the contract of ``docs/file-format.md`` and build the set."""
    frame, n = raw.frame, len(raw.frame)
    problems = Problems(raw)
    has = set(frame.columns).__contains__
    sensor = (text_column(frame["sensor"]) if has("sensor") else np.full(n, "", dtype=object))
    kind = (_stripped(text_column(frame["kind"])) if has("kind") else np.full(n, "", dtype=object))
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
    meta: dict[str, Any] = {**raw.metadata, **origin_metadata, **meta_carrier}
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


def case_problem(columns: Collection[str]) -> str | None:
    """Say which columns are tmakit's in another case (names are matched exactly), or None."""
    known = {*COLUMN_ORDER, *GEO_COLUMNS, *REF_STATE_COLUMNS, "ref_sensor", "carrier", "tonal"}
    cased = [c for c in columns if c != c.lower() and c.lower() in known
             and c.lower() not in columns]
    if not cased:
        return None
    return ("column names are lower case in tmakit's measurement file: rename "
            + ", ".join(f"{c!r} to {c.lower()!r}" for c in cased[:6])
            + (f" (and {len(cased) - 6} more)" if len(cased) > 6 else ""))


def check_columns(columns: Collection[str], kinds: list[str], problems: Problems) -> Layout:
    """Record missing or conflicting columns, given the kinds present in the file."""
    has = set(columns).__contains__
    core = ("time", "sensor", "kind", "value", "sigma")
    if not any(map(has, core)):
        problems.file.append(
            "none of the columns of tmakit's measurement file: a wide log (a row per time, a "
            "column per measurement) is read with a column mapping (--mapping MAP.toml; "
            "tma import wide LOG --guess proposes one: docs/your-own-data.md), and tmakit's "
            "own file separates its columns by commas")
    for c in core:
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
                problems.missing(c, f" ({', '.join(ref)} {'is' if len(ref) == 1 else 'are'} given)")
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


def check_cells(frame: pd.DataFrame, num: Numbers, kind: NDArray[np.object_],
                is_rd: NDArray[np.bool_], problems: Problems,
                ref_name: NDArray[np.object_] | None = None) -> NDArray[np.bool_]:
    """Check every cell against the per-cell rules; record one problem per failing cell."""
    def record(column: str, bad: NDArray[Any], what: Expected) -> None:  # a mask, or rows
        for row in (np.flatnonzero(bad) if bad.dtype == bool else bad).tolist():
            problems.cell(row, column, what(row) if callable(what) else what)

    text = {c: text_column(frame[c]) for c in ("sensor", "kind", "ref_sensor")
            if c in frame.columns}
    if "sensor" in text:
        record("sensor", np.array([s.strip() == "" for s in text["sensor"]], dtype=bool),
               "a sensor id (text)")
    if "kind" in text:
        record("kind", ~np.isin(kind.astype(str), list(KINDS)),  # (stripped, as it is read)
               f"one of the kinds {', '.join(KINDS)}")
    for c in ("time", "value", "sigma", *SENSOR_STATE_COLUMNS, *GEO_COLUMNS):
        if c in num:
            record(c, np.isnan(num[c]), "a number")
    for rule, rows in broken_rows({**num, "kind_code": _kind_codes(kind)}):
        if rule.column is not None:  # (a row's own rule is the set's: MeasurementSet's)
            record(rule.column, rows, rule.expected)
    ref = {c: num[c] for c in REF_STATE_COLUMNS if c in num}
    ref_given = np.zeros(len(frame), dtype=bool)
    for v in ref.values():
        ref_given |= ~np.isnan(v)
    ref_given &= is_rd
    if "kind" not in frame.columns:
        return ref_given
    named = np.zeros(len(frame), dtype=bool) if ref_name is None else ref_name != ""
    between = np.isin(kind, between_sensor_kinds())
    for column, bad, what in reference_problems(
            num.get("time", np.full(len(frame), np.nan)), num.get("time_ref"), kind.__getitem__,
            is_rd, between, ref, named):
        record(column, bad, what)
    if "ref_sensor" in text:  # only on tdoa/fdoa rows, another sensor than the row's
        name = text["ref_sensor"]
        own = text.get("sensor", np.full(kind.shape[0], "", dtype=object))
        record("ref_sensor", np.array([x.strip() != "" for x in name], dtype=bool) & ~between,
               lambda row: "an empty cell: only tdoa and fdoa rows name a reference sensor "
                           f"(this row is {kind[row] or 'of no kind'})")
        record("ref_sensor", np.array([x.strip() == str(o).strip() for x, o in
                                       zip(name, own, strict=True)], dtype=bool),
               lambda row: f"another sensor than the row's own ({own[row]!r})")
    if "carrier" in num:
        carrier = num["carrier"]
        with np.errstate(invalid="ignore"):
            record("carrier", ~np.isnan(carrier) & ~((carrier > 0) & np.isfinite(carrier)),
                   "a carrier frequency > 0 (Hz)")
        record("carrier", ~np.isnan(carrier) & (kind != "fdoa"),
               lambda row: "an empty cell: only fdoa rows have a carrier (this row is "
                           f"{kind[row] or 'of no kind'})")
    return ref_given


def _kind_codes(kind: NDArray[np.object_]) -> NDArray[np.int8]:
    """Give each row's kind code (-1 for no kind or an unknown one)."""
    import pandas as pd

    codes, uniques = pd.factorize(kind)
    return np.append(kind_code_table(uniques), np.int8(-1))[codes]


def kind_code_table(names: Sequence[str]) -> NDArray[np.int8]:
    """Give the code of each kind name (-1 for a text that names no kind)."""
    return np.array([KIND_CODES.get(k, -1) for k in names], dtype=np.int8)


Expected = str | Callable[[int], str]


def reference_problems(time: NDArray[np.float64], time_ref: NDArray[np.float64] | None,
                       kind_of: Callable[[int], str], is_rd: NDArray[np.bool_],
                       between: NDArray[np.bool_], ref: Mapping[str, NDArray[np.float64]],
                       named: NDArray[np.bool_] | None = None
                       ) -> Iterator[tuple[str, NDArray[np.bool_], Expected]]:
    """Give the range-difference cells that break a rule: column, rows, what was expected.

    ``time_ref`` is None without the column, ``ref`` holds the ``ref_sensor_*`` columns given,
    ``named`` flags the rows that name their reference sensor (``ref_sensor``), ``kind_of``
    names a row's kind ('' for none).  The checker reports them cell by cell; the stream
    leaves a block that breaks one to the checker.
    """
    rd_kinds = reference_kinds_text()

    def of_kind(row: int) -> str:
        return kind_of(row) or "of no kind"

    with np.errstate(invalid="ignore"):
        if time_ref is not None:  # present exactly on range differences, finite, before time
            empty = np.isnan(time_ref)
            yield ("time_ref", empty & is_rd,
                   f"a time_ref (s) before time: {rd_kinds} rows need one")
            yield ("time_ref", ~empty & ~is_rd,
                   lambda row: f"an empty cell: only {rd_kinds} rows have a time_ref (this row "
                               f"is {of_kind(row)})")
            yield "time_ref", np.isinf(time_ref), FINITE
            yield ("time_ref", (time_ref >= time) & is_rd & ~between,
                   lambda row: f"a time_ref before time ({number_text(time[row])} s)")
            yield ("time_ref", (time_ref != time) & between & ~empty,
                   lambda row: f"the row's own time ({number_text(time[row])} s): a "
                               f"{kind_of(row)} is between two sensors at one time")
        given = np.zeros(is_rd.shape[0], dtype=bool)  # all or none of a row, finite
        for v in ref.values():
            given |= ~np.isnan(v)
        given &= is_rd
        unnamed = between if named is None else between & ~named
        for c, v in ref.items():
            empty = np.isnan(v)
            yield (c, empty & unnamed,
                   lambda row: f"a number: a {kind_of(row)} row gives its reference sensor's "
                               "state (or names it in ref_sensor)")
            yield (c, ~empty & ~is_rd,
                   lambda row: f"an empty cell: only {rd_kinds} rows have a sensor state at "
                               f"time_ref (this row is {of_kind(row)})")
            yield (c, empty & given, "a number (the other ref_sensor_* cells of this row are "
                                     "given; give all or none)")
            yield c, np.isinf(v), FINITE


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
    code = pd.factorize(sensor[rows])[0]  # codes, not text: equal ids give equal codes
    for prev, row in ((int(rows[p]), int(rows[r])) for p, r in decreasing_times(t[rows], code)):
        problems.cell(row, "time",
                      f"a time >= {number_text(t[prev])} s, the time of the previous row of "
                      f"sensor '{sensor[row]}' ({problems.where(prev)})",
                      f"{number_text(t[row])} (time decreases for sensor '{sensor[row]}')")
    keep = ~problems.bad_rows("kind", "time_ref")[rows]
    rows, code = rows[keep], code[keep]
    if tonal is not None and rows.shape[0]:  # one value per time and tonal
        code = code + pd.factorize(tonal[rows])[0] * (int(code.max()) + 1)
    for row, first in ((int(rows[r]), int(rows[f])) for r, f in
                       duplicate_rows(t[rows], code, pd.factorize(kind[rows])[0], tr[rows])):
        ref = "" if math.isnan(tr[row]) else f", time_ref {number_text(tr[row])}"
        problems.cell(row, "time", "one row per (sensor, kind, time, time_ref)",
                      f"a duplicate of {problems.where(first)} (sensor '{sensor[row]}', "
                      f"kind '{kind[row]}', time {number_text(t[row])}{ref})")
