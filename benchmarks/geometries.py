"""Random scenarios for the blind-start study (``blind_start.py``, ``tests/test_blind_start.py``).

:func:`random_geometry` draws one two-dimensional constant-velocity target heard by one manoeuvring
sensor with a random mix of bearing, frequency and power measurements; :func:`observable_geometry`
redraws until the Cramér–Rao bound says the geometry can be localised.  Every draw is uniform
over the ranges of the constants below (the target's start uniform in area over the annulus
:data:`MIN_DISTANCE`-:data:`MAX_DISTANCE`) and comes from the Generator passed in.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tmakit.bounds import crlb
from tmakit.core.units import free_space_constant, linear_to_db
from tmakit.motion import ConstantVelocity
from tmakit.scenario import MeasurementPlan, Scenario
from tmakit.sensors import Leg, LegsTrack

#: The measurement kinds a random geometry mixes.
STUDY_KINDS: tuple[str, ...] = ("bearing", "frequency", "power")

MAX_DISTANCE = 20_000.0  # Largest distance (m) of the target from the sensor's start at time 0.
MIN_DISTANCE = 500.0  # Smallest distance (m) of the target from the sensor's start at time 0.
MAX_TARGET_SPEED = 40.0  # Largest target speed (m/s).
SENSOR_SPEED = (30.0, 80.0)  # Range of the sensor's speed (m/s).
TURN_RATE_DEG_S = (1.0, 4.0)  # Range of the magnitude of the sensor's turn rates (°/s).
LEG_DURATION = (20.0, 60.0)  # Range of the duration of one leg (s).
LEG_COUNTS = (3, 4, 5)  # Possible numbers of legs.
OBSERVATION_TIME = (120.0, 300.0)  # Range of the total observation time (s).
SAMPLE_INTERVALS = (1.0, 2.0)  # Possible sample intervals (s).
BEARING_SIGMA_DEG = (0.5, 2.0)  # Range of the bearing noise standard deviation (°).
CARRIER_HZ = (0.5e9, 10e9)  # Range of the carrier frequency (Hz).
FREQUENCY_SIGMA_HZ = (0.5, 3.0)  # Range of the frequency noise standard deviation (Hz).
SNR_DB = (25.0, 45.0)  # Range of the power measurements' SNR_p (dB).


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def _leg_durations(rng: np.random.Generator, total: float, n: int) -> NDArray[np.float64]:
    """``n`` durations in ``LEG_DURATION`` summing to ``total`` (uniform on that set)."""
    lo, hi = LEG_DURATION
    s = (total - n * lo) / (hi - lo)  # sum of n fractions in [0, 1]
    flip = s > n / 2.0                # sample the complement: keeps acceptance high
    target = n - s if flip else s
    for _ in range(10_000):
        u = rng.dirichlet(np.ones(n)) * target
        if np.all(u <= 1.0):
            break
    else:  # pragma: no cover - acceptance is above a few per cent for n <= 5
        u = np.full(n, target / n)
    if flip:
        u = 1.0 - u
    return lo + (hi - lo) * u


def random_sensor(rng: np.random.Generator) -> tuple[LegsTrack, float]:
    """Draw a manoeuvring :class:`~tmakit.sensors.LegsTrack` from the origin."""
    total = _uniform(rng, OBSERVATION_TIME)
    lo, hi = LEG_DURATION
    counts = [n for n in LEG_COUNTS if n * lo <= total <= n * hi]
    n = int(rng.choice(counts))
    durations = _leg_durations(rng, total, n)
    first_turns = bool(rng.integers(2))
    legs = []
    for i, d in enumerate(durations):
        turning = (i % 2 == 0) == first_turns
        rate = 0.0
        if turning:
            rate = float(np.radians(_uniform(rng, TURN_RATE_DEG_S)) * rng.choice((-1.0, 1.0)))
        legs.append(Leg(float(d), rate))
    speed = _uniform(rng, SENSOR_SPEED)
    heading = float(rng.uniform(0.0, 2.0 * np.pi))
    return LegsTrack((0.0, 0.0), heading, speed, legs), float(durations.sum())


def random_geometry(rng: np.random.Generator, kinds: Sequence[str] | None = None
                    ) -> Scenario:
    """Draw a random 2-D constant-velocity target heard by one manoeuvring sensor."""
    if kinds is not None:
        kinds = tuple(kinds)
        unknown = [k for k in kinds if k not in STUDY_KINDS]
        if not kinds or unknown:
            raise ValueError(f"kinds must be a non-empty subset of {', '.join(STUDY_KINDS)}; "
                             f"got {', '.join(kinds) or 'none'}")
    # Target at time 0: uniform in area over the annulus around the sensor's start.
    r = float(np.sqrt(rng.uniform(MIN_DISTANCE**2, MAX_DISTANCE**2)))
    b = float(rng.uniform(0.0, 2.0 * np.pi))
    speed = float(rng.uniform(0.0, MAX_TARGET_SPEED))
    course = float(rng.uniform(0.0, 2.0 * np.pi))
    truth = {"x": r * np.sin(b), "y": r * np.cos(b),
             "vx": speed * np.sin(course), "vy": speed * np.cos(course)}
    track, total = random_sensor(rng)
    dt = float(rng.choice(SAMPLE_INTERVALS))
    times = np.arange(0.0, total + 1e-9, dt)
    if kinds is None:
        subset = int(rng.integers(1, 2 ** len(STUDY_KINDS)))  # bit mask, never empty
        kinds = tuple(k for i, k in enumerate(STUDY_KINDS) if subset >> i & 1)
    carrier = _uniform(rng, CARRIER_HZ)
    plans = []
    noise = []
    for k in STUDY_KINDS:
        if k not in kinds:
            continue
        if k == "bearing":
            sigma_deg = _uniform(rng, BEARING_SIGMA_DEG)
            plans.append(MeasurementPlan(k, "sensor", times, sigma=float(np.radians(sigma_deg))))
            noise.append(f"bearing {sigma_deg:.2f} deg")
        elif k == "frequency":
            sigma_hz = _uniform(rng, FREQUENCY_SIGMA_HZ)
            plans.append(MeasurementPlan(k, "sensor", times, sigma=sigma_hz))
            noise.append(f"frequency {sigma_hz:.2f} Hz")
        else:
            snr = _uniform(rng, SNR_DB)
            plans.append(MeasurementPlan(k, "sensor", times, snr_db=snr))
            noise.append(f"power SNR_p {snr:.1f} dB")
    nuisance = {"carrier": carrier,
                "power_constant_db": float(linear_to_db(free_space_constant(carrier))),
                "path_loss_exponent": 2.0}
    description = (f"random geometry: target {r / 1000:.2f} km, {speed:.1f} m/s; sensor "
                   f"{track.speed:.0f} m/s, {len(track.legs)} legs, {total:.0f} s every "
                   f"{dt:g} s; carrier {carrier / 1e9:.3f} GHz; " + ", ".join(noise))
    return Scenario("random-geometry", ConstantVelocity(2, ref_time=0.0), truth,
                    {"sensor": track}, plans, nuisance, description)


def position_std(scenario: Scenario, t: float | None = None) -> float:
    """Return the CRB on the horizontal position error (nuisance parameters unknown).

    References
    ----------
    Gu et al. (2007), eqs. 17–18: the Fisher information of power and Doppler rows, of which
    the bound's ``Jᵀ R⁻¹ J`` is the general form.
    """
    bound = crlb(scenario)
    if not bound.observability.full_rank:
        return float("inf")
    if t is None:
        t = 0.5 * sum(scenario.time_span())
    _, cov = bound.state_covariance(t)
    var = cov[0, 0] + cov[1, 1]
    return float(np.sqrt(var)) if np.isfinite(var) and var >= 0 else float("inf")


def observable_geometry(rng: np.random.Generator, max_position_std: float = 2000.0,
                        max_tries: int = 100, kinds: Sequence[str] | None = None
                        ) -> Scenario:
    """Draw a :func:`random_geometry` that is *observable*, redrawn until it is."""
    best = float("inf")
    for _ in range(max_tries):
        scenario = random_geometry(rng, kinds)
        std = position_std(scenario)
        if std < max_position_std:
            return scenario
        best = min(best, std)
    raise RuntimeError(f"no observable geometry in {max_tries} draws (best position "
                       f"standard deviation {best:.4g} m, limit {max_position_std:g} m)")
