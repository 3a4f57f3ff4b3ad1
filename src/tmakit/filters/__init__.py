"""Recursive tracking: one interface (:class:`TrackingFilter`) for every filter.

``FILTERS`` maps the names used by ``tma track --filter`` to the filter classes.
"""

from __future__ import annotations

from ..motion.dynamics import NearlyConstantVelocity, process_noise, state_names, transition_matrix
from ..observation.groups import MeasurementGroup, group_times
from .base import FilterSettings, TrackingFilter
from .bearing_prior import BearingPrior, FirstBearing, first_bearing
from .ekf import ExtendedKalmanFilter
from .gaussian_sum import GaussianSumFilter
from .imm import InteractingMultipleModel, MultipleModelParticleFilter
from .mgekf import ModifiedGainEKF
from .modified_polar import ModifiedPolarEKF
from .multilag import multilag_groups
from .particle import ParticleFilter
from .smoothing import smooth
from .track import Track, TrackExtras, UpdateInfo
from .ukf import CubatureKalmanFilter, UnscentedKalmanFilter

FILTERS: dict[str, type[TrackingFilter]] = {cls.name: cls for cls in (
    ExtendedKalmanFilter, UnscentedKalmanFilter, ParticleFilter, ModifiedGainEKF,
    CubatureKalmanFilter, GaussianSumFilter, InteractingMultipleModel, ModifiedPolarEKF,
    MultipleModelParticleFilter)}

__all__ = [
    "FILTERS",
    "BearingPrior",
    "CubatureKalmanFilter",
    "ExtendedKalmanFilter",
    "FilterSettings",
    "FirstBearing",
    "GaussianSumFilter",
    "InteractingMultipleModel",
    "MeasurementGroup",
    "ModifiedGainEKF",
    "ModifiedPolarEKF",
    "MultipleModelParticleFilter",
    "NearlyConstantVelocity",
    "ParticleFilter",
    "Track",
    "TrackExtras",
    "TrackingFilter",
    "UnscentedKalmanFilter",
    "UpdateInfo",
    "first_bearing",
    "group_times",
    "multilag_groups",
    "process_noise",
    "smooth",
    "state_names",
    "transition_matrix",
]
