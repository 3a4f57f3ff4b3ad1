"""Units and physical constants.

tmakit works in SI inside: metres, seconds, radians, hertz, watts (power measurements in
decibels relative to one watt, dBW, because the nuisance constant enters linearly there).
Degrees, deg/s and dBm appear only at the edges (files, the command line, plots) and are
converted once, here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

SPEED_OF_LIGHT = 299_792_458.0
"""Speed of light in vacuum, m/s (the value 000_bc54bd8c50e47249.txt uses)."""

DBM_MINUS_DBW = 30.0
"""A power in dBm is its value in dBW plus 30."""


def deg2rad(x: ArrayLike) -> NDArray[np.float64]:
    """Degrees to radians."""
    return np.deg2rad(np.asarray(x, dtype=float))


def rad2deg(x: ArrayLike) -> NDArray[np.float64]:
    """Radians to degrees."""
    return np.rad2deg(np.asarray(x, dtype=float))


def db_to_linear(db: ArrayLike) -> NDArray[np.float64]:
    """A power ratio in decibels to a linear ratio."""
    return 10.0 ** (np.asarray(db, dtype=float) / 10.0)


def linear_to_db(ratio: ArrayLike) -> NDArray[np.float64]:
    """A (positive) linear power ratio to decibels."""
    return 10.0 * np.log10(np.asarray(ratio, dtype=float))


def dbm_to_dbw(dbm: ArrayLike) -> NDArray[np.float64]:
    """dBm to dBW."""
    return np.asarray(dbm, dtype=float) - DBM_MINUS_DBW


def dbw_to_dbm(dbw: ArrayLike) -> NDArray[np.float64]:
    """dBW to dBm."""
    return np.asarray(dbw, dtype=float) + DBM_MINUS_DBW


def snr_to_sigma_db(snr_db: float) -> float:
    """Standard deviation, in dB, of a received power whose relative noise has variance 1/SNR.

    000_bc54bd8c50e47249.txt §2 takes var(eta/P) = 1/SNR_p.  To first order the power in dB then
    has standard deviation (10/ln 10)/sqrt(SNR_p); this is the sigma written to files.
    """
    snr = 10.0 ** (snr_db / 10.0)
    return float(10.0 / np.log(10.0) / np.sqrt(snr))


def wavelength(frequency_hz: float) -> float:
    """Wavelength in metres of a carrier at `frequency_hz`."""
    return SPEED_OF_LIGHT / frequency_hz


def free_space_constant(frequency_hz: float) -> float:
    """C_0 = (lambda / 4 pi)^2, the free-space power constant of 000_bc54bd8c50e47249.txt §5.

    With unit transmit power and unit gains the received power is C_0 / R^2 watts.
    """
    return float((wavelength(frequency_hz) / (4.0 * np.pi)) ** 2)
