"""Range: distance from sensor to target, metres."""

from __future__ import annotations

import numpy as np

from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance


class Range(MeasurementModel):
    kind = "range"
    file_unit = "m"
    value_range = ValueRange("a range", 0.0)

    def predict(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        return np.linalg.norm(rel[..., :3], axis=-1)

    def jacobian(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        r = np.linalg.norm(rel[..., :3], axis=-1, keepdims=True)
        d = np.zeros(rel.shape)
        d[..., :3] = rel[..., :3] / r
        return Jacobian(d, None, zeros_nuisance(rel))
