"""Bearing (azimuth): angle clockwise from North of the horizontal line of sight.

``atan2(dx, dy)`` (Hörst & Oispuu (2010), eq. 6).  Radians inside, degrees in files.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance


def _derivatives_into(dx: Array, dy: Array, d_rel: Array) -> None:
    """Write the bearings' derivatives ``dy / r^2`` and ``-dx / r^2`` into ``d_rel[..., :2]``."""
    rho2 = dx * dx
    rho2 += dy * dy
    np.divide(dy, rho2, out=d_rel[..., 0])
    np.divide(dx, rho2, out=d_rel[..., 1])
    np.negative(d_rel[..., 1], out=d_rel[..., 1])  # -(dx / rho2) == -dx / rho2 exactly


class Bearing(MeasurementModel):
    """Bearing ``atan2(dx, dy)``, rad (clockwise from North); deg in files.

    No nuisance parameters; residuals are wrapped to (-pi, pi].

    References
    ----------
    Hörst & Oispuu (2010), eq. 6 (the azimuth).
    """

    kind = "bearing"
    file_unit = "deg"
    mirror_symmetric = True
    scale_free = True
    height_blind = True
    wrap_period = 2.0 * np.pi
    file_scale = np.pi / 180.0
    is_angle = True
    value_range = ValueRange("a bearing", -360.0, 360.0)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict bearings, rad; see :meth:`MeasurementModel.predict`."""
        rel = as_rel(rel)
        return np.arctan2(rel[..., 0], rel[..., 1])

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rel = as_rel(rel)
        # Component-major, like the relative states: columns 2..5 stay untouched zero pages.
        d = np.zeros(rel.swapaxes(-1, -2).shape).swapaxes(-1, -2)
        _derivatives_into(rel[..., 0], rel[..., 1], d)
        return Jacobian(d, None, zeros_nuisance(rel))

    def values_and_derivatives_into(self, rel: Array, t: Array | None, values: Array,
                                    d_rel: Array, nuisance: Array | None = None) -> None:
        """Write bearings and their derivatives (those of :meth:`jacobian`)."""
        # (the components read once, strided, then contiguous: 1.5x faster on the batches of
        # the manoeuvre search, 23 x 901 rows)
        dx, dy = np.ascontiguousarray(rel[..., 0]), np.ascontiguousarray(rel[..., 1])
        np.arctan2(dx, dy, out=values)
        _derivatives_into(dx, dy, d_rel)

    def planar_gradient(self, rel: Array, out: Array, weight: Array | None = None,
                        negate: bool = True) -> Array:
        """Write the bearings' derivatives by relative east and north.

        Parameters
        ----------
        rel : ndarray
            Relative east and north positions ``(2, m)``, m.
        out : ndarray
            ``(2, m)`` written with ``dy / r^2`` and ``-dx / r^2``, rad/m (times ``weight``).
        weight : ndarray, optional
            ``(m,)`` factors of the derivatives (e.g. ``1 / sigma``).
        negate : bool, optional
            False leaves ``out[1]`` holding the derivative's negative.

        Returns
        -------
        ndarray
            ``r^2 = dx^2 + dy^2`` ``(m,)``, m^2.
        """
        dx, dy = rel[0], rel[1]
        rho2 = dx * dx
        rho2 += dy * dy
        # both rows by one product: north, east (the same bits as row by row)
        if weight is None:
            np.divide(rel[::-1], rho2, out=out)
        else:
            np.multiply(rel[::-1], weight / rho2, out=out)
        if negate:
            np.negative(out[1], out=out[1])  # -(dx / rho2) == -dx / rho2 exactly
        return rho2

    def planar_value(self, dx: Array, dy: Array) -> Array:
        """Give bearings from the relative east and north positions.

        Parameters
        ----------
        dx, dy : ndarray
            ``(m,)``, m.

        Returns
        -------
        ndarray
            ``atan2(dx, dy)``, rad, ``(m,)``.
        """
        return np.arctan2(dx, dy)

    def planar_unit(self, dx: Array, dy: Array) -> tuple[Array, Array]:
        """Give ``sin h = dx / r`` and ``cos h = dy / r`` of bearings, without trigonometry.

        Parameters
        ----------
        dx, dy : ndarray
            Relative east and north positions, m; overwritten.

        Returns
        -------
        (ndarray, ndarray)
            ``dx`` holding ``sin h`` and ``dy`` holding ``cos h``.
        """
        inv = dx * dx  # (not hypot: three times as long)
        inv += dy * dy
        np.sqrt(inv, out=inv)
        # min and max carry any NaN: one test for a zero, infinite or NaN distance (or a
        # square under- or overflowed)
        if inv.size and not (inv.min() > 0.0 and inv.max() < np.inf):
            at = ~((inv > 0.0) & (inv < np.inf))
            h = np.arctan2(dx[at], dy[at])
            with np.errstate(divide="ignore", invalid="ignore"):
                self._scale_by_inverse(dx, dy, inv)
            dx[at], dy[at] = np.sin(h), np.cos(h)
            return dx, dy
        self._scale_by_inverse(dx, dy, inv)
        return dx, dy

    @staticmethod
    def _scale_by_inverse(dx: Array, dy: Array, r: Array) -> None:
        """Divide ``dx`` and ``dy`` by ``r`` in place (by one reciprocal: ``r`` overwritten)."""
        np.divide(1.0, r, out=r)
        dx *= r
        dy *= r

    has_row_gradient = True

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give :meth:`predict` and :meth:`jacobian`'s ``rel`` for one row in plain floats."""
        return bearing_row(rel)


def bearing_row(rel: tuple[float, ...]) -> tuple[float, ...]:
    """Give :meth:`Bearing.row_gradient` (a function, for numba)."""
    dx, dy = rel[0], rel[1]
    inv = 1.0 / (dx * dx + dy * dy)
    return math.atan2(dx, dy), dy * inv, -dx * inv, 0.0, 0.0, 0.0, 0.0
