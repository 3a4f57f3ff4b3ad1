"""Range rate: d|p|/dt = p.v / |p| for the relative position p and velocity v, m/s.

This is the combined radial velocity v_k of Gu et al. (2007), eq. 6 (positive when the
target recedes); the sensor's own velocity enters through the relative velocity."""

from __future__ import annotations

import numpy as np

from .base import Jacobian, MeasurementModel, as_rel, dot3, inverse_range_and_unit, zeros_nuisance


def range_rate_and_gradient(rel: np.ndarray, scale: float = 1.0
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Range rate ``(..., n)`` and its gradient with respect to the relative state
    ``(..., n, 6)`` (in ``rel``'s memory layout), both multiplied by ``scale``."""
    v = rel[..., 3:]
    inv_r, unit = inverse_range_and_unit(rel)
    rdot = dot3(unit, v)
    grad = np.empty_like(rel)
    np.multiply(unit, scale, out=grad[..., 3:])
    grad[..., :3] = (v - rdot[..., None] * unit) * (scale * inv_r)[..., None]
    if scale != 1.0:
        rdot *= scale
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
