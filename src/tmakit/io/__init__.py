"""Input and output: measurement files by format, the one table writer, atomic writes.

- :mod:`.formats`: the registry of measurement-file formats (:class:`Format`,
  :func:`register_format`); :mod:`.csv_file` and :mod:`.parquet_file` register CSV and Parquet.
- :mod:`.measurement_files`: :func:`read_measurements` and :func:`write_measurements`, which
  dispatch through the registry.
- :mod:`.checker` and its steps (:mod:`.check_columns`, :mod:`.check_cells`,
  :mod:`.check_rows`, :mod:`.positions`): a raw table checked against the file contract.
- :mod:`.tables`: :func:`write_table`, the one CSV/Parquet table writer.
- :mod:`.atomic`: :func:`atomic_write`, the one safe-write helper.

pandas, pyarrow and pandera are imported on first use.
"""

from __future__ import annotations

from .atomic import atomic_write, exists_error
from .errors import MeasurementFileError
from .formats import (
    Format,
    find_format,
    register_format,
    registered_formats,
    unregister_format,
)
from .measurement_files import read_measurements, write_measurements
from .tables import TABLE_SUFFIXES, table_format, write_table

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
