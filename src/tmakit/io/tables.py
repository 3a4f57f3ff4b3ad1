"""The one table writer: a table of columns as CSV or Parquet, written atomically."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .atomic import atomic_write, fsync_file

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import pyarrow as pa

__all__ = ["TABLE_SUFFIXES", "table_format", "write_table"]

#: The table formats by file suffix (lower case).
TABLE_SUFFIXES: dict[str, str] = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def table_format(path: str | os.PathLike[str]) -> str | None:
    """Return the table format of ``path`` by its suffix: ``"csv"``, ``"parquet"`` or ``None``.

    Parameters
    ----------
    path : str or os.PathLike
        The file name.

    Returns
    -------
    str or None
        The format name, ``None`` for a suffix that names no table format.
    """
    return TABLE_SUFFIXES.get(Path(path).suffix.lower())


def write_table(path: str | os.PathLike[str], table: pd.DataFrame | Mapping[str, Any], *,
                format: str | None = None, force: bool = False, what: str = "a table",
                csv_preamble: Sequence[str] = (),
                parquet_metadata: Mapping[str, str] | None = None,
                parquet_schema: pa.Schema | None = None) -> Path:
    """Write a table as CSV or Parquet, atomically (:func:`tmakit.io.atomic.atomic_write`).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    table : pandas.DataFrame or mapping of str to array_like
        The columns, in order.
    format : {"csv", "parquet"}, optional
        The format; by default from the suffix of ``path`` (:data:`TABLE_SUFFIXES`).
    force : bool, optional
        Overwrite an existing file (default: refuse with ``FileExistsError``).
    what : str, optional
        What the table is, for the message about a wrong suffix ("a track").
    csv_preamble : sequence of str, optional
        Lines written before the CSV header (each without its line end).
    parquet_metadata : mapping of str to str, optional
        Keys and values added to the Arrow schema metadata of a Parquet file.
    parquet_schema : pyarrow.Schema, optional
        The Arrow schema of a Parquet file; when given, the file carries only this schema and
        ``parquet_metadata`` (no pandas metadata). By default the types come from pandas and pandas'
        metadata is kept. With a schema, ``table`` is read column by column (NaN is written as NaN,
        not as a null).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If the format is not given and the suffix names no table format.
    FileExistsError
        If ``path`` exists and not ``force``.
    """
    import pandas as pd

    path = Path(path)
    fmt = format or table_format(path)
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"{path}: {what} is written as .csv or .parquet, not "
                         f"{path.suffix or 'a file without suffix'}")
    with atomic_write(path, force) as tmp:
        if fmt == "csv":
            _write_csv(pd.DataFrame(table), tmp, csv_preamble)
        else:
            _write_parquet(table, tmp, parquet_metadata or {}, parquet_schema)
    return path


def _write_csv(frame: pd.DataFrame, tmp: Path, preamble: Sequence[str]) -> None:
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        for line in preamble:
            f.write(line + "\n")
        frame.to_csv(f, index=False, na_rep="", lineterminator="\n")
        f.flush()
        os.fsync(f.fileno())


def _write_parquet(table: pd.DataFrame | Mapping[str, Any], tmp: Path,
                   metadata: Mapping[str, str], schema: pa.Schema | None) -> None:
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    meta = {k.encode(): v.encode() for k, v in metadata.items()}
    if schema is None:
        arrow = pa.Table.from_pandas(pd.DataFrame(table), preserve_index=False)
        meta = {**(arrow.schema.metadata or {}), **meta}
    else:  # column by column: NaN stays NaN (pandas would write nulls)
        arrow = pa.Table.from_arrays(
            [_arrow_column(table[f.name], f.type) for f in schema], schema=schema)
    pq.write_table(arrow.replace_schema_metadata(meta), tmp)
    fsync_file(tmp)


def _arrow_column(values: Any, kind: pa.DataType) -> pa.Array:
    import pyarrow as pa

    if pa.types.is_string(kind):
        return pa.array(np.asarray(values).tolist(), type=kind)
    return pa.array(np.asarray(values), type=kind)
