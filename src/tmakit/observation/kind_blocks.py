"""Rows grouped by kind: each kind's contiguous block, from the categorical kind codes."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..data import KIND_CODES, MeasurementSet
from ..measurements import MeasurementModel


def group_by_kind(meas: MeasurementSet, kinds: list[str]
                  ) -> tuple[dict[str, slice], NDArray[np.intp] | None]:
    """Group the rows of a set by kind: each kind's slice of the grouped order, and that order."""
    n = len(meas)
    if len(kinds) <= 1:
        return {k: slice(0, n) for k in kinds}, None
    code = meas.kind_code
    order = None
    if not bool(np.all(code[1:] >= code[:-1])):
        order = np.argsort(code, kind="stable")
        code = code[order]
    ends = np.searchsorted(code, [KIND_CODES[k] for k in kinds], side="right").tolist()
    return {k: slice(a, b) for k, a, b in zip(kinds, [0, *ends[:-1]], ends, strict=True)}, order


def angle_runs(models: Mapping[str, MeasurementModel], slices: Mapping[str, slice], m: int
               ) -> tuple[bool, bool, slice | None]:
    """Tell whether some and all of ``m`` rows grouped by kind are angles, and where."""
    runs = sorted((sl.start, sl.stop) for kind, sl in slices.items()
                  if models[kind].is_angle and sl.stop > sl.start)
    count = sum(stop - start for start, stop in runs)
    # Disjoint runs form one run when their span holds no other row.
    one = bool(runs) and runs[-1][1] - runs[0][0] == count
    return count > 0, count == m, slice(runs[0][0], runs[-1][1]) if one else None
