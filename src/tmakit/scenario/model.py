"""Scenario: what happens, and :meth:`Scenario.simulate` to observe it.

A scenario is the target motion and truth, the sensors' tracks and the measurement plans with
their noise; built in code or loaded from TOML (:mod:`tmakit.scenario.files`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import rules
from ..core.keywords import RngLike, as_generator
from ..core.units import snr_to_sigma_db
from ..data import MeasurementSet
from ..measurements import KINDS, interval_count, options_with_metadata
from ..measurements.codes import KIND_CODES
from ..measurements.tdoa import noise_form
from ..motion import MotionModel
from ..observation import ObservationModel
from ..sensors import SensorTrack

__all__ = ["MeasurementPlan", "Scenario", "simulate"]

#: Most pulse intervals a range-difference plan may span: the simulation draws one noise term
#: per interval (8 bytes each), and beyond int64 the interval count overflows.
MAX_PULSE_INTERVALS = 100_000_000
#: Largest |snr_db| of a power plan (10^30 as a power ratio).
MAX_SNR_DB = 300.0


@dataclass
class MeasurementPlan:
    """One stream of measurements: a kind from one sensor at given times, with its noise.

    Parameters
    ----------
    kind, sensor : str
        A key of :data:`tmakit.measurements.KINDS`; a key of :attr:`Scenario.sensors`.
    times : array_like
        Sample times, s, non-empty and increasing.
    sigma : float, optional
        Noise std, SI; for range differences that of one pulse interval.
    snr_db : float, optional
        Power only, instead of ``sigma``: SNR_p (dB) of ``P (1 + e)``, ``var(e) = 1/SNR_p``.
    pri, lags : float and tuple of int, optional
        Range differences only: the pulse repetition interval (s), the intervals back (>= 1).
    ref_sensor, noise, known_carrier : str, str and bool, optional
        ``tdoa``/``fdoa`` only: the reference sensor (required), ``"shared"`` (default) or
        ``"independent"`` noise, and (``fdoa``) whether the estimators are told the carrier.

    Raises
    ------
    ValueError
        If the kind is unknown, the times are empty or not increasing, or the noise or a
        difference's reference, interval or lags are missing or wrong.

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
    ref_sensor: str | None = None
    noise: str = "shared"
    known_carrier: bool = False

    def __post_init__(self) -> None:
        """Check the plan and normalise ``times`` (floats) and ``lags`` (ints)."""
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
            if not abs(self.snr_db) <= MAX_SNR_DB:  # 10^(SNR/10) overflowed at 1e300 dB
                raise ValueError(f"power from {self.sensor}: snr_db = {self.snr_db:g}; expected "
                                 f"an SNR within [-{MAX_SNR_DB:g}, {MAX_SNR_DB:g}] dB")
        elif self.sigma is None or not self.sigma > 0:
            raise ValueError(f"{self.kind} from {self.sensor}: sigma must be positive")
        if KINDS[self.kind].between_sensors:
            if self.ref_sensor is None or self.ref_sensor == self.sensor:
                raise ValueError(f"{self.kind} from {self.sensor}: name its reference sensor "
                                 "(ref_sensor), another sensor than the plan's own")
            self.noise = noise_form(self.noise, f"{self.kind} from {self.sensor}: noise")
        elif self.ref_sensor is not None:
            between = ", ".join(k for k, c in KINDS.items() if c.between_sensors)
            raise ValueError(f"{self.kind} from {self.sensor}: only differences between "
                             f"sensors ({between}) have a ref_sensor")
        elif KINDS[self.kind].uses_reference:  # range differences: pulse interval and lags
            if self.pri is None or not self.pri > 0:
                raise ValueError(f"{self.kind}: the pulse repetition interval pri (s) "
                                 "must be positive")
            if not self.lags or any(int(lag) < 1 for lag in self.lags):
                raise ValueError(f"{self.kind}: lags must be whole numbers >= 1")
            self.lags = tuple(int(lag) for lag in self.lags)
            span = float(self.times[-1] - self.times[0])
            if span < min(self.lags) * self.pri - 1e-9 * max(1.0, abs(float(self.times[0]))):
                raise ValueError(
                    f"{self.kind} from {self.sensor}: the sample times span {span:g} s, less "
                    f"than the shortest lag ({min(self.lags)} x pri {self.pri:g} s), so no "
                    "difference can be formed; sample over at least lag x pri seconds")
            if span / self.pri > MAX_PULSE_INTERVALS:
                raise ValueError(
                    f"{self.kind} from {self.sensor}: the sample times span {span:g} s, "
                    f"{span / self.pri:.3g} pulse intervals of pri {self.pri:g} s; at most "
                    f"{MAX_PULSE_INTERVALS:.0e} (the noise has one term per interval): give "
                    "the pulse repetition interval pri in seconds")


