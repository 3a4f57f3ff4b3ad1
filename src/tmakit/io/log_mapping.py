"""The column mapping of a wide log: a small TOML file, or command-line text.

It says which column holds the time, the position, the velocity and each measurement, with its kind,
unit and sigma.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..core.input_files import read_toml
from .logs import KNOT, YARD

__all__ = ["UNITS", "LogMapping", "MappingError", "load_mapping", "mapping_from_text"]

#: The units of each measurement kind a wide log may use: ``(scale, offset)`` to SI
#: (``si = value * scale + offset``; sigmas are scaled only).
UNITS: dict[str, dict[str, tuple[float, float]]] = {
    "bearing": {"deg": (math.pi / 180.0, 0.0), "rad": (1.0, 0.0)},
    "elevation": {"deg": (math.pi / 180.0, 0.0), "rad": (1.0, 0.0)},
    "azimuth_rate": {"deg/s": (math.pi / 180.0, 0.0), "rad/s": (1.0, 0.0)},
    "range": {"m": (1.0, 0.0), "km": (1000.0, 0.0), "yd": (YARD, 0.0), "nmi": (1852.0, 0.0)},
    "range_rate": {"m/s": (1.0, 0.0), "kn": (KNOT, 0.0), "km/h": (1 / 3.6, 0.0)},
    "frequency": {"Hz": (1.0, 0.0), "kHz": (1e3, 0.0), "MHz": (1e6, 0.0), "GHz": (1e9, 0.0)},
    "power": {"dBm": (1.0, -30.0), "dBW": (1.0, 0.0)},
}


class MappingError(ValueError):
    """A mapping that cannot be used; the message names the file (or option) and the key."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PositionMap(_Strict):
    """Position columns: ``lat``/``lon``/``alt`` or ``east``/``north``/``up``."""

    lat: str | None = None
    lon: str | None = None
    alt: str | None = None
    east: str | None = None
    north: str | None = None
    up: str | None = None
    altitude: Literal["ellipsoid", "msl"] = "ellipsoid"

    @model_validator(mode="after")
    def _one_way(self) -> PositionMap:
        geo, enu = (self.lat or self.lon), (self.east or self.north)
        if geo and enu:
            raise ValueError("give lat/lon or east/north, not both")
        if geo and not (self.lat and self.lon):
            raise ValueError("lat and lon go together")
        if enu and not (self.east and self.north):
            raise ValueError("east and north go together")
        if not (geo or enu):
            raise ValueError("give the columns lat and lon (or east and north)")
        return self

    @property
    def geodetic(self) -> bool:
        """Whether positions are latitude/longitude."""
        return self.lat is not None


class VelocityMap(_Strict):
    """Velocity columns in ``enu`` (east, north, up) or ``ned`` (north, east, down), m/s."""

    frame: Literal["enu", "ned"]
    east: str
    north: str
    up: str | None = None
    down: str | None = None

    @model_validator(mode="after")
    def _vertical(self) -> VelocityMap:
        if self.frame == "enu" and self.down:
            raise ValueError("frame 'enu' has up, not down")
        if self.frame == "ned" and self.up:
            raise ValueError("frame 'ned' has down, not up")
        return self


class MeasurementMap(_Strict):
    """One measurement column: its kind, unit and sigma (or sigma column)."""

    column: str
    kind: str
    unit: str
    sigma: float | None = Field(default=None, gt=0)
    sigma_column: str | None = None
    reference: Literal["true", "relative"] = "true"
    ambiguous: str | None = None

    @model_validator(mode="after")
    def _kind_unit(self) -> MeasurementMap:
        if self.kind not in UNITS:
            raise ValueError(f"kind {self.kind!r}: a wide log gives one of {', '.join(UNITS)}")
        if self.unit not in UNITS[self.kind]:
            raise ValueError(f"unit {self.unit!r} of {self.kind}: expected one of "
                             f"{', '.join(UNITS[self.kind])}")
        if self.reference == "relative" and self.kind != "bearing":
            raise ValueError("reference 'relative' (to the heading) applies to bearings only")
        if self.ambiguous is not None and self.kind != "bearing":
            raise ValueError("ambiguous (a towed array's second bearing column) applies to "
                             "bearings only")
        if (self.sigma is None) == (self.sigma_column is None):
            raise ValueError("give sigma (in the unit; dB for power) or sigma_column")
        return self


