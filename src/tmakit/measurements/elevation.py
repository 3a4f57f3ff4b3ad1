"""Elevation: angle of the line of sight above the horizontal plane.

``atan2(dz, rho)`` with ``rho`` the horizontal range.  Radians inside, degrees in files.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance


class Elevation(MeasurementModel):
    """Elevation ``atan2(dz, hypot(dx, dy))``, rad; deg in files.

    No nuisance parameters; residuals are wrapped to (-pi, pi].
    """

    kind = "elevation"
    file_unit = "deg"
    gives_height = True
    scale_free = True
    file_scale = np.pi / 180.0
    is_angle = True
    value_range = ValueRange("an elevation", -90.0, 90.0)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict elevations, rad; see :meth:`MeasurementModel.predict`."""
        rel = as_rel(rel)
        return np.arctan2(rel[..., 2], np.hypot(rel[..., 0], rel[..., 1]))

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rel = as_rel(rel)
        dx, dy, dz = rel[..., 0], rel[..., 1], rel[..., 2]
        rho = np.hypot(dx, dy)
        r2 = rho * rho + dz * dz
        d = np.zeros(rel.shape)
        d[..., 0] = -dz * dx / (rho * r2)
        d[..., 1] = -dz * dy / (rho * r2)
        d[..., 2] = rho / r2
        return Jacobian(d, None, zeros_nuisance(rel))

    has_row_gradient = True

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give :meth:`predict` and :meth:`jacobian`'s ``rel`` for one row in plain floats."""
        return elevation_row(rel)


def elevation_row(rel: tuple[float, ...]) -> tuple[float, ...]:
    """Give :meth:`Elevation.row_gradient` (a function, for numba)."""
    dx, dy, dz = rel[0], rel[1], rel[2]
    rho = math.hypot(dx, dy)
    inv_r2 = 1.0 / (rho * rho + dz * dz)
    c = -dz * inv_r2 / rho
    return math.atan2(dz, rho), c * dx, c * dy, rho * inv_r2, 0.0, 0.0, 0.0