def _noisy_values(plan: MeasurementPlan, rows: MeasurementSet, clean: NDArray[np.float64],
                  gen: np.random.Generator, shared: dict[tuple[str, str, float], float]
                  ) -> NDArray[np.float64]:
    """Draw the plan's noise on its noise-free values (SI); ``shared``: one run's reference errors.

    References
    ----------
    Gu et al. (2007), §2 (power noise); Chen & Sun, eq. 1 (range differences from ΔTOA);
    Chan & Ho (1994) (differences against one reference sensor).
    """
    if plan.kind == "power" and plan.snr_db is not None:
        # Gu et al. (2007), §2: P_hat = P + eta with var(eta / P) = 1 / SNR_p.
        rel_noise = gen.standard_normal(clean.shape) / np.sqrt(10.0 ** (plan.snr_db / 10))
        if np.any(rel_noise <= -1.0):
            raise ValueError(f"power: SNR_p = {plan.snr_db} dB is too low for the "
                             "multiplicative noise model (a power came out negative); "
                             "give sigma in dB instead")
        return cast(NDArray[np.float64], clean + 10.0 * np.log10(1.0 + rel_noise))
    if KINDS[plan.kind].between_sensors and plan.noise == "shared":
        # sigma / sqrt(2) (own error - reference's): covariance sigma_i sigma_j (I + 11')/2
        own = gen.standard_normal(clean.shape)
        keys = [(plan.kind, str(plan.ref_sensor), t) for t in rows.time.tolist()]
        new = [k for k in dict.fromkeys(keys) if k not in shared]
        shared.update(zip(new, gen.standard_normal(len(new)).tolist(), strict=True))
        ref = np.array([shared[k] for k in keys])
        return cast(NDArray[np.float64], clean + rows.sigma_si * (own - ref) / np.sqrt(2.0))
    if KINDS[plan.kind].uses_reference and not KINDS[plan.kind].between_sensors:
        # One independent noise term per pulse interval, summed over each difference.
        assert plan.pri is not None and plan.sigma is not None
        t0 = float(rows.time_ref.min())
        end = interval_count(rows.time, t0, plan.pri)
        start = interval_count(rows.time_ref, t0, plan.pri)
        steps = gen.standard_normal(int(end.max()) + 1) * plan.sigma
        walk = np.concatenate([[0.0], np.cumsum(steps[1:])])
        return cast(NDArray[np.float64], clean + walk[end] - walk[start])
    return clean + gen.standard_normal(clean.shape) * rows.sigma_si


def _refuse_impossible(plan: MeasurementPlan, rows: MeasurementSet, clean: NDArray[np.float64],
                       value_si: NDArray[np.float64], rng: object) -> None:
    """Refuse a noisy draw no sensor can report (a negative range, ...); noise is never redrawn."""
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


