"""Motion models by name: the one parser of the motion names tmakit accepts.

``cv2d`` (``cv``), ``cv3d``, ``static2d`` (``static``), ``static3d``, ``curvilinear:M`` (M
manoeuvres) and ``curvilinear`` (``curvilinear:2``, :data:`DEFAULT_MANOEUVRES`);
case-insensitive.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .base import MotionModel
from .constant_velocity import ConstantVelocity, Stationary
from .curvilinear import PiecewiseCurvilinear

__all__ = ["DEFAULT_MANOEUVRES", "MOTION_NAMES", "default_ref_time", "motion_from_name"]

DEFAULT_MANOEUVRES = 2
"""Manoeuvres of the bare name ``curvilinear`` (it means ``curvilinear:2``)."""

MOTION_NAMES = ("cv2d", "cv3d", "static2d", "static3d", "curvilinear[:M]")
"""The names accepted, as the CLI lists them."""

_FIXED = {
    "cv": (ConstantVelocity, 2), "cv2d": (ConstantVelocity, 2), "cv3d": (ConstantVelocity, 3),
    "static": (Stationary, 2), "static2d": (Stationary, 2), "static3d": (Stationary, 3),
}


def motion_from_name(name: str, ref_time: float = 0.0) -> MotionModel:
    """Make the motion model a name stands for (see the module docstring for the names).

    Parameters
    ----------
    name : str
        ``cv2d``, ``cv3d``, ``static2d``, ``static3d`` (``cv``, ``static``: the 2-D ones),
        ``curvilinear:M`` (``M`` a whole number of manoeuvres) or ``curvilinear``
        (= ``curvilinear:2``); case-insensitive.
    ref_time : float
        Reference time of the model's parameters (s); unused by stationary models.

    Returns
    -------
    MotionModel
        A new model; ``model.name`` is the canonical name (``curvilinear:2`` for
        ``curvilinear``).

    Raises
    ------
    ValueError
        For an unknown name, or a manoeuvre count that is not a whole number; the message
        names the accepted forms.

    References
    ----------
    Hörst & Oispuu (2010), eqs. 1-4, for the piecewise curvilinear model.
    """
    key = name.strip().lower()
    if key in _FIXED:
        cls, dim = _FIXED[key]
        return Stationary(dim) if cls is Stationary else ConstantVelocity(dim, ref_time)
    base, colon, count = (part.strip() for part in key.partition(":"))
    if base == "curvilinear":
        if not colon:
            return PiecewiseCurvilinear(DEFAULT_MANOEUVRES, ref_time)
        if count.isascii() and count.isdigit():
            return PiecewiseCurvilinear(int(count), ref_time)
        raise ValueError(f"motion {name!r}: expected curvilinear (= curvilinear:"
                         f"{DEFAULT_MANOEUVRES}) or curvilinear:M with M a whole number of "
                         "manoeuvres")
    raise ValueError(f"unknown motion model {name!r}; expected one of "
                     f"{', '.join(MOTION_NAMES)}")


def default_ref_time(times: ArrayLike) -> float:
    """Give the reference time of a motion model fitted to data at ``times``: near the data.

    0 when the data lie within one time span of it (as before: files that start at or near
    0 keep their parameters), else the first time.  Parameters referred to a time far from
    the data (an absolute clock, 1.7e9 s since 1970) would make the positions at the
    reference time depend on the velocities 1e9 times over and the fit ill-conditioned; so
    data shifted far from 0 give the same estimate and bound as data starting at 0.

    Parameters
    ----------
    times : array_like
        The measurement times (s).

    Returns
    -------
    float
        The reference time (s); 0 for no finite times.
    """
    t = np.asarray(times, dtype=float)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return 0.0
    low, high = float(t.min()), float(t.max())
    span = max(high - low, 1.0)
    return 0.0 if low - span <= 0.0 <= high + span else low
