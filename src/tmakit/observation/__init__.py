"""The observation layer: measurement rows to predictions, Jacobians, noise and nuisance.

:class:`RowModel` (the core), :class:`MeasurementGroup` (from a filter state),
:class:`ObservationModel` (from motion parameters), :class:`NoiseModel` (whitening) and
:func:`radar_group`.
"""

from .groups import (
    MeasurementGroup,
    group_times,
    radar_group,
    radar_rows,
    time_blocks,
    tonals_scaled,
)
from .model import ObservationModel
from .noise import NoiseModel
from .planar import Linearisation
from .rows import RowLayout, RowModel, nuisance_layout, resolve_models

__all__ = ["Linearisation", "MeasurementGroup", "NoiseModel", "ObservationModel", "RowLayout",
           "RowModel", "group_times", "nuisance_layout", "radar_group", "radar_rows",
           "resolve_models", "time_blocks", "tonals_scaled"]
