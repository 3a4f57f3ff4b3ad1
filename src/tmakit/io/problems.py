"""A raw table as read from a file, its cells, and the problems found in it while checking."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .contract import COLUMN_PURPOSE

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["Problems", "RawTable", "blank_mask", "is_blank", "number_text", "show", "text_column"]


@dataclass
class RawTable:
    """A file's table as read, before checking: text cells for CSV, typed for Parquet."""

    frame: pd.DataFrame  # The cells, one column per header name
    #: The file's metadata (``# key: value`` lines of a CSV file, ``tmakit:`` keys of the Parquet
    #: schema)
    metadata: dict[str, str]
    #: Line of each data row in the CSV file (1-based), or None (Parquet)
    lines: NDArray[np.int64] | None


@dataclass
class Problems:
    """The problems found in one raw table: file-wide ones, and one per cell at most."""

    raw: RawTable
    file: list[str] = field(default_factory=list)  # The file-wide problems
    #: The problem of each (0-based row, column) cell
    cells: dict[tuple[int, str], str] = field(default_factory=dict)

    def where(self, row: int) -> str:
        """Say where a row is: ``row R (line L)`` (``row R`` without line numbers)."""
        lines = self.raw.lines
        if lines is None:
            return f"row {row + 1}"
        return f"row {row + 1} (line {lines[row]})"

    def cell(self, row: int, column: str, expected: str, found: str | None = None) -> None:
        """Record a problem at one cell (the first problem of a cell wins)."""
        if (row, column) in self.cells:
            return
        frame = self.raw.frame
        if found is None:
            found = show(frame[column].iat[row]) if column in frame else "nothing"
        self.cells[(row, column)] = (
            f"{self.where(row)}, column '{column}': expected {expected}, found {found}")

    def missing(self, column: str, extra: str = "") -> None:
        """Record that a column of the contract is missing."""
        self.file.append(f"column '{column}' is missing: {COLUMN_PURPOSE[column]}{extra}")

    def bad_rows(self, *columns: str) -> NDArray[np.bool_]:
        """Mark the rows with a problem in one of ``columns``."""
        mask = np.zeros(len(self.raw.frame), dtype=bool)
        wanted = set(columns)
        for row, column in self.cells:
            if column in wanted:
                mask[row] = True
        return mask

    def sorted(self) -> list[str]:
        """List the problems: file-wide first, then cells by row and column order."""
        order = {c: i for i, c in enumerate(self.raw.frame.columns)}
        cells = sorted(self.cells.items(),
                       key=lambda item: (item[0][0], order.get(item[0][1], len(order))))
        return self.file + [p for _, p in cells]


def number_text(x: float) -> str:
    """Format a number for messages: shortest exact representation, no trailing '.0'."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def is_blank(v: Any) -> bool:
    """Whether a cell is empty: ``None``, NaN or NA, or text that is only spaces."""
    if v is None:
        return True
    if isinstance(v, str):
        return v.strip() == ""
    try:
        return bool(v != v)  # NaN and pandas NA-likes
    except (TypeError, ValueError):
        return False


def show(v: Any) -> str:
    """Format a cell value for "found ..." in messages."""
    if v is None or (isinstance(v, str) and v.strip() == ""):
        return "an empty cell"
    if isinstance(v, str):
        try:
            float(v)
        except ValueError:
            return repr(v)
        return v.strip()
    if isinstance(v, (bool, np.bool_)):
        return repr(bool(v))
    if isinstance(v, (float, int, np.floating, np.integer)):
        if isinstance(v, (float, np.floating)) and math.isnan(v):
            return "an empty cell (NaN)"
        return number_text(float(v))
    try:
        if v != v:
            return "an empty cell"
    except (TypeError, ValueError):
        pass
    return repr(v)


def blank_mask(series: pd.Series) -> NDArray[np.bool_]:
    """Empty cells of a column: NaN/None/NA, or text that is only spaces."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):
        return (series.str.strip() == "").fillna(True).to_numpy(dtype=bool)
    return series.map(is_blank).to_numpy(dtype=bool)


def text_column(series: pd.Series) -> NDArray[np.object_]:
    """Cells of a text column as Python str ('' for empty), ids like 1 kept as '1'."""
    import pandas as pd

    if isinstance(series.dtype, pd.StringDtype):  # one str object per distinct id, shared
        codes, uniques = pd.factorize(series.fillna(""))
        return np.asarray(uniques, dtype=object)[codes]
    out = np.empty(len(series), dtype=object)
    for i, v in enumerate(series.tolist()):
        out[i] = "" if is_blank(v) else str(v)
    return out
