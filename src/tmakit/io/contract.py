"""The measurement-file contract: its columns as data, a raw table as read, and the problems in it.

The contract itself (columns, units, rules) is written in ``docs/file-format.md``; a problem names
the row, line and column, and what was expected and found there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["COLUMN_ORDER", "COLUMN_PURPOSE", "FORMAT_LINE", "GEO_COLUMNS", "NUMERIC_COLUMNS",
           "PARQUET_METADATA_PREFIX", "Problems", "RawTable", "between_sensor_kinds", "blank_mask",
           "file_columns", "is_blank", "number_text", "reference_kinds", "reference_kinds_text",
           "show", "text_column"]


#: First line of every CSV file tmakit writes.
FORMAT_LINE = "# tmakit measurements v1"
#: Prefix of tmakit's keys in the Arrow schema metadata of Parquet files.
PARQUET_METADATA_PREFIX = "tmakit:"
#: Column order of written files (the ``ref_sensor_*`` columns follow when the set has
#: range differences).
COLUMN_ORDER = ("time", "sensor", "kind", "value", "sigma", *SENSOR_STATE_COLUMNS,
                "time_ref")
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
    """Return the columns to write, in :data:`~tmakit.io.contract.COLUMN_ORDER` (file units)."""
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
        wanted = set(columns)
        for row, column in self.cells:
            if column in wanted:
                mask[row] = True
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
        return number_text(float(v))
    try:
        if v != v:
            return "an empty cell"
    except (TypeError, ValueError):
        pass
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
    out = np.empty(len(series), dtype=object)
    for i, v in enumerate(series.tolist()):
        out[i] = "" if is_blank(v) else str(v)
    return out
