"""Reproduce Ho & Xu (2004): a moving source from TDOA and FDOA of five moving sensors.

Five sensors moving in 3-D, a source at constant velocity near them; TDOAs and FDOAs against the
first sensor at one time, their noise shared through it (range-difference covariance
``sigma^2 (I + 1 1') / 2``, range-rate differences ten times finer, ``0.1 sigma`` in m/s).  The
layout is the one commonly used with Ho & Xu (2004) and Ho, Lu & Kovavisaruch (2007), stated by
tmakit, not checked against the paper's table.
"""

from __future__ import annotations

import numpy as np

from ..core.units import SPEED_OF_LIGHT
from ..motion import ConstantVelocity
from ..scenario import MeasurementPlan, Scenario
from ..sensors import SensorTrack, WaypointTrack
from .geolocation_sweep import SweepReproduction, plot, reproduce

__all__ = ["plot", "run", "scenario_at"]

#: Sensor positions (m) and velocities (m/s), the first the reference.
SENSORS = np.array([[300.0, 100.0, 150.0], [400.0, 150.0, 100.0], [300.0, 500.0, 200.0],
                    [350.0, 200.0, 100.0], [-100.0, -100.0, -100.0]])
VELOCITIES = np.array([[30.0, -20.0, 20.0], [-30.0, 10.0, 20.0], [10.0, -20.0, 10.0],
                       [10.0, 20.0, 30.0], [-20.0, 10.0, 10.0]])
#: The near-field source: position (m) and velocity (m/s) at t = 0.
SOURCE = {"x": 285.0, "y": 325.0, "z": 275.0, "vx": -20.0, "vy": 15.0, "vz": 40.0}
CARRIER_HZ = 1e9
#: Range-rate difference std over range-difference std (s^-1).
RATE_RATIO = 0.1
#: The noise levels: 10 log10 sigma^2 from -30 to 30 dB (sigma in m).
SIGMA_M = tuple(float(10 ** (db / 20)) for db in range(-30, 31, 10))
RUNS = 4000


def scenario_at(sigma_m: float, source: dict[str, float] | None = None) -> Scenario:
    """Build the layout with range-difference noise ``sigma_m`` (m)."""
    sensors: dict[str, SensorTrack] = {
        f"s{i + 1}": WaypointTrack(np.stack([p - v, p + v]), times=[-1.0, 1.0])
        for i, (p, v) in enumerate(zip(SENSORS, VELOCITIES, strict=True))}
    times = np.array([0.0])
    plans = []
    for name in list(sensors)[1:]:
        plans.append(MeasurementPlan("tdoa", name, times, sigma_m / SPEED_OF_LIGHT,
                                     ref_sensor="s1"))
        plans.append(MeasurementPlan("fdoa", name, times,
                                     RATE_RATIO * sigma_m * CARRIER_HZ / SPEED_OF_LIGHT,
                                     ref_sensor="s1", known_carrier=True))
    return Scenario("ho-xu2004", ConstantVelocity(3, 0.0), dict(source or SOURCE), sensors,
                    plans, {"carrier": CARRIER_HZ}, "Ho & Xu (2004): 5 moving sensors")


def run(runs: int = RUNS, seed: int = 1, progress: bool = True) -> SweepReproduction:
    """Reproduce Ho & Xu (2004)'s position and velocity MSE against noise."""
    return reproduce("ho-xu2004", "Ho & Xu (2004): TDOA + FDOA, 5 moving sensors",
                     scenario_at, SIGMA_M, runs, seed)
