"""Track files: the table of a :class:`~tmakit.filters.Track` as CSV or Parquet.

What the table holds is the tracking layer's (:func:`tmakit.tracking.track_table`); this
module writes it, atomically (:func:`~.measurement_files.written_in_place`).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..filters import Track
from ..tracking import track_table
from .measurement_files import written_in_place

__all__ = ["TRACK_SUFFIXES", "write_track"]

#: File suffixes :func:`write_track` writes (CSV, Parquet).
TRACK_SUFFIXES = (".csv", ".parquet", ".pq")


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

    Notes
    -----
    One row per update (:meth:`Track.table_columns`).  The file is written to a temporary
    file in the same folder and moved into place, so a failure leaves nothing half-written.
    Parquet files carry the filter, start and q as schema metadata (``tmakit:filter``, ...).
    """
    import pandas as pd

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TRACK_SUFFIXES:
        raise ValueError(f"{path}: a track is written as .csv or .parquet, not "
                         f"{path.suffix or 'a file without suffix'}")
    table = track_table(tr)
    with written_in_place(path, force) as tmp:
        frame = pd.DataFrame(table.columns)
        if suffix == ".csv":
            frame.to_csv(tmp, index=False)
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            arrow = pa.Table.from_pandas(frame, preserve_index=False)
            meta = dict(arrow.schema.metadata or {})
            for key, value in table.metadata.items():
                meta[f"tmakit:{key}".encode()] = value.encode()
            pq.write_table(arrow.replace_schema_metadata(meta), tmp)
    return path
