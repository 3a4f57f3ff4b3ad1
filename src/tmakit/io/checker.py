"""From a raw table to a checked :class:`~tmakit.data.MeasurementSet`.

Every rule of the contract is checked and all problems are reported together.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet
from ..measurements import KINDS
from ..rules import check_set, metadata_problems
from .cells import text_column
from .check_cells import check_cells, read_numbers
from .check_columns import check_columns
from .check_rows import check_order
from .contract import between_sensor_kinds, reference_kinds
from .errors import MeasurementFileError
from .positions import fdoa_carriers, ref_sensor_state, sensor_state
from .problems import Problems, RawTable

__all__ = ["check_table", "table_reader"]


def check_table(path: str | os.PathLike[str], raw: RawTable,
                origin: tuple[float, float, float] | None = None) -> MeasurementSet:
    """Check a raw table against the contract of ``docs/file-format.md`` and build the set."""
    frame, n = raw.frame, len(raw.frame)
    problems = Problems(raw)
    has = set(frame.columns).__contains__
    sensor = (text_column(frame["sensor"]) if has("sensor")
              else np.full(n, "", dtype=object))
    kind = (_stripped(text_column(frame["kind"])) if has("kind")
            else np.full(n, "", dtype=object))
    is_rd = np.isin(kind, reference_kinds())

    layout = check_columns(frame.columns, [k for k in KINDS if np.any(kind == k)], problems)
    num = read_numbers(frame, problems)
    ref_name = (_stripped(text_column(frame["ref_sensor"])) if has("ref_sensor") else None)
    ref_given = check_cells(frame, num, kind, is_rd, problems, ref_name)
    tonal = _tonal(frame, kind, problems) if has("tonal") else None
    check_order(num, sensor, kind, problems, tonal)
    state, origin_metadata = sensor_state(num, layout, origin, problems)
    time_ref = num["time_ref"] if "time_ref" in num else np.full(n, np.nan)
    earlier = is_rd & ~np.isin(kind, between_sensor_kinds())  # tdoa, fdoa: given, checked
    named = (is_rd & ~earlier & ~ref_given & (ref_name != "") if ref_name is not None
             else np.zeros(n, dtype=bool))
    ref_state = ref_sensor_state(num, state, sensor, earlier, ref_given | (is_rd & ~earlier),
                                 layout, problems, ref_name, named)
    meta_carrier = fdoa_carriers(num, kind, raw.metadata, problems)
    if not layout.has_ref and np.any(is_rd & ~earlier & ~named):
        problems.missing("ref_sensor_x", "; tdoa and fdoa rows give their reference sensor's "
                                         "state, or name it in a ref_sensor column")

    problems.file.extend(metadata_problems(raw.metadata))  # the keys the library reads
    found = problems.sorted()
    if found:
        raise MeasurementFileError(Path(path), found)
    meta: dict[str, Any] = dict(raw.metadata)
    meta.update(origin_metadata)
    meta.update(meta_carrier)
    out = MeasurementSet(num["time"], np.asarray(sensor.tolist(), dtype=str),
                         np.asarray(kind.tolist(), dtype=str), num["value"],
                         num["sigma"], state, time_ref, ref_state, meta, check=tonal is None)
    if tonal is not None:
        out = out.with_tonal(tonal)
        check_set(out)
    return out


def _tonal(frame: Any, kind: NDArray[np.object_], problems: Problems) -> NDArray[np.str_]:
    """Read the ``tonal`` column: a label on each frequency row, empty on the others."""
    text = np.array([("" if c is None or c != c else str(c)).strip()
                     for c in frame["tonal"].tolist()], dtype=str)
    for row in np.flatnonzero((text != "") != (kind == "frequency"))[:20].tolist():
        problems.cell(row, "tonal", "a tonal label on a frequency row, empty on any other",
                      repr(text[row]))
    return text


def _stripped(text: NDArray[np.object_]) -> NDArray[np.object_]:
    """Strip each cell, once per distinct text (the cells then share their str objects)."""
    import pandas as pd

    codes, uniques = pd.factorize(text)
    return np.array([str(u).strip() for u in uniques] + [""], dtype=object)[codes]


def table_reader(load: Callable[[Path], RawTable], label: str
                 ) -> Callable[..., MeasurementSet]:
    """Make a format's reader: load the raw table with ``load``, then :func:`check_table` it."""

    def read(path: Path, *, origin: tuple[float, float, float] | None = None,
             **options: Any) -> MeasurementSet:
        if options:
            raise TypeError(f"{label} files take no options {', '.join(sorted(options))}")
        return check_table(path, load(path), origin)

    read.__doc__ = f"Read and check a {label} measurement file (see :func:`check_table`)."
    return read
