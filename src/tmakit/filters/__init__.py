"""Recursive tracking: one interface (:class:`TrackingFilter`) for every filter.

``FILTERS`` maps the names used by ``tma track --filter`` to the filter classes.
"""

from __future__ import annotations

from .base import Track, TrackingFilter, UpdateInfo, group_times
from .dynamics import NearlyConstantVelocity, process_noise, state_names, transition_matrix
from .ekf import ExtendedKalmanFilter
from .measurement_group import MeasurementGroup

FILTERS: dict[str, type[TrackingFilter]] = {
    ExtendedKalmanFilter.name: ExtendedKalmanFilter,
}

__all__ = [
    "FILTERS",
    "ExtendedKalmanFilter",
    "MeasurementGroup",
    "NearlyConstantVelocity",
    "Track",
    "TrackingFilter",
    "UpdateInfo",
    "group_times",
    "process_noise",
    "state_names",
    "transition_matrix",
]
