"""tmakit: passive emitter localisation and target motion analysis.

>>> import tmakit as tk
>>> scn = tk.load_scenario("gu2007")
>>> meas = scn.simulate(rng=1)          # a MeasurementSet
>>> tk.write_measurements(meas, "obs.csv")

The core (models, scenarios, measurement sets) needs only numpy and scipy.  File I/O
(pandas, pyarrow, pandera) and scenario files (pydantic) are imported when first used.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from .data import MeasurementSet
from .measurements import KINDS, model_for
from .motion import (
    ConstantVelocity,
    MotionModel,
    PiecewiseCurvilinear,
    Stationary,
    motion_from_name,
)
from .observation import ObservationModel
from .scenario import MeasurementPlan, Scenario, simulate
from .sensors import FixedSensor, Leg, LegsTrack, RecordedTrack, SensorTrack, WaypointTrack

__version__ = "0.1.0"

_LAZY = {
    "load_scenario": "scenario_file",
    "read_scenario_file": "scenario_file",
    "scenario_from_dict": "scenario_file",
    "builtin_scenarios": "scenario_file",
    "ScenarioFileError": "scenario_file",
    "read_measurements": "io",
    "write_measurements": "io",
    "MeasurementFileError": "io",
    "geodetic_to_enu": "geodesy",
    "enu_to_geodetic": "geodesy",
    "track": "tracking",
    "write_track": "tracking",
    "estimate": "batch",
}

if TYPE_CHECKING:  # pragma: no cover
    from .batch import estimate
    from .geodesy import enu_to_geodetic, geodetic_to_enu
    from .io import MeasurementFileError, read_measurements, write_measurements
    from .scenario_file import (
        ScenarioFileError,
        builtin_scenarios,
        load_scenario,
        read_scenario_file,
        scenario_from_dict,
    )
    from .tracking import track, write_track


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'tmakit' has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "KINDS",
    "ConstantVelocity",
    "FixedSensor",
    "Leg",
    "LegsTrack",
    "MeasurementFileError",
    "MeasurementPlan",
    "MeasurementSet",
    "MotionModel",
    "ObservationModel",
    "PiecewiseCurvilinear",
    "RecordedTrack",
    "Scenario",
    "ScenarioFileError",
    "SensorTrack",
    "Stationary",
    "WaypointTrack",
    "builtin_scenarios",
    "enu_to_geodetic",
    "estimate",
    "geodetic_to_enu",
    "load_scenario",
    "model_for",
    "motion_from_name",
    "read_measurements",
    "read_scenario_file",
    "scenario_from_dict",
    "simulate",
    "track",
    "write_measurements",
    "write_track",
]
