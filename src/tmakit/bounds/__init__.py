"""Bounds: Cramér–Rao lower bounds, observability, confidence ellipses."""

from .fim import Bound, crlb, fisher_information
from .noise import NoiseModel
from .observability import Direction, Observability, analyse

__all__ = ["Bound", "Direction", "NoiseModel", "Observability", "analyse", "crlb",
           "fisher_information"]
