"""Scenario files: TOML, validated with pydantic, turned into a :class:`~tmakit.scenario.Scenario`.

Units: m, s, degrees (``*_deg``), deg/s (``*_deg_s``), Hz; ``sigma`` in its kind's file unit;
``docs/scenarios.md`` lists every field.  ``angle_convention = "east_ccw"`` angles are converted
here once.  A ``times`` table asks for ``(stop - start) / step + 1`` rows; more than
:func:`max_samples` (``TMA_MAX_SAMPLES``, default 2,000,000) is refused before anything is
simulated.
"""

from __future__ import annotations

import math
import os
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..core.input_files import read_toml
from ..core.units import free_space_constant, linear_to_db
from ..measurements import KINDS
from ..motion import MotionModel, motion_from_name
from ..sensors import FixedSensor, Leg, LegsTrack, RecordedTrack, SensorTrack, WaypointTrack
from .catalog import builtin_scenario_names
from .catalog import builtin_scenarios as builtin_scenarios  # re-exported
from .model import MeasurementPlan, Scenario
from .planning_table import PlanningSpec


class ScenarioFileError(ValueError):
    """A scenario file that cannot be used (a ``ValueError``); the message names file and field."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)  # NaN/inf: refused


class TimeRange(_Strict):
    """Sample times ``start, start + step, ...`` up to ``stop`` (s; included to 1e-9 of a step)."""

    start: float
    stop: float
    step: float = Field(gt=0)

    def values(self) -> np.ndarray:
        """Give the sample times (s)."""
        n = math.floor((self.stop - self.start) / self.step + 1e-9) + 1
        if n < 1:
            raise ValueError("stop is before start")
        if n > max_samples():
            raise ValueError(f"{n:,} sample times (start {self.start:g}, stop {self.stop:g}, "
                             f"step {self.step:g} s): more than the limit of "
                             f"{max_samples():,}; raise it with TMA_MAX_SAMPLES=N")
        return self.start + self.step * np.arange(n)


def max_samples() -> int:
    """Give the most sample times one ``times`` range may ask for (``TMA_MAX_SAMPLES``)."""
    try:
        return max(1, int(os.environ.get("TMA_MAX_SAMPLES", "2000000")))
    except ValueError:
        return 2_000_000


Times = TimeRange | list[float]
Point = Annotated[list[float], Field(min_length=2, max_length=3)]
GeoPoint = Annotated[list[float], Field(min_length=2, max_length=3)]


class LegSpec(_Strict):
    """One leg of a ``legs`` sensor (a :class:`~tmakit.sensors.Leg`)."""

    duration: float = Field(gt=0, allow_inf_nan=True,
                            description="seconds; inf for a last leg that never ends")
    turn_rate_deg_s: float = Field(default=0.0, ge=-360.0, le=360.0,
                                   description="a turn a second at most (motion.MAX_TURN_RATE)")
    speed: float | None = Field(default=None, gt=0)


class FixedSpec(_Strict):
    """A sensor that does not move (``type = "fixed"``)."""

    type: Literal["fixed"]
    id: str
    position: Point | None = None
    position_geodetic: GeoPoint | None = None


class LegsSpec(_Strict):
    """A sensor flying straight legs and constant-rate turns (``type = "legs"``)."""

    type: Literal["legs"]
    id: str
    start: Point | None = None
    start_geodetic: GeoPoint | None = None
    start_time: float = 0.0
    heading_deg: float = Field(ge=-360.0, le=360.0)
    speed: float = Field(gt=0)
    legs: list[LegSpec] = Field(min_length=1)


class WaypointsSpec(_Strict):
    """A sensor flying straight between waypoints (``type = "waypoints"``)."""

    type: Literal["waypoints"]
    id: str
    points: list[Point] | None = None
    points_geodetic: list[GeoPoint] | None = None
    speed: float | None = Field(default=None, gt=0)
    times: list[float] | None = None
    start_time: float = 0.0


class RecordedSpec(_Strict):
    """A sensor track recorded at given times (``type = "recorded"``)."""

    type: Literal["recorded"]
    id: str
    times: list[float]
    positions: list[Point] | None = None
    positions_geodetic: list[GeoPoint] | None = None
    velocities: list[Point] | None = None


SensorSpec = Annotated[FixedSpec | LegsSpec | WaypointsSpec | RecordedSpec,
                       Field(discriminator="type")]


class TargetSpec(_Strict):
    """The target: a motion model, its reference time and truth (``course_deg`` in deg)."""

    motion: str
    ref_time: float = 0.0
    truth: dict[str, float]

    @field_validator("motion")
    @classmethod
    def _known_motion(cls, v: str) -> str:
        motion_from_name(v)
        return v


class EmitterSpec(_Strict):
    """The emitter's nuisance truth (``power_constant = "free_space"``: Gu et al. (2007), §5)."""

    carrier_hz: float | None = Field(default=None, gt=0)
    carrier_drift_hz_per_s: float = 0.0
    power_constant: float | Literal["free_space"] | None = None
    power_constant_db: float | None = None
    path_loss_exponent: float = Field(default=2.0, gt=0)


