"""Frame and angle conventions, written once.

- Local East-North-Up (ENU) Cartesian frame, metres.  A 2-D problem lives in the plane z = 0.
- Bearing (azimuth) is measured clockwise from North: ``atan2(d_east, d_north)``
  (002_e7269ad11b825346.txt eq. 6).  Elevation is measured up from the horizontal plane.
- Headings/courses are bearings too (clockwise from North).  A paper that measures angles
  counter-clockwise from East (000_bc54bd8c50e47249.txt's sensor path,
  003_e5155d4fe60daef8.txt's bearings) is converted with :func:`math_angle_to_bearing` in its
  scenario, never in the models.
- Relative state = target minus sensor, ``[dx, dy, dz, dvx, dvy, dvz]``.
- Angle residuals are wrapped to (-pi, pi].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

POSITION = slice(0, 3)
VELOCITY = slice(3, 6)
STATE_SIZE = 6
"""Every state in tmakit is a 3-D position and velocity; 2-D problems keep z = vz = 0."""


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles (radians) to the interval (-pi, pi]."""
    a = np.asarray(angle, dtype=float)
    wrapped = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    # mod maps +pi to -pi; the convention keeps +pi.
    return np.where(wrapped == -np.pi, np.pi, wrapped)


def wrap_to_2pi(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles (radians) to [0, 2 pi)."""
    return np.mod(np.asarray(angle, dtype=float), 2.0 * np.pi)


def bearing(d_east: ArrayLike, d_north: ArrayLike) -> NDArray[np.float64]:
    """Bearing (radians, clockwise from North, in (-pi, pi]) of the vector (d_east, d_north)."""
    return np.arctan2(d_east, d_north)


def math_angle_to_bearing(angle: ArrayLike) -> NDArray[np.float64]:
    """Convert an angle counter-clockwise from East (x-axis) to a bearing clockwise from North.

    Works for angles in radians; the map is its own inverse.
    """
    return wrap_angle(np.pi / 2.0 - np.asarray(angle, dtype=float))


bearing_to_math_angle = math_angle_to_bearing


def unit_vector_from_bearing(bearing_rad: ArrayLike) -> NDArray[np.float64]:
    """Horizontal unit vector(s) ``[east, north]`` pointing along a bearing; shape (..., 2)."""
    b = np.asarray(bearing_rad, dtype=float)
    return np.stack([np.sin(b), np.cos(b)], axis=-1)
