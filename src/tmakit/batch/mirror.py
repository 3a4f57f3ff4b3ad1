"""The mirror ambiguity of 3-D fits without elevation data: the track above the sensors.

When every sensor is at one height and none moves vertically, a 3-D track and its mirror image
through the sensors' plane give the same bearings, Doppler and power; :func:`mirror_plane`
finds that plane and :func:`prefer_above` reports the solution above it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..motion import MotionModel
from .solver import VarProProblem

__all__ = ["mirror_plane", "prefer_above"]


def mirror_plane(problem: VarProProblem) -> float | None:
    """Return the height of a plane through every sensor that mirrors the track unseen."""
    meas, motion = problem.obs.meas, problem.obs.motion
    if (motion.dim != 3 or "z" not in motion.param_names
            or not np.all(meas.kind_flag("mirror_symmetric"))):
        return None
    z = np.concatenate([meas.sensor_state[:, 2], meas.ref_sensor_state[:, 2]])
    z = z[np.isfinite(z)]
    vz = meas.sensor_state[:, 5]
    if z.size == 0 or np.ptp(z) > 1e-9 * max(1.0, np.abs(z).max()) or np.any(vz != 0):
        return None
    return float(z[0])


def prefer_above(motion: MotionModel, theta: NDArray[np.float64], plane: float
                 ) -> tuple[NDArray[np.float64], str]:
    """Choose, of a track and its mirror image through the sensors' plane, the one above."""
    names = motion.param_names
    theta = np.array(theta, dtype=float)
    iz = names.index("z")
    note = (f"z is ambiguous: the mirror image through the sensors' plane z = {plane:g} m fits "
            "exactly as well (no elevation is measured); the solution above it is reported")
    if theta[iz] < plane:
        theta[iz] = 2.0 * plane - theta[iz]
        if "vz" in names:
            theta[names.index("vz")] *= -1.0
    return theta, note