class MeasurementSpec(_Strict):
    """One measurement entry in file units (a MeasurementPlan per sensor it names)."""

    kind: str
    sensor: str | None = None
    sensors: list[str] | None = None
    ref_sensor: str | None = None
    noise: str = "shared"
    known_carrier: bool = False
    times: Times
    sigma: float | None = Field(default=None, gt=0, description="in the kind's file unit")
    snr_db: float | None = None
    pri: float | None = Field(default=None, gt=0)
    lags: list[int] = [1]

    @field_validator("kind")
    @classmethod
    def _known_kind(cls, v: str) -> str:
        if v not in KINDS:
            raise ValueError(f"unknown kind {v!r}; expected one of {', '.join(KINDS)}")
        return v

    @model_validator(mode="after")
    def _keys_of_its_kind(self) -> MeasurementSpec:
        """Refuse a key another kind reads (a bearing's pri was silently ignored)."""
        rd = KINDS[self.kind].uses_reference and not KINDS[self.kind].between_sensors
        for key, wanted in (("pri", rd), ("lags", rd), ("snr_db", self.kind == "power")):
            if key in self.model_fields_set and not wanted:
                owner = "power" if key == "snr_db" else "range_difference"
                raise ValueError(f"{key} is a key of {owner} measurements only, not of "
                                 f"{self.kind}")
        return self


class ScenarioSpec(_Strict):
    """A whole scenario file, validated."""

    name: str
    title: str = ""
    description: str = ""
    paper: str | None = None
    angle_convention: Literal["north_cw", "east_ccw"] = "north_cw"
    origin: Annotated[list[float], Field(min_length=3, max_length=3)] | None = None
    target: TargetSpec

    @field_validator("origin")
    @classmethod
    def _origin_on_earth(cls, v: list[float] | None) -> list[float] | None:
        if v is not None and not (-90 <= v[0] <= 90 and -180 <= v[1] <= 360):
            raise ValueError(f"origin (lat, lon, alt) = {v}: latitude must be within "
                             "[-90, 90] deg and longitude within [-180, 360] deg")
        return v

    emitter: EmitterSpec = EmitterSpec()
    sensors: list[SensorSpec] = Field(min_length=1)
    measurements: list[MeasurementSpec] = Field(min_length=1)
    planning: PlanningSpec | None = None


