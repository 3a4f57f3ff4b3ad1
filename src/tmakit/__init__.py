"""tmakit: passive emitter localisation and target motion analysis.

>>> import tmakit as tk
>>> scn = tk.load_scenario("gu2007")
>>> meas = scn.simulate(rng=1)          # a MeasurementSet
>>> res = tk.estimate(meas, scn.motion)  # no initial guess
>>> bound = tk.crlb(scn)                 # the Cramér–Rao bound at the truth

Every name below is imported when first used, so ``import tmakit`` (and the ``tma`` command's
``--help``) loads none of the numerical core; the core itself needs only numpy and scipy.
The layers behind these names are described in ``docs/architecture.md``.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> the module (relative to ``tmakit``) that defines it.
_LAZY = {
    # the measurement set and the models behind it
    "MeasurementSet": "data",
    "KINDS": "measurements",
    "model_for": "measurements",
    "ConstantVelocity": "motion",
    "MotionModel": "motion",
    "PiecewiseCurvilinear": "motion",
    "Stationary": "motion",
    "motion_from_name": "motion",
    "ObservationModel": "observation",
    # sensors
    "FixedSensor": "sensors",
    "Leg": "sensors",
    "LegsTrack": "sensors",
    "RecordedTrack": "sensors",
    "SensorTrack": "sensors",
    "WaypointTrack": "sensors",
    "PlatformState": "sensors",
    "PlatformKinematics": "sensors",
    "PlatformTrack": "sensors",
    # scenarios
    "MeasurementPlan": "scenario",
    "Scenario": "scenario",
    "simulate": "scenario",
    "load_scenario": "scenario_file",
    "read_scenario_file": "scenario_file",
    "scenario_from_dict": "scenario_file",
    "builtin_scenarios": "scenario_file",
    "ScenarioFileError": "scenario_file",
    "load_planning": "scenario_file",
    # results
    "EstimateResult": "results",
    "Bound": "results",
    "Observability": "results",
    "KnownNuisance": "results.nuisance",
    "Answer": "results",
    "SanityWarning": "results",
    "track_answer": "results",
    "measurement_warnings": "results",
    "Track": "filters",
    "PosteriorBound": "bounds",
    "PosteriorInformation": "bounds",
    "CrbSequence": "bounds",
    "ManoeuvreEstimate": "batch.manoeuvre",
    "MonteCarloResult": "montecarlo",
    # estimators, bounds, applications
    "estimate": "batch",
    "crlb": "bounds",
    "posterior_crb": "bounds",
    "track": "tracking",
    "monte_carlo": "montecarlo",
    # sensor path planning
    "plan": "montecarlo.planned",
    "recommend": "planning",
    # files and geodesy
    "read_measurements": "io",
    "write_measurements": "io",
    "MeasurementFileError": "io",
    "write_track": "io.track_files",
    "geodetic_to_enu": "geodesy",
    "enu_to_geodetic": "geodesy",
}

if TYPE_CHECKING:  # pragma: no cover
    from .batch import estimate
    from .batch.manoeuvre import ManoeuvreEstimate
    from .bounds import CrbSequence, PosteriorBound, PosteriorInformation, crlb, posterior_crb
    from .data import MeasurementSet
    from .filters import Track
    from .geodesy import enu_to_geodetic, geodetic_to_enu
    from .io.measurement_files import MeasurementFileError, read_measurements, write_measurements
    from .io.track_files import write_track
    from .measurements import KINDS, model_for
    from .montecarlo import MonteCarloResult, monte_carlo
    from .montecarlo.planned import plan
    from .motion import (
        ConstantVelocity,
        MotionModel,
        PiecewiseCurvilinear,
        Stationary,
        motion_from_name,
    )
    from .observation import ObservationModel
    from .planning import recommend
    from .results import (
        Answer,
        Bound,
        EstimateResult,
        Observability,
        SanityWarning,
        measurement_warnings,
        track_answer,
    )
    from .results.nuisance import KnownNuisance
    from .scenario import MeasurementPlan, Scenario, simulate
    from .scenario_file import (
        ScenarioFileError,
        builtin_scenarios,
        load_planning,
        load_scenario,
        read_scenario_file,
        scenario_from_dict,
    )
    from .sensors import (
        FixedSensor,
        Leg,
        LegsTrack,
        PlatformKinematics,
        PlatformState,
        PlatformTrack,
        RecordedTrack,
        SensorTrack,
        WaypointTrack,
    )
    from .tracking import track


def __getattr__(name: str) -> Any:
    """Import a public name on first use (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'tmakit' has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Return the public names, for completion."""
    return sorted([*globals(), *_LAZY])


__all__ = [
    "KINDS",
    "Answer",
    "Bound",
    "ConstantVelocity",
    "CrbSequence",
    "EstimateResult",
    "FixedSensor",
    "KnownNuisance",
    "Leg",
    "LegsTrack",
    "ManoeuvreEstimate",
    "MeasurementFileError",
    "MeasurementPlan",
    "MeasurementSet",
    "MonteCarloResult",
    "MotionModel",
    "Observability",
    "ObservationModel",
    "PiecewiseCurvilinear",
    "PlatformKinematics",
    "PlatformState",
    "PlatformTrack",
    "PosteriorBound",
    "PosteriorInformation",
    "RecordedTrack",
    "SanityWarning",
    "Scenario",
    "ScenarioFileError",
    "SensorTrack",
    "Stationary",
    "Track",
    "WaypointTrack",
    "builtin_scenarios",
    "crlb",
    "enu_to_geodetic",
    "estimate",
    "geodetic_to_enu",
    "load_planning",
    "load_scenario",
    "measurement_warnings",
    "model_for",
    "monte_carlo",
    "motion_from_name",
    "plan",
    "posterior_crb",
    "read_measurements",
    "read_scenario_file",
    "recommend",
    "scenario_from_dict",
    "simulate",
    "track",
    "track_answer",
    "write_measurements",
    "write_track",
]
