"""Range: distance from sensor to target, metres."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.units import REACH_M
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, range_of, zeros_nuisance


class Range(MeasurementModel):
    """Range ``|p|`` from sensor to target, m (also in files); no nuisance parameters."""

    kind = "range"
    file_unit = "m"
    mirror_symmetric = True
    value_range = ValueRange("a range", 0.0, REACH_M)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict ranges, m; see :meth:`MeasurementModel.predict`."""
        rel = as_rel(rel)
        return range_of(rel)

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rel = as_rel(rel)
        r = range_of(rel)[..., None]
        d = np.zeros(rel.shape)
        d[..., :3] = rel[..., :3] / r
        return Jacobian(d, None, zeros_nuisance(rel))

    has_row_gradient = True

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give the range and its derivatives for one row in plain floats (m, 1)."""
        return range_row(rel)


def range_row(rel: tuple[float, ...]) -> tuple[float, ...]:
    """Give :meth:`Range.row_gradient` (a function, for numba)."""
    px, py, pz = rel[0], rel[1], rel[2]
    r = math.sqrt(px * px + py * py + pz * pz)
    return r, px / r, py / r, pz / r, 0.0, 0.0, 0.0
