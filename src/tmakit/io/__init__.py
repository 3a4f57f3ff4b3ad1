"""Input and output: measurement files by format, the one table writer, atomic writes."""

from __future__ import annotations

from .errors import MeasurementFileError
from .formats import (
    Format,
    find_format,
    register_format,
    registered_formats,
    unregister_format,
)
from .measurement_files import read_measurements, write_measurements
from .tables import TABLE_SUFFIXES, atomic_write, exists_error, table_format, write_table

__all__ = [
    "TABLE_SUFFIXES",
    "Format",
    "MeasurementFileError",
    "atomic_write",
    "exists_error",
    "find_format",
    "read_measurements",
    "register_format",
    "registered_formats",
    "table_format",
    "unregister_format",
    "write_measurements",
    "write_table",
]
