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
from .tables import atomic_write, write_table

__all__ = [
    "Format",
    "MeasurementFileError",
    "atomic_write",
    "find_format",
    "read_measurements",
    "register_format",
    "registered_formats",
    "unregister_format",
    "write_measurements",
    "write_table",
]