# -- turning a validated spec into objects ------------------------------------------------
class _Builder:
    def __init__(self, spec: ScenarioSpec) -> None:
        self.spec = spec
        self.ccw = spec.angle_convention == "east_ccw"

    def heading(self, deg: float) -> float:
        """Convert a heading/course in the file's convention (deg) to rad clockwise from North."""
        return math.radians(90.0 - deg) if self.ccw else math.radians(deg)

    def turn_rate(self, deg_s: float) -> float:
        return math.radians(-deg_s if self.ccw else deg_s)

    def enu(self, where: str, given: list[Any] | None, geo: list[Any] | None,
            what: str = "the ENU and the geodetic form") -> np.ndarray:
        """Give ENU positions (m) from the ENU or the geodetic form (one point or a list)."""
        if (given is None) == (geo is None):
            raise ValueError(f"{where}: give exactly one of {what}")
        if given is not None:
            return np.asarray(given, dtype=float)
        assert geo is not None  # (exactly one given)
        if self.spec.origin is None:
            raise ValueError(f"{where}: geodetic positions need the scenario's origin "
                             "= [lat, lon, alt]")
        from ..core.geodesy import geodetic_to_enu

        one = bool(geo) and not isinstance(geo[0], list)
        g = np.array([[*p, 0.0][:3] for p in ([geo] if one else geo)], dtype=float).reshape(-1, 3)
        e, n, u = geodetic_to_enu(g[:, 0], g[:, 1], g[:, 2], tuple(self.spec.origin))
        enu = np.column_stack([e, n, u])
        return enu[0] if one else enu

    def sensor(self, s: Any) -> SensorTrack:
        where = f"sensor {s.id!r}"
        if isinstance(s, FixedSpec):
            return FixedSensor(self.enu(where, s.position, s.position_geodetic))
        if isinstance(s, LegsSpec):
            legs = [Leg(leg.duration, self.turn_rate(leg.turn_rate_deg_s), leg.speed)
                    for leg in s.legs]
            start = self.enu(where, s.start, s.start_geodetic)
            return LegsTrack(start, self.heading(s.heading_deg), s.speed, legs, s.start_time)
        if isinstance(s, WaypointsSpec):
            pts = self.enu(where, s.points, s.points_geodetic, "points and points_geodetic")
            return WaypointTrack(pts, s.speed, s.times, s.start_time)
        pos = self.enu(where, s.positions, s.positions_geodetic,
                       "positions and positions_geodetic")
        return RecordedTrack(s.times, pos, s.velocities)

    def motion_and_truth(self) -> tuple[MotionModel, dict[str, float]]:
        t = self.spec.target
        motion = motion_from_name(t.motion, t.ref_time)
        truth = dict(t.truth)
        if "course_deg" in truth:  # curvilinear models: course given in degrees
            truth["course"] = self.heading(truth.pop("course_deg"))
        if self.ccw:
            for key in [k for k in truth if k.startswith("an_")]:
                truth[key] = -truth[key]  # counter-clockwise positive -> clockwise positive
        motion.theta(truth)  # names checked here, with a message listing the expected ones
        return motion, truth

    def nuisance(self) -> dict[str, float]:
        e = self.spec.emitter
        out: dict[str, float] = {}
        if e.carrier_hz is not None:
            out["carrier"] = e.carrier_hz
            out["carrier_drift"] = e.carrier_drift_hz_per_s
        if e.power_constant is not None and e.power_constant_db is not None:
            raise ValueError("emitter: give power_constant or power_constant_db, not both")
        if e.power_constant == "free_space":
            if e.carrier_hz is None:
                raise ValueError("emitter: power_constant = 'free_space' needs carrier_hz")
            out["power_constant_db"] = float(linear_to_db(free_space_constant(e.carrier_hz)))
        elif e.power_constant is not None:
            if e.power_constant <= 0:
                raise ValueError("emitter: power_constant must be positive")
            out["power_constant_db"] = float(linear_to_db(e.power_constant))
        elif e.power_constant_db is not None:
            out["power_constant_db"] = e.power_constant_db
        out["path_loss_exponent"] = e.path_loss_exponent
        return out

    def plans(self, m: MeasurementSpec, sensor_ids: list[str]) -> list[MeasurementPlan]:
        times = m.times.values() if isinstance(m.times, TimeRange) else np.asarray(m.times)
        sigma = None if m.sigma is None else float(KINDS[m.kind]().sigma_to_si(m.sigma))
        return [MeasurementPlan(m.kind, sensor, times, sigma, m.snr_db, m.pri, tuple(m.lags),
                                m.ref_sensor, m.noise, m.known_carrier)
                for sensor in self.plan_sensors(m, sensor_ids)]

    @staticmethod
    def plan_sensors(m: MeasurementSpec, sensor_ids: list[str]) -> list[str]:
        """Name the sensors of one entry: ``sensor``, ``sensors``, or all but the reference."""
        if (m.sensor is None) == (m.sensors is None):
            raise ValueError(f"measurement of kind {m.kind!r}: give sensor or sensors (a list "
                             "against one ref_sensor), one of them")
        if m.sensors is not None:
            if m.ref_sensor is None:
                raise ValueError(f"measurement of kind {m.kind!r}: sensors = [...] names "
                                 "several sensors against one ref_sensor, which is missing")
            return list(m.sensors)
        if m.sensor == "all" and m.ref_sensor is not None and "all" not in sensor_ids:
            return [s for s in sensor_ids if s != m.ref_sensor]
        assert m.sensor is not None
        return [m.sensor]

    def build(self, source: str) -> Scenario:
        sensors: dict[str, SensorTrack] = {}
        for s in self.spec.sensors:
            if s.id in sensors:
                raise ValueError(f"sensor id {s.id!r} is used twice")
            sensors[s.id] = self.sensor(s)
        motion, truth = self.motion_and_truth()
        return Scenario(
            name=self.spec.name, motion=motion, truth=truth, sensors=sensors,
            plans=[p for m in self.spec.measurements for p in self.plans(m, list(sensors))],
            nuisance=self.nuisance(),
            description=self.spec.title or self.spec.description,
            origin=None if self.spec.origin is None else (
                self.spec.origin[0], self.spec.origin[1], self.spec.origin[2]),
            source=source)