@dataclass
class Scenario:
    """Motion model + true parameters + sensors + measurement plans (+ nuisance truth).

    Parameters
    ----------
    name, description, source : str
        Its name, one-line title and where it came from (a file path, for messages).
    motion, truth : MotionModel and dict of str to float
        The target's motion model and its true parameters by name, SI.
    sensors, plans : dict of str to SensorTrack and list of MeasurementPlan
    nuisance : dict of str to float, optional
        True ``carrier`` (Hz), ``carrier_drift`` (Hz/s), ``power_constant_db``,
        ``path_loss_exponent``.
    origin : tuple of float, optional
        ``(lat, lon, alt)`` (deg, deg, m) of the ENU origin.

    Attributes
    ----------
    theta : numpy.ndarray
        The true parameter vector (SI).

    Raises
    ------
    ValueError
        If a plan names an unknown sensor, a needed nuisance truth is missing, or ``truth`` does
        not name the motion's parameters.
    """

    name: str
    motion: MotionModel
    truth: dict[str, float]
    sensors: dict[str, SensorTrack]
    plans: list[MeasurementPlan]
    nuisance: dict[str, float] = field(default_factory=dict)
    description: str = ""
    origin: tuple[float, float, float] | None = None
    source: str = ""

    def __post_init__(self) -> None:
        """Set :attr:`theta` and check the plans against the sensors and the nuisance truth."""
        self.theta = self.motion.theta(self.truth)
        for plan in self.plans:
            for name in (plan.sensor, plan.ref_sensor):
                if name is not None and name not in self.sensors:
                    raise ValueError(f"{plan.kind} plan uses sensor {name!r}, which the "
                                     f"scenario does not define ({', '.join(self.sensors)})")
        kinds = {p.kind for p in self.plans}
        for kind in ("frequency", "fdoa"):
            if kind in kinds and "carrier" not in self.nuisance:
                raise ValueError(f"{kind} measurements need the emitter's carrier (Hz)")
        for kind in kinds:
            forms = {(p.noise, p.known_carrier) for p in self.plans if p.kind == kind}
            if KINDS[kind].between_sensors and len(forms) > 1:
                raise ValueError(f"the {kind} plans differ in their noise form or known "
                                 "carrier: one form per kind")
        if "power" in kinds and "power_constant_db" not in self.nuisance:
            raise ValueError("power measurements need the emitter's power constant")

    @property
    def kinds(self) -> list[str]:
        """Measurement kinds of the plans, in the order of :data:`~tmakit.measurements.KINDS`."""
        return [k for k in KINDS if k in {p.kind for p in self.plans}]

    @property
    def measurement_options(self) -> dict[str, dict[str, object]]:
        """Model options that reproduce the truth, by kind."""
        opts: dict[str, dict[str, object]] = {}
        if "frequency" in self.kinds:
            opts["frequency"] = {"drift": self.nuisance.get("carrier_drift", 0.0) != 0.0}
        if "power" in self.kinds:
            opts["power"] = {"exponent": self.nuisance.get("path_loss_exponent", 2.0)}
        opts.update(options_with_metadata(self.kinds, None, self._between_metadata()))
        return opts

    def _between_metadata(self) -> dict[str, str]:
        """Give the metadata the kinds read: noise form, known carrier, the ENU origin."""
        meta: dict[str, str] = {}
        for plan in self.plans:
            if plan.noise == "independent":
                meta[f"{plan.kind}_noise"] = "independent"
            if plan.kind == "fdoa" and plan.known_carrier:
                meta["fdoa_carrier"] = repr(float(self.nuisance["carrier"]))
        if self.origin is not None:
            meta.update(zip(("origin_lat", "origin_lon", "origin_alt"),
                            (repr(float(v)) for v in self.origin), strict=True))
        return meta

    def time_span(self) -> tuple[float, float]:
        """Give the first and last sample time of the plans.

        Returns
        -------
        tuple of float
            ``(t_first, t_last)``, s.
        """
        return (min(float(p.times[0]) for p in self.plans),
                max(float(p.times[-1]) for p in self.plans))

    def target_states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the true target states ``(n, 6)`` (ENU, m and m/s) at times ``t`` (s).

        Parameters
        ----------
        t : array_like

        Returns
        -------
        numpy.ndarray
        """
        return self.motion.states(self.theta, np.atleast_1d(np.asarray(t, dtype=float)))

    def _layout(self, plan: MeasurementPlan,
                states: dict[tuple[str, bytes], NDArray[np.float64]]) -> MeasurementSet:
        """Lay out the rows of one plan with noise-free placeholders for value and sigma."""
        track = self.sensors[plan.sensor]
        model = KINDS[plan.kind]
        if model.between_sensors:  # against the reference sensor at the same times
            assert plan.ref_sensor is not None  # MeasurementPlan refuses one without it
            times = time_ref = plan.times
            ref_state = self.sensors[plan.ref_sensor].states(times)
            sigma_si = np.full(times.shape, float(plan.sigma or 0.0))
        elif model.uses_reference:  # differences with earlier samples, lags back
            t_all, t_ref_all, lag_all = [], [], []
            assert plan.pri is not None  # MeasurementPlan refuses a difference without it
            pri = plan.pri
            for lag in plan.lags:
                t_ref = plan.times - lag * pri
                keep = t_ref >= plan.times[0] - 1e-9 * max(1.0, abs(plan.times[0]))
                t_all.append(plan.times[keep])
                t_ref_all.append(t_ref[keep])
                lag_all.append(np.full(int(keep.sum()), lag))
            order = np.lexsort((np.concatenate(lag_all), np.concatenate(t_all)))
            times = np.concatenate(t_all)[order]
            time_ref = np.concatenate(t_ref_all)[order]
            sigma_si = plan.sigma * np.sqrt(np.concatenate(lag_all)[order])
            ref_state = track.states(time_ref)
        else:
            times, time_ref, ref_state = plan.times, None, None
            sigma_si = np.full(times.shape, plan.sigma if plan.sigma is not None
                               else snr_to_sigma_db(float(plan.snr_db or 0.0)))
        n = times.shape[0]
        key = (plan.sensor, times.tobytes())
        if key not in states:
            states[key] = track.states(times)
        return MeasurementSet._of_codes(  # values: simulate_values
            np.array(times, dtype=float), np.zeros(n, dtype=np.int32), (str(plan.sensor),),
            np.full(n, KIND_CODES[plan.kind], dtype=np.int8), np.zeros(n),
            np.array(sigma_si, dtype=float), states[key],
            None if time_ref is None else np.array(time_ref, dtype=float), ref_state, {})

    def simulate(self, rng: RngLike = None, noise: bool = True) -> MeasurementSet:
        """Observe the scenario: rows by sensor in time order, with metadata (an int seed too).

        Parameters
        ----------
        rng : numpy.random.Generator, int or None, optional
        noise : bool, optional
            Add the plans' noise (False: exact predictions).

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            If a power becomes negative, or a row breaks a rule of :mod:`tmakit.rules`.
        """
        return self.simulate_many([rng], noise)[0]

    def simulate_many(self, rngs: Sequence[RngLike], noise: bool = True
                      ) -> list[MeasurementSet]:
        """Observe the scenario once per random source (``[simulate(r) for r in rngs]``).

        Parameters
        ----------
        rngs : sequence of numpy.random.Generator, int or None
        noise : bool, optional

        Returns
        -------
        list of MeasurementSet

        Raises
        ------
        ValueError
            As :meth:`simulate`.
        """
        template, values = self.simulate_values(rngs, noise)
        out = []
        for i, (rng, value_si) in enumerate(zip(rngs, values, strict=True)):
            # (the template, made for this call, is the last set)
            meas = template if i == len(rngs) - 1 else template.take(np.arange(len(template)))
            meas.value_si = value_si
            if isinstance(rng, int):
                meas.metadata["seed"] = str(rng)
            out.append(meas)
        return out

    def simulate_values(self, rngs: Sequence[RngLike], noise: bool = True
                        ) -> tuple[MeasurementSet, NDArray[np.float64]]:
        """Observe the scenario once per random source: the shared rows and each run's values.

        Parameters
        ----------
        rngs : sequence of numpy.random.Generator, int or None
        noise : bool, optional

        Returns
        -------
        template : MeasurementSet
            The rows with their noise-free values.
        values : ndarray, shape (len(rngs), n)
            Each run's values, SI, as :meth:`simulate` draws them.

        Raises
        ------
        ValueError
            As :meth:`simulate`.
        """
        plans = []  # (plan, rows, noise-free values SI, model), in plan order
        states: dict[tuple[str, bytes], NDArray[np.float64]] = {}
        targets: dict[bytes, NDArray[np.float64]] = {}  # the target's states, by times
        options = self.measurement_options
        for plan in self.plans:
            rows = self._layout(plan, states)
            self._refuse_coincident(plan, rows, targets)
            obs = ObservationModel(rows, self.motion, options)
            clean = obs.predict(self.theta, obs.nuisance_vector(self.nuisance))
            plans.append((plan, rows, clean, obs.models[plan.kind].wrap_period))
        template, order = self._template([rows for _, rows, _, _ in plans], noise)
        values = np.empty((len(rngs) + 1, len(template)))  # the last: noise-free
        for i in range(len(rngs) + 1):
            gen = as_generator(rngs[i]) if noise and i < len(rngs) else None
            shared: dict[tuple[str, str, float], float] = {}  # the reference sensors' errors
            parts = [clean if gen is None else _noisy_values(plan, rows, clean, gen, shared)
                     for plan, rows, clean, _ in plans]
            for k, (plan, rows, clean, period) in enumerate(plans):
                if period is not None:  # files carry bearings in [0, 360) deg
                    parts[k] = np.mod(parts[k], period)
                if gen is not None:
                    _refuse_impossible(plan, rows, clean, parts[k], rngs[i])
            values[i] = np.concatenate(parts)[order]
        template.value_si, values = values[-1], values[:-1]
        # NaN truth, infinite sigma, ...: the first set that breaks a rule names its rows, as
        # simulate() would.
        for i in np.flatnonzero(~np.isfinite(values).all(axis=1)).tolist():
            bad = template.take(np.arange(len(template)))
            bad.value_si = values[i]
            rules.check_set(bad, order=False)
        rules.check_set(template)  # the file's rules, time order and value ranges too
        return template, values

    def _template(self, parts: list[MeasurementSet], noise: bool
                  ) -> tuple[MeasurementSet, NDArray[np.int64]]:
        """Join the plans' rows in one set (by sensor, in time order); give the order too."""
        meta = {
            "scenario": self.name,
            "motion": self.motion.name,
            "truth": json.dumps(self.truth, sort_keys=True),
            "noise": "yes" if noise else "no",
        }
        ref_time = getattr(self.motion, "ref_time", None)
        if ref_time is not None:
            meta["ref_time"] = repr(float(ref_time))
        if self.nuisance:
            meta["nuisance"] = json.dumps(self.nuisance, sort_keys=True)
        meta.update(self._between_metadata())
        n = [rows.time.shape[0] for rows in parts]
        for rows, start in zip(parts, np.cumsum([0, *n[:-1]]), strict=True):
            rows.value_si = start + np.arange(rows.time.shape[0], dtype=float)
        template = MeasurementSet.concatenate(parts, meta)
        return template, template.value_si.astype(int)

    def _refuse_coincident(self, plan: MeasurementPlan, rows: MeasurementSet,
                           targets: dict[bytes, NDArray[np.float64]]) -> None:
        """Refuse a target out of reach (the file's rules) or exactly at a sensor."""
        key = rows.time.tobytes()
        if key not in targets:
            with np.errstate(all="ignore"):
                states = np.asarray(self.motion.states(self.theta, rows.time), dtype=float)
            within = rules.state_within_reach(states)
            if not within.all():
                j = int(np.flatnonzero(~within.all(axis=0))[0])
                i = int(np.flatnonzero(~within[:, j])[0])
                raise ValueError(f"the target's {('x', 'y', 'z', 'vx', 'vy', 'vz')[j]} at t = "
                                 f"{rows.time[i]:g} s is {states[i, j]:g}: expected "
                                 f"{rules.POSITION if j < 3 else rules.VELOCITY}")
            targets[key] = states
        target, sensor = targets[key], rows.sensor_state
        if not (target[:, 0] == sensor[:, 0]).any():  # (the whole test where x meets)
            return
        at = np.flatnonzero(np.all(target[:, :3] == sensor[:, :3], axis=1))
        if at.size:
            raise ValueError(f"the target is exactly at sensor {plan.sensor!r} at t = "
                             f"{rows.time[at[0]]:g} s: its {plan.kind} is undefined there")

    def summary(self) -> str:
        """Describe the scenario in a few lines.

        Returns
        -------
        str
        """
        t0, t1 = self.time_span()
        truth = ", ".join(f"{k}={v:g}" for k, v in self.truth.items())
        lines = [f"{self.name}: {self.description}".rstrip(": "),
                 f"  target: {self.motion.name}, {truth}",
                 f"  sensors: {', '.join(self.sensors)}; samples {t0:g}..{t1:g} s"]
        for p in self.plans:
            model = KINDS[p.kind]
            noise = (f"SNR_p {p.snr_db:g} dB" if p.snr_db is not None else
                     f"sigma {model().sigma_from_si(p.sigma or 0.0):g} {model.file_unit}")
            lines.append(f"  {p.kind} from {p.sensor}: {p.times.size} samples, {noise}")
        return "\n".join(lines)


def simulate(scenario: Scenario, rng: RngLike = None, noise: bool = True) -> MeasurementSet:
    """Observe ``scenario``: the function form of :meth:`Scenario.simulate`.

    Parameters
    ----------
    scenario : Scenario
    rng : numpy.random.Generator, int or None, optional
    noise : bool, optional

    Returns
    -------
    MeasurementSet

    Raises
    ------
    ValueError
        As :meth:`Scenario.simulate`.
    """
    return scenario.simulate(rng, noise)

