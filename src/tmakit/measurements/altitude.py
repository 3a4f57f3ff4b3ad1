"""Altitude: the target's height above the WGS-84 ellipsoid, a known-altitude constraint.

An emitter on the ground (or an aircraft at a known flight level) seen from high sensors: the
ENU frame's flat plane is far from the Earth's surface there (150 km from the origin the
ellipsoid is 1.8 km below it), so the height is stated on the ellipsoid.  A row's sensor is
the ENU frame's origin (``rel`` is then the target's ENU position), its value the height
(m) and its sigma how well it is known (a terrain model's error).  The gradient of the
geodetic height is the ellipsoid's unit normal at the point's latitude and longitude.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.geodesy import enu_to_geodetic
from ..core.units import REACH_M
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, zeros_nuisance

__all__ = ["Altitude"]


class Altitude(MeasurementModel):
    """Height of the target above the WGS-84 ellipsoid, m (also in files).

    Parameters
    ----------
    origin : sequence of float, optional
        The ENU origin ``(lat, lon, alt)`` (deg, deg, m); a set's ``origin_lat``,
        ``origin_lon`` and ``origin_alt`` metadata give it.

    Raises
    ------
    ValueError
        On :meth:`predict` without an origin.
    """

    kind = "altitude"
    file_unit = "m"
    value_range = ValueRange("an altitude", -REACH_M, REACH_M)
    gives_height = True
    sensor_at_origin = True

    def __init__(self, origin: ArrayLike | None = None) -> None:
        self.origin = None if origin is None else tuple(float(v) for v in np.ravel(origin))

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the ENU origin a set's metadata states (``origin_lat``, ...)."""
        if "origin_lat" not in metadata or "origin_lon" not in metadata:
            return {}
        return {"origin": [float(metadata[k]) if k in metadata else 0.0
                           for k in ("origin_lat", "origin_lon", "origin_alt")]}

    def _geodetic(self, rel: Array) -> tuple[Array, Array, Array]:
        if self.origin is None:
            raise ValueError("altitude needs the ENU origin (the set's origin_lat and "
                             "origin_lon metadata, or the origin option)")
        return enu_to_geodetic(rel[..., 0], rel[..., 1], rel[..., 2], self.origin)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict the target's height above the ellipsoid, m (``rel`` from the origin)."""
        return self._geodetic(as_rel(rel))[2]

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the ellipsoid's unit normal at the target, in the origin's ENU axes (m/m)."""
        rel = as_rel(rel)
        lat, lon, _ = np.radians(self._geodetic(rel))
        assert self.origin is not None
        lat0, lon0 = np.radians(self.origin[:2])
        normal = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)],
                          axis=-1)
        enu = np.array([[-np.sin(lon0), np.cos(lon0), 0.0],
                        [-np.sin(lat0) * np.cos(lon0), -np.sin(lat0) * np.sin(lon0),
                         np.cos(lat0)],
                        [np.cos(lat0) * np.cos(lon0), np.cos(lat0) * np.sin(lon0),
                         np.sin(lat0)]])
        d = np.zeros(rel.shape)
        d[..., :3] = (normal[..., None, :] * enu).sum(axis=-1)  # the same bits in a batch
        return Jacobian(d, None, zeros_nuisance(rel))

    def __repr__(self) -> str:
        """Name the kind with its origin."""
        return f"Altitude(origin={self.origin!r})"
