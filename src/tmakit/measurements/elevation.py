"""Elevation: angle of the line of sight above the horizontal plane, ``atan2(dz, rho)`` with
``rho`` the horizontal range.  Radians inside, degrees in files."""

from __future__ import annotations

import numpy as np

from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance


class Elevation(MeasurementModel):
    kind = "elevation"
    file_unit = "deg"
    file_scale = np.pi / 180.0
    is_angle = True
    value_range = ValueRange("an elevation", -90.0, 90.0)

    def predict(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        return np.arctan2(rel[..., 2], np.hypot(rel[..., 0], rel[..., 1]))

    def jacobian(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        dx, dy, dz = rel[..., 0], rel[..., 1], rel[..., 2]
        rho = np.hypot(dx, dy)
        r2 = rho * rho + dz * dz
        d = np.zeros(rel.shape)
        d[..., 0] = -dz * dx / (rho * r2)
        d[..., 1] = -dz * dy / (rho * r2)
        d[..., 2] = rho / r2
        return Jacobian(d, None, zeros_nuisance(rel))
