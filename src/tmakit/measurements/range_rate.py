"""Range rate: d|p|/dt = p.v / |p| for the relative position p and velocity v, m/s.

This is the combined radial velocity v_k of 000_bc54bd8c50e47249.txt eq. 6 (positive when the
target recedes); the sensor's own velocity enters through the relative velocity."""

from __future__ import annotations

import numpy as np

from .base import Jacobian, MeasurementModel, as_rel, zeros_nuisance


def range_rate_and_gradient(rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range rate ``(..., n)`` and its gradient with respect to the relative state."""
    p, v = rel[..., :3], rel[..., 3:]
    r = np.linalg.norm(p, axis=-1)
    rdot = np.einsum("...i,...i->...", p, v) / r
    grad = np.empty(rel.shape)
    grad[..., :3] = (v - rdot[..., None] * p / r[..., None]) / r[..., None]
    grad[..., 3:] = p / r[..., None]
    return rdot, grad


class RangeRate(MeasurementModel):
    kind = "range_rate"
    file_unit = "m/s"
    uses_velocity = True

    def predict(self, rel, t=None, nuisance=None, rel_ref=None):
        return range_rate_and_gradient(as_rel(rel))[0]

    def jacobian(self, rel, t=None, nuisance=None, rel_ref=None):
        rel = as_rel(rel)
        return Jacobian(range_rate_and_gradient(rel)[1], None, zeros_nuisance(rel))
