"""Units and physical constants: SI inside (power in dBW); degrees and dBm only at the edges."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

SPEED_OF_LIGHT = 299_792_458.0
"""Speed of light in vacuum, m/s (the value Gu et al. (2007) use)."""

REACH_M = 1e9
"""The farthest a position or a range may be from the local frame's origin, m: 2.6 times the
distance to the Moon.  Beyond it a number is a unit mistake or garbage, and a local
East-North-Up frame means nothing (:mod:`tmakit.rules`)."""

TIME_LIMIT_S = 1e10
"""The largest time (s, either side of the time origin) a measurement may carry: 317 years.
Epoch seconds stay below it until 2286; epoch milliseconds (1.7e12) and nanoseconds do not."""

DBM_MINUS_DBW = 30.0
"""A power in dBm is its value in dBW plus 30."""


def linear_to_db(ratio: ArrayLike) -> NDArray[np.float64]:
    """Convert a (positive) linear power ratio to decibels."""
    return 10.0 * np.log10(np.asarray(ratio, dtype=float))


def snr_to_sigma_db(snr_db: float) -> float:
    """Give the standard deviation (dB) of a power whose relative noise has variance 1/SNR.

    References
    ----------
    Gu et al. (2007), §2 (the noise model ``P_hat = P + eta``, ``var(eta / P) = 1 / SNR_p``).
    """
    snr = 10.0 ** (snr_db / 10.0)
    return float(10.0 / np.log(10.0) / np.sqrt(snr))


def free_space_constant(frequency_hz: float) -> float:
    """Give C_0 = (lambda / 4 pi)^2, the free-space power constant of Gu et al. (2007), §5.

    References
    ----------
    Gu et al. (2007), §5 (the simulation's power constant).
    """
    return float((SPEED_OF_LIGHT / frequency_hz / (4.0 * np.pi)) ** 2)
