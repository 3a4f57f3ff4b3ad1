"""A measurement plan (a kind from one sensor at given times) and the noise it draws.

:class:`MeasurementPlan` says what is measured and with what noise; :func:`noisy_values` draws
that noise on the noise-free values, and :func:`refuse_impossible` refuses a draw no sensor
could report.  :mod:`tmakit.scenario` puts plans, sensors and a target together.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import NDArray

from .data import MeasurementSet
from .measurements import KINDS, interval_count

__all__ = ["MeasurementPlan", "noisy_values", "refuse_impossible"]


@dataclass
class MeasurementPlan:
    """One stream of measurements: a kind from one sensor at given times, with its noise.

    Parameters
    ----------
    kind : str
        Measurement kind, a key of :data:`tmakit.measurements.KINDS` (``"bearing"``,
        ``"frequency"``, ``"power"``, ``"range_difference"``, ...).
    sensor : str
        Id of the sensor (a key of :attr:`Scenario.sensors`).
    times : array_like
        Sample times (s), non-empty and increasing.
    sigma : float, optional
        Noise standard deviation in SI (rad for angles, rad/s for azimuth rate, dB for
        power, Hz, m, m/s).  For range differences: that of one pulse interval's difference.
    snr_db : float, optional
        Power only, instead of ``sigma``: SNR_p (dB) of the multiplicative noise
        ``P_measured = P (1 + e)``, ``var(e) = 1/SNR_p`` (Gu et al. (2007), §2).
    pri : float, optional
        Range differences only: the pulse repetition interval (s, > 0).
    lags : tuple of int, optional
        Range differences only: how many intervals back each difference reaches (>= 1);
        the noise accumulates one term per interval (Chen & Sun, eq. 1).

    Raises
    ------
    ValueError
        If the kind is unknown, the times are empty or not increasing, ``sigma`` is missing
        or not positive (power: both ``sigma`` and ``snr_db`` given), or a range-difference
        plan has no positive ``pri`` or a lag below 1.

    References
    ----------
    Gu et al. (2007), §2 (power noise); Chen & Sun, eq. 1 (range differences from ΔTOA).
    """

    kind: str
    sensor: str
    times: NDArray[np.float64]
    sigma: float | None = None
    snr_db: float | None = None
    pri: float | None = None
    lags: tuple[int, ...] = (1,)

    def __post_init__(self) -> None:
        """Check the plan and normalise ``times`` (float array) and ``lags`` (ints)."""
        if self.kind not in KINDS:
            raise ValueError(f"unknown measurement kind {self.kind!r}; expected one of "
                             f"{', '.join(KINDS)}")
        self.times = np.atleast_1d(np.asarray(self.times, dtype=float))
        if self.times.ndim != 1 or self.times.size == 0 or np.any(np.diff(self.times) <= 0):
            raise ValueError(f"{self.kind} from {self.sensor}: sample times must be a "
                             "non-empty increasing list")
        if self.kind == "power" and self.snr_db is not None:
            if self.sigma is not None:
                raise ValueError("power: give either snr_db or sigma, not both")
        elif self.sigma is None or not self.sigma > 0:
            raise ValueError(f"{self.kind} from {self.sensor}: sigma must be positive")
        if KINDS[self.kind].uses_reference:  # range differences: pulse interval and lags
            if self.pri is None or not self.pri > 0:
                raise ValueError(f"{self.kind}: the pulse repetition interval pri (s) "
                                 "must be positive")
            if not self.lags or any(int(lag) < 1 for lag in self.lags):
                raise ValueError(f"{self.kind}: lags must be whole numbers >= 1")
            self.lags = tuple(int(lag) for lag in self.lags)


def noisy_values(plan: MeasurementPlan, rows: MeasurementSet, clean: NDArray[np.float64],
                 gen: np.random.Generator) -> NDArray[np.float64]:
    """Draw the plan's measurement noise on its noise-free values.

    Parameters
    ----------
    plan : MeasurementPlan
        The plan whose noise is drawn (``sigma``, ``snr_db`` or ``pri``).
    rows : MeasurementSet
        The plan's rows (times, reference times, SI sigmas).
    clean : ndarray, shape (n,)
        The noise-free values (SI).
    gen : numpy.random.Generator
        The random source.

    Returns
    -------
    ndarray, shape (n,)
        The noisy values (SI).

    Raises
    ------
    ValueError
        If a power plan's SNR_p is so low that the multiplicative noise makes a power
        negative.

    References
    ----------
    Gu et al. (2007), §2 (power noise); Chen & Sun, eq. 1 (range differences from ΔTOA).
    """
    if plan.kind == "power" and plan.snr_db is not None:
        # Gu et al. (2007), §2: P_hat = P + eta with var(eta / P) = 1 / SNR_p.
        rel_noise = gen.standard_normal(clean.shape) / np.sqrt(10.0 ** (plan.snr_db / 10))
        if np.any(rel_noise <= -1.0):
            raise ValueError(f"power: SNR_p = {plan.snr_db} dB is too low for the "
                             "multiplicative noise model (a power came out negative); "
                             "give sigma in dB instead")
        return cast(NDArray[np.float64], clean + 10.0 * np.log10(1.0 + rel_noise))
    if KINDS[plan.kind].uses_reference:
        # One independent noise term per pulse interval, summed over each difference.
        assert plan.pri is not None and plan.sigma is not None
        t0 = float(rows.time_ref.min())
        end = interval_count(rows.time, t0, plan.pri)
        start = interval_count(rows.time_ref, t0, plan.pri)
        steps = gen.standard_normal(int(end.max()) + 1) * plan.sigma
        walk = np.concatenate([[0.0], np.cumsum(steps[1:])])
        return cast(NDArray[np.float64], clean + walk[end] - walk[start])
    return clean + gen.standard_normal(clean.shape) * rows.sigma_si


def refuse_impossible(plan: MeasurementPlan, rows: MeasurementSet, clean: NDArray[np.float64],
                      value_si: NDArray[np.float64], rng: object) -> None:
    """Refuse a noisy draw that no sensor can report: a negative range, ... (see docs).

    The noise is not reflected nor drawn again: either would change the Gaussian noise
    that the estimators and the bounds assume, without a word.

    Parameters
    ----------
    plan : MeasurementPlan
        The plan the values were drawn for.
    rows : MeasurementSet
        The plan's rows (times, SI sigmas).
    clean : ndarray, shape (n,)
        The noise-free values (SI).
    value_si : ndarray, shape (n,)
        The noisy values (SI).
    rng : object
        The random source or seed (an int seed is named in the message).

    Raises
    ------
    ValueError
        If a finite noisy value is outside the kind's range (a negative range, an
        elevation past 90 deg, a frequency <= 0, ...), naming sensor, time and seed.
    """
    cls = KINDS[plan.kind]
    if cls.value_range is None:
        return
    model = cls()
    value = model.value_from_si(value_si)
    bad = np.flatnonzero(np.isfinite(value) & ~cls.check_values(value))
    if bad.size == 0:
        return
    i = int(bad[0])
    seed = f" with seed {rng}" if isinstance(rng, int) else ""
    raise ValueError(
        f"the noise drew an impossible {plan.kind}{seed}: sensor {plan.sensor!r} at t = "
        f"{rows.time[i]:g} s gives {value[i]:g} {cls.file_unit} (noise-free "
        f"{model.value_from_si(clean[i]):g}, sigma "
        f"{model.sigma_from_si(rows.sigma_si[i]):g}), expected {cls.describe_values()}; "
        f"{bad.size} of {value.size} rows of this plan.  The Gaussian noise model does not "
        "hold this close to the limit: lower the plan's sigma (or keep the target "
        "farther from the limit)")
