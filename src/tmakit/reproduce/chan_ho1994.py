"""Reproduce Chan & Ho (1994): a stationary source from the TDOAs of ten sensors.

Ten fixed sensors on the ground and a source on the ground (a 2-D problem, the source's height
known); TDOAs of sensors 2-10 against sensor 1 at one time, their noise shared through it
(range-difference covariance ``sigma^2 (I + 1 1') / 2``, Chan & Ho's noise model).
"""

from __future__ import annotations

import numpy as np

from ..core.units import SPEED_OF_LIGHT
from ..motion import Stationary
from ..scenario import MeasurementPlan, Scenario
from ..sensors import FixedSensor, SensorTrack
from .geolocation_sweep import SweepReproduction, plot, reproduce

__all__ = ["plot", "run", "scenario_at"]

#: Sensor positions (ENU, m), the first the reference.
SENSORS = np.array([[0.0, 0.0], [8000.0, 1500.0], [-6000.0, 4000.0], [3000.0, 9000.0],
                    [-9000.0, -5000.0], [5000.0, -8000.0], [10000.0, 10000.0],
                    [-3000.0, -11000.0], [-11000.0, 9000.0], [12000.0, -3000.0]])
#: The source (m).
SOURCE = {"x": 15000.0, "y": 25000.0}
#: The noise levels: 10 log10 sigma^2 from 0 to 70 dB (sigma from 1 m to 3.2 km).
SIGMA_M = tuple(float(10 ** (db / 20)) for db in range(0, 71, 10))
RUNS = 4000


def scenario_at(sigma_m: float) -> Scenario:
    """Build the layout with range-difference noise ``sigma_m`` (m)."""
    sensors: dict[str, SensorTrack] = {f"s{i + 1}": FixedSensor(p)
                                       for i, p in enumerate(SENSORS)}
    times = np.array([0.0])
    plans = [MeasurementPlan("tdoa", name, times, sigma_m / SPEED_OF_LIGHT, ref_sensor="s1")
             for name in list(sensors)[1:]]
    return Scenario("chan-ho1994", Stationary(2), dict(SOURCE), sensors, plans,
                    description="Chan & Ho (1994): 10 sensors, TDOA")


def run(runs: int = RUNS, seed: int = 1, progress: bool = True) -> SweepReproduction:
    """Reproduce Chan & Ho (1994)'s position MSE against noise."""
    return reproduce("chan-ho1994", "Chan & Ho (1994): TDOA, 10 sensors", scenario_at,
                     SIGMA_M, runs, seed)
