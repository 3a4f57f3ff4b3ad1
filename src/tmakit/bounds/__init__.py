"""Bounds: Cramér–Rao lower bounds, observability, confidence ellipses; posterior CRB.

The posterior CRB is that of recursive trackers (Tichavský, Muravchik & Nehorai (1998)).
"""

from ..observation.noise import NoiseModel
from ..results.bound import Bound
from ..results.observability import Direction, Observability
from .fim import crlb
from .manoeuvre import CrbPoint, CrbSequence, curvilinear_crb_sequence
from .pcrb import PosteriorBound, deterministic_pcrb, posterior_crb
from .pcrb_recursion import PosteriorInformation, pcrb_over_runs

__all__ = ["Bound", "CrbPoint", "CrbSequence", "Direction", "NoiseModel", "Observability",
           "PosteriorBound", "PosteriorInformation", "crlb", "curvilinear_crb_sequence",
           "deterministic_pcrb", "pcrb_over_runs", "posterior_crb"]
