"""Motion models by name: the one parser of the motion names tmakit accepts.

``cv2d`` (``cv``), ``cv3d``, ``static2d`` (``static``), ``static3d``, ``curvilinear:M`` (M
manoeuvres) and ``curvilinear`` (``curvilinear:2``, :data:`DEFAULT_MANOEUVRES`);
case-insensitive.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import finite_range
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
    """Make the motion model a name stands for (case-insensitive).

    Parameters
    ----------
    name : str
        ``cv2d``, ``cv3d``, ``static2d``, ``static3d``, ``cv``, ``static``, ``curvilinear:M``
        or ``curvilinear``.
    ref_time : float
        s; unused by stationary models.

    Returns
    -------
    MotionModel
        ``model.name`` is the canonical name.

    Raises
    ------
    ValueError
        For an unknown name or a bad manoeuvre count.

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
    """Give the reference time for data at ``times``: 0 when within one span of it, else the first.

    Parameters
    ----------
    times : array_like
        s.

    Returns
    -------
    float
    """
    finite = finite_range(np.asarray(times, dtype=float))
    if finite is None:
        return 0.0
    low, high = finite
    span = max(high - low, 1.0)
    return 0.0 if low - span <= 0.0 <= high + span else low
