"""Bearing (azimuth): angle clockwise from North of the horizontal line of sight,
``atan2(dx, dy)`` (Hörst & Oispuu (2010), eq. 6).  Radians inside, degrees in files."""

from __future__ import annotations

import numpy as np

from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance


class Bearing(MeasurementModel):
    kind = "bearing"
    file_unit = "deg"
    file_scale = np.pi / 180.0
    is_angle = True
    value_range = ValueRange("a bearing", -360.0, 360.0)

    def predict(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        return np.arctan2(rel[..., 0], rel[..., 1])

    def jacobian(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        dx, dy = rel[..., 0], rel[..., 1]
        rho2 = dx * dx + dy * dy
        d = np.zeros(rel.shape)
        d[..., 0] = dy / rho2
        d[..., 1] = -dx / rho2
        return Jacobian(d, None, zeros_nuisance(rel))
