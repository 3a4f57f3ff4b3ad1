"""The observation layer: measurement rows to predictions, Jacobians, noise and nuisance.

It is the one way rows become predictions, Jacobians, noise covariance and nuisance
structure, for batch estimators, filters and bounds alike.

* :class:`RowModel` (``rows.py``): the core — rows of several kinds predicted from relative
  states by their measurement models, vectorised over rows, states and sensor poses; noise
  covariance and nuisance structure from the kinds' hooks.
* :class:`MeasurementGroup` (``groups.py``): rows predicted from a filter state
  ``[position, velocity]`` (filters, the posterior CRB, planners).
* :class:`ObservationModel` (``model.py``): rows predicted from motion parameters (batch
  estimators, the CRLB).
* :class:`NoiseModel` (``noise.py``): whitening by the noise covariance.
* :func:`radar_group` (``radar.py``): the radar's rows with its full covariance.
"""

from .groups import MeasurementGroup, group_times, time_blocks
from .linearisation import Linearisation
from .model import ObservationModel
from .noise import NoiseModel
from .radar import radar_group, radar_rows
from .rows import RowLayout, RowModel, nuisance_layout, resolve_models

__all__ = ["Linearisation", "MeasurementGroup", "NoiseModel", "ObservationModel", "RowLayout",
           "RowModel", "group_times", "nuisance_layout", "radar_group", "radar_rows",
           "resolve_models", "time_blocks"]
