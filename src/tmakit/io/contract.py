"""The measurement-file contract as data: column names, order and purpose; a set's columns.

The contract itself (columns, units, rules) is written in ``docs/file-format.md``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS

__all__ = ["COLUMN_ORDER", "COLUMN_PURPOSE", "FORMAT_LINE", "GEO_COLUMNS", "NUMERIC_COLUMNS",
           "PARQUET_METADATA_PREFIX", "between_sensor_kinds", "file_columns", "reference_kinds",
           "reference_kinds_text"]


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
    from ..measurements import KINDS

    return tuple(k for k, cls in KINDS.items() if cls.uses_reference)


def between_sensor_kinds() -> tuple[str, ...]:
    """Name the kinds that are differences between two sensors at one time."""
    from ..measurements import KINDS

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
