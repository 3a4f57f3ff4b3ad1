"""Closed-loop study files: the per-step table of a closed-loop Monte Carlo study.

The table (:meth:`tmakit.montecarlo.closed_loop.ClosedLoopStudy.table`) is written with the one
table writer (:func:`~.tables.write_table`), atomically, never over an existing file without
``force``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

from .atomic import exists_error
from .tables import TABLE_SUFFIXES, table_format, write_table

if TYPE_CHECKING:  # pragma: no cover
    from ..montecarlo.closed_loop import ClosedLoopStudy, LoopChunk

__all__ = ["LOOP_SUFFIXES", "LoopCheckpoint", "write_loop_table"]

#: File suffixes :func:`write_loop_table` writes (CSV, Parquet).
LOOP_SUFFIXES = tuple(TABLE_SUFFIXES)


def write_loop_table(study: ClosedLoopStudy, path: str | os.PathLike[str],
                     force: bool = False) -> Path:
    """Write the per-step table of a closed-loop study."""
    return write_table(path, study.table(), force=force, what="the per-step table")


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in text)


class LoopCheckpoint:
    """Save each finished chunk of a closed-loop study at once; the whole table at the end.

    Parameters
    ----------
    path : str or path-like
        The final table (``.parquet``, ``.pq`` or ``.csv``); the chunks go to the folder
        ``<path>.parts`` (Parquet).
    force : bool, optional
        Overwrite an existing table or parts folder.
    """

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
        name = f"{_slug(chunk.case)}-{chunk.first_run:06d}.parquet"
        self.saved.append(write_table(self.parts / name, chunk.table(), force=True,
                                      what="a chunk of the per-step table"))

    def finish(self, study: ClosedLoopStudy) -> Path:
        """Write the whole table, then remove the parts folder."""
        out = write_loop_table(study, self.path, force=self.force)
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        return out