def _validate(data: dict[str, Any], source: str) -> ScenarioSpec:
    try:
        return ScenarioSpec.model_validate(data)
    except ValidationError as err:
        problems = []
        for e in err.errors():
            loc = ""
            for part in e["loc"]:
                loc += f"[{part}]" if isinstance(part, int) else (f".{part}" if loc else str(part))
            problems.append(f"{loc or '(top level)'}: {e['msg']}")
        raise ScenarioFileError(f"{source}: " + "; ".join(problems) if len(problems) == 1
                                else f"{source}:\n  " + "\n  ".join(problems)) from None


def scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> Scenario:
    """Validate a scenario given as a dict (a parsed TOML file) and build it.

    Parameters
    ----------
    data : dict
        The scenario in file form and file units.
    source : str, optional
        Where it came from, for messages.

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioFileError
        If it is not valid; the message lists every problem by field.
    """
    spec = _validate(data, source)
    try:
        return _Builder(spec).build(source)
    except ValueError as err:
        raise ScenarioFileError(f"{source}: {err}") from None


def planned_scenario(data: dict[str, Any], source: str = "<dict>"
                     ) -> tuple[Scenario, PlanningSpec, SensorSpec, bool]:
    """Validate a scenario with a ``[planning]`` table (built by :mod:`tmakit.planning.setup`)."""
    spec = _validate(data, source)
    if spec.planning is None:
        raise ScenarioFileError(f"{source}: no [planning] table: the file declares no "
                                "steered sensor (see docs/planning.md)")
    try:
        scenario = _Builder(spec).build(source)
        sensor = next((s for s in spec.sensors if s.id == spec.planning.sensor), None)
        if sensor is None:
            raise ValueError(f"planning.sensor: no sensor {spec.planning.sensor!r} "
                             f"(sensors: {', '.join(s.id for s in spec.sensors)})")
    except ValueError as err:
        raise ScenarioFileError(f"{source}: {err}") from None
    return scenario, spec.planning, sensor, spec.angle_convention == "east_ccw"

def read_scenario_file(path: str | Path) -> Scenario:
    """Load and validate a TOML scenario file.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioFileError
        If the file does not exist, is not TOML, or is not a valid scenario.
    """
    path = Path(path)
    return scenario_from_dict(read_toml(path, "scenario", ScenarioFileError), str(path))


def scenario_data(name_or_path: str | os.PathLike[str]) -> tuple[dict[str, Any], str]:
    """Return the parsed TOML of a built-in scenario name or a file, and its source."""
    text = str(name_or_path)
    path = Path(text)
    if path.suffix == ".toml" or path.exists():
        return read_toml(path, "scenario", ScenarioFileError), str(path)
    names = builtin_scenario_names()
    if text not in names:
        raise ScenarioFileError(f"unknown scenario {text!r}: not a file, and not one of the "
                                f"built-in scenarios ({', '.join(names)})")
    with resources.as_file(resources.files("tmakit.scenario") / "builtin" / f"{text}.toml") as p:
        return read_toml(Path(p), "scenario", ScenarioFileError), str(p)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a built-in scenario by name or a TOML scenario file by path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A built-in name (``gu2007``, ...) or a path.

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioFileError
        If it is neither a file nor a built-in name, or the file is not valid.
    """
    return scenario_from_dict(*scenario_data(name_or_path))
