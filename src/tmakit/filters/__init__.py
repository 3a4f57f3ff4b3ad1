"""Recursive tracking: one interface (:class:`TrackingFilter`) for every filter.

``FILTERS`` maps the names used by ``tma track --filter`` to the filter classes.
"""

from __future__ import annotations

from ..motion.dynamics import NearlyConstantVelocity, process_noise, state_names, transition_matrix
from ..observation.groups import MeasurementGroup, group_times
from .base import TrackingFilter
from .ekf import ExtendedKalmanFilter
from .extras import TrackExtras
from .mgekf import ModifiedGainEKF
from .multilag import multilag_groups
from .particle import ParticleFilter
from .record import UpdateInfo
from .track import Track
from .ukf import UnscentedKalmanFilter

FILTERS: dict[str, type[TrackingFilter]] = {
    ExtendedKalmanFilter.name: ExtendedKalmanFilter,
    UnscentedKalmanFilter.name: UnscentedKalmanFilter,
    ParticleFilter.name: ParticleFilter,
    ModifiedGainEKF.name: ModifiedGainEKF,
}

__all__ = [
    "FILTERS",
    "ExtendedKalmanFilter",
    "MeasurementGroup",
    "ModifiedGainEKF",
    "NearlyConstantVelocity",
    "ParticleFilter",
    "Track",
    "TrackExtras",
    "TrackingFilter",
    "UnscentedKalmanFilter",
    "UpdateInfo",
    "group_times",
    "multilag_groups",
    "process_noise",
    "state_names",
    "transition_matrix",
]
