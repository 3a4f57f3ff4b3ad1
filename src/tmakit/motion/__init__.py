"""Target motion models: parameters theta -> target states at times, and d state / d theta.

Models by name (``cv2d``, ``curvilinear:M``, ...) come from :func:`motion_from_name`
(:mod:`tmakit.motion.names`, the one parser of motion names).
"""

from .base import FixedParameters, MotionModel
from .constant_velocity import ConstantVelocity, Stationary
from .curvilinear import PiecewiseCurvilinear, propagate_curvilinear
from .names import default_ref_time, motion_from_name

__all__ = ["ConstantVelocity", "FixedParameters", "MotionModel", "PiecewiseCurvilinear",
           "Stationary", "default_ref_time", "motion_from_name", "propagate_curvilinear"]
