"""The moving radar of Hurtado & Nehorai (2008): its array signal model and what it measures.

:class:`RadarModel` gives the Fisher information of the array signal model (section 2.2, eqs. 4-6)
about azimuth, elevation, delay and Doppler, the amplitude eliminated by the Schur complement
(Stoica & Nehorai (1989)); the covariance of tmakit's bearing, elevation, range and range rate
(mono-static Doppler ``f_D = -2 rdot / lambda``); and the state information ``Xi`` (eq. 13).
``range_accuracy="resolution"`` replaces the range sigma by ``c / (2 B)``; docs/radar_model.md
has the derivation and the numbers.

References
----------
Hurtado, M. and Nehorai, A. (2008), "Adaptive path design of a moving radar", eqs. 4-6, 13,
section 5.  Kershaw, D. J. and Evans, R. J. (1994), "Optimal waveform selection for tracking
systems".  Stoica, P. and Nehorai, A. (1989), "MUSIC, maximum likelihood, and Cramér-Rao bound".
"""

from .geometry import elevation_of, measurement_jacobian, measurements, relative_states
from .model import HURTADO_NEHORAI_2008_RADAR, RADAR_KINDS, RadarModel

__all__ = ["HURTADO_NEHORAI_2008_RADAR", "RADAR_KINDS", "RadarModel", "elevation_of",
           "measurement_jacobian", "measurements", "relative_states"]
