"""WGS-84 latitude/longitude/altitude <-> the local East-North-Up frame (via pymap3d).

Latitudes and longitudes in degrees, altitudes and ENU coordinates in metres.  The origin
is ``(lat, lon, alt)`` of the frame's (0, 0, 0).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _check_origin(origin: ArrayLike) -> tuple[float, float, float]:
    try:
        lat, lon, alt = (float(v) for v in np.asarray(origin, dtype=np.float64).reshape(-1))
    except (TypeError, ValueError):
        raise ValueError("an ENU origin is (lat, lon, alt) in degrees, degrees, metres") from None
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 360.0 and np.isfinite(alt)):
        raise ValueError(f"ENU origin out of range: lat {lat}, lon {lon}, alt {alt}")
    return lat, lon, alt


def geodetic_to_enu(lat: ArrayLike, lon: ArrayLike, alt: ArrayLike, origin: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Convert WGS-84 geodetic coordinates to the local East-North-Up frame about ``origin``.

    Parameters
    ----------
    lat, lon : array_like
        Geodetic latitude and longitude (deg).
    alt : array_like
        Altitude above the WGS-84 ellipsoid (m).
    origin : array_like
        ``(lat, lon, alt)`` of the frame's (0, 0, 0) (deg, deg, m).

    Returns
    -------
    east, north, up : numpy.ndarray
        ENU coordinates (m).

    Raises
    ------
    ValueError
        If ``origin`` is not three numbers, or its latitude is outside [-90, 90], its
        longitude outside [-180, 360] or its altitude not finite.
    """
    import pymap3d

    lat0, lon0, alt0 = _check_origin(origin)
    e, n, u = pymap3d.geodetic2enu(np.asarray(lat, float), np.asarray(lon, float),
                                   np.asarray(alt, float), lat0, lon0, alt0)
    return np.asarray(e, float), np.asarray(n, float), np.asarray(u, float)


def enu_to_geodetic(east: ArrayLike, north: ArrayLike, up: ArrayLike, origin: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Convert local East-North-Up coordinates about ``origin`` to WGS-84 geodetic ones.

    Parameters
    ----------
    east, north, up : array_like
        ENU coordinates (m).
    origin : array_like
        ``(lat, lon, alt)`` of the frame's (0, 0, 0) (deg, deg, m).

    Returns
    -------
    lat, lon : numpy.ndarray
        Geodetic latitude and longitude (deg).
    alt : numpy.ndarray
        Altitude above the WGS-84 ellipsoid (m).

    Raises
    ------
    ValueError
        If ``origin`` is not three numbers or is out of range (see :func:`geodetic_to_enu`).
    """
    import pymap3d

    lat0, lon0, alt0 = _check_origin(origin)
    lat, lon, alt = pymap3d.enu2geodetic(np.asarray(east, float), np.asarray(north, float),
                                         np.asarray(up, float), lat0, lon0, alt0)
    return np.asarray(lat, float), np.asarray(lon, float), np.asarray(alt, float)
