"""Writing files: atomically (a temporary file moved into place), and tables as CSV or Parquet."""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import pyarrow as pa

    from ..montecarlo.closed_loop import ClosedLoopStudy, LoopChunk

__all__ = ["TABLE_SUFFIXES", "TEMP_PATTERN", "LoopCheckpoint", "atomic_write",
           "clean_stale_temporaries", "exists_error", "fsync_file", "table_format", "write_table"]

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no advisory locks, stale files stay
    fcntl = None  # type: ignore[assignment]


#: The names of tmakit's temporary files: ``.NAME.<12 hex digits>.tmp[.suffix]``.
TEMP_PATTERN = re.compile(r"^\..+\.[0-9a-f]{12}\.tmp(\.[A-Za-z0-9]{1,8})?$")


def exists_error(path: str | os.PathLike[str]) -> FileExistsError:
    """Build (not raise) the error refusing to overwrite ``path``; it names ``force=True``."""
    return FileExistsError(f"{path} already exists; pass force=True to overwrite it")


def clean_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove tmakit's temporary files in ``folder`` that no live writer holds."""
    removed: list[Path] = []
    if fcntl is None:
        return removed
    try:
        names = [e.name for e in os.scandir(folder) if TEMP_PATTERN.match(e.name)]
    except OSError:
        return removed
    for name in names:
        tmp = Path(folder) / name
        try:
            fd = os.open(tmp, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # a live writer holds it
            os.close(fd)
            continue
        try:
            tmp.unlink()
            removed.append(tmp)
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


def _create_locked(path: Path, keep_suffix: bool) -> tuple[Path, int]:
    """Create and lock a new temporary file beside ``path``; return it and its descriptor."""
    suffix = path.suffix if keep_suffix else ""
    while True:
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp{suffix}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        if fcntl is None:
            return tmp, fd
        fcntl.flock(fd, fcntl.LOCK_EX)
        try:  # a cleaner may have removed it between creation and locking: start again
            if os.stat(tmp).st_ino == os.fstat(fd).st_ino:
                return tmp, fd
        except FileNotFoundError:
            pass
        os.close(fd)


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], force: bool = False,
                 keep_suffix: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: yield a new empty temporary file, then move it into place.

    Use as ``with atomic_write(path, force) as tmp: write(tmp)``.  Without ``force`` the move is
    a hard link, so a file created meanwhile is never overwritten; on any failure the temporary
    file is removed and ``path`` left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    force : bool, optional
        Overwrite an existing file (default: refuse).
    keep_suffix : bool, optional
        End the temporary file's name with the suffix of ``path`` (for writers, such as matplotlib,
        that choose the format by the suffix).

    Yields
    ------
    pathlib.Path
        The temporary file (created empty) for the caller to write.

    Raises
    ------
    FileExistsError
        If ``path`` exists (checked before and, atomically, after writing) and not ``force``.
    IsADirectoryError
        If ``path`` is a folder.
    """
    path = Path(path)
    if path.exists() and not force:
        raise exists_error(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a folder, not a file")
    clean_stale_temporaries(path.parent)
    tmp, fd = _create_locked(path, keep_suffix)
    try:
        yield tmp
        _move_into_place(tmp, path, force)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    finally:
        os.close(fd)


def _move_into_place(tmp: Path, path: Path, force: bool) -> None:
    if force:
        os.replace(tmp, path)
        return
    try:  # atomic "create only if absent": a hard link fails if the name exists
        os.link(tmp, path)
    except FileExistsError:
        raise exists_error(path) from None
    except OSError:  # no hard links on this file system
        if path.exists():
            raise exists_error(path) from None
        os.replace(tmp, path)
        return
    tmp.unlink()


def fsync_file(path: str | os.PathLike[str]) -> None:
    """Flush a written file to disk (before it is moved into place)."""
    with open(path, "rb+") as f:
        os.fsync(f.fileno())


#: The table formats by file suffix (lower case).
TABLE_SUFFIXES: dict[str, str] = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def table_format(path: str | os.PathLike[str]) -> str | None:
    """Return the table format of ``path`` by its suffix: ``"csv"``, ``"parquet"`` or ``None``."""
    return TABLE_SUFFIXES.get(Path(path).suffix.lower())


def write_table(path: str | os.PathLike[str], table: pd.DataFrame | Mapping[str, Any], *,
                format: str | None = None, force: bool = False, what: str = "a table",
                csv_preamble: Sequence[str] = (),
                parquet_metadata: Mapping[str, str] | None = None,
                parquet_schema: pa.Schema | None = None) -> Path:
    """Write a table as CSV or Parquet, atomically (:func:`atomic_write`).

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
        The Arrow schema of a Parquet file (then no pandas metadata, and NaN written as NaN, not
        null); by default the types come from pandas.

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


class LoopCheckpoint:
    """Save each finished chunk of a closed-loop study to ``<path>.parts``; the table at the end."""

    def __init__(self, path: str | os.PathLike[str], force: bool = False) -> None:
        self.path = Path(path)
        self.force = bool(force)
        if table_format(self.path) is None:
            raise ValueError(f"{self.path}: the per-step table is written as .csv or "
                             ".parquet, not {self.path.suffix or 'a file without suffix'}")
        self.parts = self.path.with_name(self.path.name + ".parts")
        for p in (self.path, self.parts):
            if p.exists() and not force:
                raise exists_error(p)
        self.saved: list[Path] = []

    def __call__(self, chunk: LoopChunk) -> None:
        """Save one finished chunk (atomically) in the parts folder."""
        self.parts.mkdir(parents=True, exist_ok=True)
        slug = "".join(c if c.isalnum() or c in "-_" else "_" for c in chunk.case)
        name = f"{slug}-{chunk.first_run:06d}.parquet"
        self.saved.append(write_table(self.parts / name, chunk.table(), force=True,
                                      what="a chunk of the per-step table"))

    def finish(self, study: ClosedLoopStudy, table: pd.DataFrame | None = None) -> Path:
        """Write the whole table (``table``, default the study's), then remove the parts."""
        out = write_table(self.path, study.table() if table is None else table,
                          force=self.force, what="the per-step table")
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        return out
