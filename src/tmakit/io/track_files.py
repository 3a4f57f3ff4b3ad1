"""Track files: the table of a :class:`~tmakit.filters.Track` as CSV or Parquet."""

from __future__ import annotations

import os
from pathlib import Path

from ..filters import Track
from ..tracking import track_table
from .tables import write_table

__all__ = ["write_track"]


def write_track(tr: Track, path: str | os.PathLike[str], force: bool = False) -> Path:
    """Write the track table as CSV or Parquet, by the suffix of ``path``.

    Parameters
    ----------
    tr : Track
        The track (from :func:`tmakit.track`).
    path : str or path-like
        ``.csv``, ``.parquet`` or ``.pq``.
    force : bool
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        Another suffix.
    FileExistsError
        ``path`` exists and not ``force``.
    """
    table = track_table(tr)  # write_table refuses another suffix, naming "a track"
    return write_table(path, table.columns, force=force, what="a track",
                       parquet_metadata={f"tmakit:{k}": v for k, v in table.metadata.items()})
