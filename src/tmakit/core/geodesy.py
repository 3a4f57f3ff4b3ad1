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
    return _convert("geodetic2enu", lat, lon, alt, origin)


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
    return _convert("enu2geodetic", east, north, up, origin)


def _convert(how: str, a: ArrayLike, b: ArrayLike, c: ArrayLike, origin: ArrayLike
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    import pymap3d

    out = getattr(pymap3d, how)(np.asarray(a, float), np.asarray(b, float),
                                np.asarray(c, float), *_check_origin(origin))
    return np.asarray(out[0], float), np.asarray(out[1], float), np.asarray(out[2], float)
