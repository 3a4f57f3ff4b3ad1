"""The observation layer: measurement rows to predictions, Jacobians, noise and nuisance.

:class:`ObservationModel` (from motion parameters), :class:`MeasurementGroup` (from a filter
state), :class:`NoiseModel` (whitening) and the radar's :func:`radar_group`; the row core is
:mod:`tmakit.observation.rows`.
"""

from .groups import MeasurementGroup, group_times, radar_group, radar_rows
from .model import ObservationModel
from .noise import NoiseModel

__all__ = ["MeasurementGroup", "NoiseModel", "ObservationModel", "group_times", "radar_group",
           "radar_rows"]
