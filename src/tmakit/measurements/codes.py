"""Integer codes of the measurement kinds, for categorical columns (:mod:`tmakit.data`)."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import KINDS

#: The kind of each code: ``kind_code == i`` means the kind ``KIND_NAMES[i]`` (the order of
#: :data:`tmakit.measurements.KINDS`).
KIND_NAMES: tuple[str, ...] = tuple(KINDS)
#: The code of each kind (the inverse of :data:`KIND_NAMES`).
KIND_CODES: dict[str, int] = {k: i for i, k in enumerate(KIND_NAMES)}

# value_SI = value_file * scale + offset; sigma_SI = sigma_file * scale (per kind code).
FILE_SCALE = np.array([float(KINDS[k].file_scale) for k in KIND_NAMES])
FILE_OFFSET = np.array([float(KINDS[k].file_offset) for k in KIND_NAMES])


@functools.cache
def kind_table(width: int) -> NDArray[np.str_]:
    """Give :data:`KIND_NAMES` as a numpy string array (cached)."""
    return np.array(KIND_NAMES, dtype=f"<U{width}")


@functools.cache
def kind_flags(hook: str) -> NDArray[np.bool_]:
    """Give the boolean hook ``hook`` of every kind, by kind code (cached)."""
    return np.array([bool(getattr(KINDS[k], hook)) for k in KIND_NAMES], dtype=bool)


def kind_codes(kind: NDArray[np.str_]) -> NDArray[np.int8]:
    """Give the kind codes (:data:`KIND_CODES`) of a string column."""
    codes = np.full(kind.shape[0], -1, dtype=np.int8)
    for code, name in enumerate(KIND_NAMES):
        codes[kind == name] = code
    if np.any(codes < 0):
        unknown = sorted(set(kind[codes < 0].tolist()))
        raise ValueError(f"unknown measurement kind(s) {', '.join(unknown)}; expected "
                         f"{', '.join(KINDS)}")
    return codes


def run_starts(column: NDArray[Any]) -> NDArray[np.intp]:
    """Return the indices where a new run of equal values starts (a sensor's rows come in runs)."""
    if column.shape[0] == 0:
        return np.zeros(0, dtype=np.intp)
    return np.flatnonzero(np.concatenate(([True], column[1:] != column[:-1])))


def first_appearance(values: NDArray[Any]) -> tuple[NDArray[Any], NDArray[np.intp]]:
    """Distinct ``values`` in order of first appearance, and each value's rank in that order."""
    starts = run_starts(values)
    if starts.shape[0] == 1:  # one run (one sensor): nothing to sort
        return values[:1], np.zeros(values.shape[0], dtype=np.intp)
    distinct, first, inverse = np.unique(values[starts], return_index=True,
                                         return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(order.shape[0], dtype=np.intp)
    rank[order] = np.arange(order.shape[0])
    lengths = np.diff(np.append(starts, values.shape[0]))
    return distinct[order], np.repeat(rank[inverse.reshape(-1)], lengths)
