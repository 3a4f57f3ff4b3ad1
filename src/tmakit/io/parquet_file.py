"""The Parquet measurement file.

The columns of the contract, and metadata under ``tmakit:`` keys of the Arrow schema.
"""

from __future__ import annotations

from pathlib import Path

from ..data import MeasurementSet
from .checker import (
    PARQUET_METADATA_PREFIX,
    RawTable,
    case_problem,
    check_table,
    file_columns,
)
from .errors import MeasurementFileError
from .formats import Format, register_format
from .tables import write_table

__all__ = ["PARQUET", "load_parquet", "read_parquet", "write_parquet"]


def load_parquet(path: Path) -> RawTable:
    """Read a Parquet measurement file as a raw table of typed cells (no line numbers)."""
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
    problems += [cased] if (cased := case_problem(names)) is not None else []
    if problems:
        raise MeasurementFileError(path, problems)
    # (ignore_metadata: an index pandas wrote, df.set_index("time"), is a column as written)
    frame = table.to_pandas(ignore_metadata=True).reset_index(drop=True)
    frame.columns = names
    return RawTable(frame, metadata, None)


def write_parquet(ms: MeasurementSet, path: Path, force: bool) -> None:
    """Write a set as a Parquet measurement file, atomically (the :data:`PARQUET` writer)."""
    import pyarrow as pa

    columns = file_columns(ms)
    fields = [pa.field(name, pa.string(), nullable=False) if name in ("sensor", "kind", "tonal")
              else pa.field(name, pa.float64()) for name in columns]
    metadata = {"tmakit": "measurements v1"}
    # (text, as MeasurementSet keeps it; a value assigned into .metadata since is made so)
    metadata.update({PARQUET_METADATA_PREFIX + str(k): str(v) for k, v in ms.metadata.items()})
    write_table(path, columns, format="parquet", force=force, parquet_metadata=metadata,
                parquet_schema=pa.schema(fields))


def read_parquet(path: Path, *, origin: tuple[float, float, float] | None = None
                 ) -> MeasurementSet:
    """Read and check a Parquet measurement file (the :data:`PARQUET` format's reader)."""
    return check_table(path, load_parquet(path), origin)


#: The Parquet format: ``.parquet`` and ``.pq``.
PARQUET = register_format(Format("parquet", "Parquet", (".parquet", ".pq"), read_parquet,
                                 write_parquet))
