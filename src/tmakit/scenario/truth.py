"""The true target states a simulated measurement set carries in its metadata.

:func:`truth_states` turns the metadata's ``motion``, ``truth`` and ``ref_time`` into true
states at any times; sets without them (real logs) have no truth.
"""

from __future__ import annotations

import json

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import motion_from_name

__all__ = ["truth_states"]

#: The components of the full 3-D state ``[x, y, z, vx, vy, vz]`` kept for a 2-D state.
_PLANE = [0, 1, 3, 4]


def truth_states(meas: MeasurementSet, times: ArrayLike, dim: int
                 ) -> NDArray[np.float64] | None:
    """Return true target states at ``times`` from the set's metadata, or ``None`` if unknown.

    Parameters
    ----------
    meas : MeasurementSet
        Its ``metadata`` carries ``motion``, ``truth`` and optionally ``ref_time``.
    times : array_like, shape (K,)
        Times, s.
    dim : int
        3 for ``[x, y, z, vx, vy, vz]``; otherwise 2, ``[x, y, vx, vy]``.

    Returns
    -------
    ndarray, shape (K, 2 dim), or None
        ENU states, m and m/s; None when the metadata carry no usable truth.
    """
    meta = meas.metadata
    if "motion" not in meta or "truth" not in meta:
        return None
    try:
        motion = motion_from_name(meta["motion"], float(meta.get("ref_time", 0.0)))
        theta = motion.theta(json.loads(meta["truth"]))
        s6 = motion.states(theta, np.asarray(times, dtype=float))
    except (ValueError, KeyError, TypeError, json.JSONDecodeError):
        return None
    keep = [0, 1, 2, 3, 4, 5] if dim == 3 else _PLANE
    return np.asarray(s6, dtype=float)[:, keep]
