"""Monte Carlo study files: the per-run table of a study as CSV or Parquet.

What the table holds is the study's (:attr:`tmakit.montecarlo.MonteCarloResult.table`); this
module writes it with the one table writer (:func:`~.tables.write_table`), atomically.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..montecarlo import MonteCarloResult
from .tables import TABLE_SUFFIXES, write_table

__all__ = ["STUDY_SUFFIXES", "write_study_table"]

#: File suffixes :func:`write_study_table` writes (CSV, Parquet).
STUDY_SUFFIXES = tuple(TABLE_SUFFIXES)


def write_study_table(res: MonteCarloResult, path: str | os.PathLike[str],
                      force: bool = False) -> Path:
    """Write the per-run table of a Monte Carlo study."""
    # write_table refuses another suffix, naming "the per-run table".
    return write_table(path, res.table, force=force, what="the per-run table")