class LogMapping(_Strict):
    """How a wide log maps to a measurement set (see the module text)."""

    time: str
    time_unit: Literal["s", "ms", "us", "ns"] = "s"
    sensor: str = "sensor"
    sensor_column: str | None = None
    track: str | None = None
    heading: str | None = None
    position: PositionMap | None = None
    velocity: VelocityMap | None = None
    velocity_window: float = Field(default=10.0, gt=0)
    origin: tuple[float, float, float] | None = None
    altitude: Literal["ellipsoid", "msl"] | None = None
    dim: Literal[2, 3] | None = None
    measurement: list[MeasurementMap] = Field(min_length=1)

    @model_validator(mode="after")
    def _where(self) -> LogMapping:
        if self.position is None and self.track is None:
            raise ValueError("give [position] columns or a track file (track = \"own.gpx\")")
        return self

    def resolve_track(self, base: Path | None) -> LogMapping:
        """Return the mapping with a relative ``track`` path taken relative to ``base``."""
        if self.track is None or base is None or Path(self.track).is_absolute():
            return self
        return self.model_copy(update={"track": str(base / self.track)})


def _explain(source: str, err: ValidationError) -> MappingError:
    lines = []
    for e in err.errors():
        where = ".".join(str(p) for p in e["loc"]) or "(top level)"
        lines.append(f"  - {where}: {e['msg'].removeprefix('Value error, ')}")
    return MappingError(f"{source}: the column mapping is not valid:\n" + "\n".join(lines))


def load_mapping(path: str | os.PathLike[str]) -> LogMapping:
    """Read a mapping TOML file (``track`` is taken relative to its folder)."""
    path = Path(path)
    data = read_toml(path, "mapping", MappingError)
    try:
        return LogMapping.model_validate(data).resolve_track(path.parent)
    except ValidationError as e:
        raise _explain(str(path), e) from None


_POSITION_KEYS = ("lat", "lon", "alt", "east", "north", "up", "altitude")
_VELOCITY_KEYS = {"vn": "north", "ve": "east", "vd": "down", "vu": "up"}


def mapping_from_text(text: str, measures: list[str]) -> LogMapping:
    """Build a mapping from command-line text."""
    data: dict[str, Any] = {}
    position: dict[str, str] = {}
    velocity: dict[str, str] = {}
    for part in (p for p in text.split(",") if p.strip()):
        key, eq, value = (s.strip() for s in part.partition("="))
        if not eq or not key or not value:
            raise MappingError(f"--map {text!r}: expected key=value pairs separated by commas "
                               f"(problem at {part!r})")
        if key in _POSITION_KEYS:
            position[key] = value
        elif key in _VELOCITY_KEYS:
            velocity[_VELOCITY_KEYS[key]] = value
        elif key in ("time", "time_unit", "sensor", "track", "velocity_window"):
            data[key] = value
        else:
            raise MappingError(f"--map: unknown key {key!r}; expected time, time_unit, sensor, "
                               "track, "
                               f"{', '.join(_POSITION_KEYS)}, vn, ve, vd, vu, velocity_window")
    if position:
        data["position"] = position
    if velocity:
        velocity["frame"] = "ned" if "down" in velocity else "enu"
        data["velocity"] = velocity
    data["measurement"] = [_measure(m) for m in measures]
    try:
        return LogMapping.model_validate(data)
    except ValidationError as e:
        raise _explain("--map/--measure", e) from None


def _measure(text: str) -> dict[str, Any]:
    column, eq, spec = text.partition("=")
    parts = spec.split(":")
    if not eq or len(parts) != 3:
        raise MappingError(f"--measure {text!r}: expected COLUMN=KIND:UNIT:SIGMA, e.g. "
                           "rssi_dbm=power:dBm:2")
    try:
        sigma = float(parts[2])
    except ValueError:
        raise MappingError(f"--measure {text!r}: SIGMA {parts[2]!r} is not a number") from None
    return {"column": column.strip(), "kind": parts[0], "unit": parts[1], "sigma": sigma}
