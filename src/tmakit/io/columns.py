"""The columns of a measurement file as written, from a set."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS, MeasurementSet
from .contract import reference_kinds

__all__ = ["file_columns"]


def file_columns(ms: MeasurementSet) -> dict[str, NDArray[Any]]:
    """Return the columns to write, in :data:`~tmakit.io.contract.COLUMN_ORDER` (file units)."""
    cols: dict[str, NDArray[Any]] = {
        "time": ms.time, "sensor": ms.sensor, "kind": ms.kind, "value": ms.value,
        "sigma": ms.sigma}
    for i, c in enumerate(SENSOR_STATE_COLUMNS):
        cols[c] = ms.sensor_state[:, i]
    cols["time_ref"] = ms.time_ref
    if any(np.any(ms.kind_mask(k)) for k in reference_kinds()):
        for i, c in enumerate(REF_STATE_COLUMNS):
            cols[c] = ms.ref_sensor_state[:, i]
    if ms.tonal is not None:  # each frequency row's tonal (its own f0)
        cols["tonal"] = ms.tonal
    return cols
