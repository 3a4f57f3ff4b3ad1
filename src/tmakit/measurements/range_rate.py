"""Range rate: d|p|/dt = p.v / |p| for the relative position p and velocity v, m/s.

This is the combined radial velocity v_k of Gu et al. (2007), eq. 6 (positive when the
target recedes); the sensor's own velocity enters through the relative velocity.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.units import SPEED_OF_LIGHT
from .base import (
    Jacobian,
    MeasurementModel,
    ValueRange,
    as_rel,
    dot3,
    inverse_range_and_unit,
    zeros_nuisance,
)


def range_rate(rel: np.ndarray) -> np.ndarray:
    """Give the range rate alone, as :func:`range_rate_and_gradient` computes it."""
    return dot3(inverse_range_and_unit(rel)[1], rel[..., 3:])


def range_rate_and_gradient(rel: np.ndarray, scale: float = 1.0
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Give the range rate and its gradient with respect to the relative state.

    References
    ----------
    Gu et al. (2007), eq. 6 (the combined radial velocity ``v_k``).
    """
    v = rel[..., 3:]
    inv_r, unit = inverse_range_and_unit(rel)
    rdot = dot3(unit, v)
    grad = np.empty_like(rel)
    np.multiply(unit, scale, out=grad[..., 3:])
    grad[..., :3] = (v - rdot[..., None] * unit) * (scale * inv_r)[..., None]
    if scale != 1.0:
        rdot *= scale
    return rdot, grad


def range_rate_row(rel: tuple[float, ...]) -> tuple[float, ...]:
    """Give :func:`range_rate_and_gradient` (scale 1) for one row in plain floats."""
    px, py, pz, vx, vy, vz = rel
    inv_r = 1.0 / math.sqrt(px * px + py * py + pz * pz)
    ux, uy, uz = px * inv_r, py * inv_r, pz * inv_r
    rdot = ux * vx + uy * vy + uz * vz
    return (rdot, (vx - rdot * ux) * inv_r, (vy - rdot * uy) * inv_r,
            (vz - rdot * uz) * inv_r, ux, uy, uz)


class RangeRate(MeasurementModel):
    """Range rate ``p.v / |p|``, m/s (also in files), positive when the target recedes.

    No nuisance parameters; needs the relative velocity.

    References
    ----------
    Gu et al. (2007), eq. 6 (the combined radial velocity ``v_k``).
    """

    kind = "range_rate"
    file_unit = "m/s"
    value_range = ValueRange("a range rate", -SPEED_OF_LIGHT, SPEED_OF_LIGHT)
    mirror_symmetric = True
    uses_velocity = True

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict range rates, m/s; see :meth:`MeasurementModel.predict`."""
        return range_rate(as_rel(rel))

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rel = as_rel(rel)
        return Jacobian(range_rate_and_gradient(rel)[1], None, zeros_nuisance(rel))

    has_row_gradient = True

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give the range rate and its derivatives for one row in plain floats."""
        return range_rate_row(rel)
