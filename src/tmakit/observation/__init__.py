"""The observation layer: the one way measurement rows become predictions, Jacobians, noise
covariance and nuisance structure, for batch estimators, filters and bounds alike."""

from .groups import MeasurementGroup
from .model import Linearisation, ObservationModel
from .noise import NoiseModel

__all__ = ["Linearisation", "MeasurementGroup", "NoiseModel", "ObservationModel"]
