"""Target motion models: parameters theta -> target states at times, and d state / d theta."""

from .base import MotionModel, numerical_jacobian
from .constant_velocity import ConstantVelocity, Stationary
from .curvilinear import PiecewiseCurvilinear, propagate_curvilinear
from .fixed import FixedParameters

__all__ = [
    "ConstantVelocity",
    "FixedParameters",
    "MotionModel",
    "PiecewiseCurvilinear",
    "Stationary",
    "motion_from_name",
    "numerical_jacobian",
    "propagate_curvilinear",
]


def motion_from_name(name: str, ref_time: float = 0.0) -> MotionModel:
    """A motion model from its command-line name: ``cv2d``, ``cv3d``, ``static2d``,
    ``static3d`` (``static`` = ``static2d``), ``curvilinear[:M]``."""
    key = name.strip().lower()
    if key in ("cv2d", "cv"):
        return ConstantVelocity(2, ref_time)
    if key == "cv3d":
        return ConstantVelocity(3, ref_time)
    if key in ("static", "static2d"):
        return Stationary(2)
    if key == "static3d":
        return Stationary(3)
    if key.startswith("curvilinear"):
        _, _, m = key.partition(":")
        try:
            manoeuvres = int(m) if m else 0
        except ValueError:
            raise ValueError(f"motion {name!r}: expected curvilinear or curvilinear:M "
                             "with M a whole number of manoeuvres") from None
        return PiecewiseCurvilinear(manoeuvres, ref_time)
    raise ValueError(f"unknown motion model {name!r}; expected one of cv2d, cv3d, static2d, "
                     "static3d, curvilinear[:M]")
