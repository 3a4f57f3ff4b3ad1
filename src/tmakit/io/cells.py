"""Cells of a raw table: empty or not, as text, and as shown in problem messages."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["blank_mask", "is_blank", "number_text", "show", "text_column"]


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
