"""The column mapping of a wide log: a small TOML file, command-line text, or a guess.

It says which column holds the time, the position, the velocity and each measurement, with its kind,
unit and sigma; ``tma import wide FILE --guess`` proposes one from the log's header.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ..core.input_files import read_toml
from ..measurements import KINDS
from ..rules import sigma_ceiling, sigma_ceiling_text
from .logs import EPOCH_UNITS, KNOT, LATEST_NS, YARD, csv_separator

__all__ = ["UNITS", "LogMapping", "MappingError", "MappingGuess", "guess_mapping", "load_mapping",
           "mapping_from_text"]


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
    #: What latitude and longitude numbers count: degrees, or 1e-7 degrees (integers, as PX4
    #: before v1.14 and ArduPilot's binary logs write them)
    lat_lon_unit: Literal["deg", "1e-7 deg"] = "deg"
    #: What altitude numbers count: metres, or millimetres (PX4 before v1.14)
    alt_unit: Literal["m", "mm"] = "m"

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

    @property
    def lat_lon_scale(self) -> float:
        """Degrees per latitude or longitude number."""
        return 1e-7 if self.lat_lon_unit == "1e-7 deg" else 1.0

    @property
    def alt_scale(self) -> float:
        """Metres per altitude number."""
        return 1e-3 if self.alt_unit == "mm" else 1.0


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


def _sensor_id(name: str | None) -> str | None:
    """Refuse a blank sensor id (a file refuses an empty ``sensor`` cell)."""
    if name is not None and not name.strip():
        raise ValueError(f"expected a sensor id (text), found {name!r}")
    return name


class MeasurementMap(_Strict):
    """One measurement column: its kind, unit and sigma (or sigma column)."""

    column: str
    kind: str
    unit: str
    sigma: float | None = Field(default=None, gt=0)
    sigma_column: str | None = None
    reference: Literal["true", "relative"] = "true"
    ambiguous: str | None = None
    sensor: str | None = Field(default=None, min_length=1)

    @field_validator("sensor")
    @classmethod
    def _named(cls, v: str | None) -> str | None:
        return _sensor_id(v)

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
        limit = sigma_ceiling(self.kind)
        if self.sigma is not None and limit is not None and (
                self.sigma * UNITS[self.kind][self.unit][0] > limit * KINDS[self.kind].file_scale):
            raise ValueError(f"sigma {self.sigma:g} {self.unit}: expected "
                             f"{sigma_ceiling_text(self.kind)}")
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

    @field_validator("sensor")
    @classmethod
    def _named(cls, v: str) -> str:
        return str(_sensor_id(v))

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
    lines = [f"  - {'.'.join(str(p) for p in e['loc']) or '(top level)'}: "
             f"{e['msg'].removeprefix('Value error, ')}" for e in err.errors()]
    return MappingError(f"{source}: the column mapping is not valid:\n" + "\n".join(lines))


def load_mapping(path: str | os.PathLike[str], track: str | None = None) -> LogMapping:
    """Read a mapping TOML file (its ``track`` relative to its folder; ``track`` given: as is)."""
    path = Path(path)
    data = read_toml(path, "mapping", MappingError)
    try:
        if track is not None:
            return LogMapping.model_validate({**data, "track": str(track)})
        return LogMapping.model_validate(data).resolve_track(path.parent)
    except ValidationError as e:
        raise _explain(str(path), e) from None


_POSITION_KEYS = ("lat", "lon", "alt", "east", "north", "up", "altitude", "lat_lon_unit",
                  "alt_unit")
_VELOCITY_KEYS = {"vn": "north", "ve": "east", "vd": "down", "vu": "up"}


def mapping_from_text(text: str, measures: list[str], track: str | None = None) -> LogMapping:
    """Build a mapping from command-line text (``track``: the command line's own track file)."""
    data: dict[str, Any] = {} if track is None else {"track": str(track)}
    position: dict[str, str] = {}
    velocity: dict[str, str] = {}
    seen: set[str] = set()
    for part in (p for p in text.split(",") if p.strip()):
        key, eq, value = (s.strip() for s in part.partition("="))
        if not eq or not key or not value:
            raise MappingError(f"--map {text!r}: expected key=value pairs separated by commas "
                               f"(problem at {part!r})")
        if key in seen:  # (the last was taken without a word)
            raise MappingError(f"--map {text!r}: {key} is given twice")
        seen.add(key)
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


#: Names (lower case, spaces and brackets dropped) by role, most specific first.
_NAMES: dict[str, tuple[str, ...]] = {
    "time": ("time_utc_usec", "datetime(utc)", "datetimeutc", "gps_time", "utc", "time_utc",
             "timestamp_utc", "datetime", "date_time", "epoch_s", "epoch_ms", "epoch",
             "unix_time", "unixtime", "timestamp", "time_usec", "timeus", "time_s", "time_ms",
             "time(millisecond)", "time"),
    "lat": ("latitude_deg", "lat_deg", "latitude", "lat"),
    "lon": ("longitude_deg", "lon_deg", "lng_deg", "longitude", "lon", "lng", "long"),
    "alt": ("altitude_ellipsoid_m", "alt_ellipsoid", "altitude_msl_m", "alt_msl", "altitude_m",
            "alt_m", "altitude", "alt", "height_m", "height", "elevation", "ele"),
    "north": ("vel_n_m_s", "vel_n", "velocity_north", "v_north", "north_velocity", "veln", "vn"),
    "east": ("vel_e_m_s", "vel_e", "velocity_east", "v_east", "east_velocity", "vele", "ve"),
    "down": ("vel_d_m_s", "vel_d", "velocity_down", "v_down", "down_velocity", "veld", "vd"),
    "up": ("vel_u_m_s", "vel_u", "velocity_up", "v_up", "up_velocity", "velu", "vu"),
    "heading": ("heading_deg", "heading", "yaw_deg", "hdg", "true_heading"),
    "sensor": ("sensor", "sensor_id", "receiver", "drone_id", "vehicle_id"),
    "power": ("rssi_dbm", "rssi", "signal_dbm", "power_dbm", "rx_power_dbm", "rx_power",
              "signal_strength", "power_dbw", "power"),
    "frequency": ("frequency_hz", "freq_hz", "frequency_khz", "freq_khz", "frequency_mhz",
                  "freq_mhz", "frequency_ghz", "freq_ghz", "center_freq", "centre_freq",
                  "frequency", "freq"),
    "bearing": ("bearing_deg", "bearing_rad", "bearing", "azimuth_deg", "azimuth", "doa_deg",
                "doa", "aoa_deg", "aoa", "direction_deg"),
    "range": ("range_m", "range_km", "range", "distance_m", "distance"),
}
#: Units read from the end of a name, per kind (the first that matches; else the default).
_UNIT_SUFFIXES: dict[str, tuple[tuple[str, str], ...]] = {
    "power": (("dbw", "dBW"), ("dbm", "dBm")),
    "frequency": (("ghz", "GHz"), ("mhz", "MHz"), ("khz", "kHz"), ("hz", "Hz")),
    "bearing": (("rad", "rad"), ("deg", "deg")),
    "range": (("km", "km"), ("nmi", "nmi"), ("yd", "yd"), ("m", "m")),
}
_DEFAULT_UNIT = {"power": "dBm", "frequency": "Hz", "bearing": "deg", "range": "m"}
#: Placeholder sigmas, in the default unit of each kind (to be replaced by the receiver's).
_SIGMA = {"power": 2.0, "frequency": 1.0, "bearing": 2.0, "range": 10.0}
_SIGMA_IN = {"MHz": 1e-6, "kHz": 1e-3, "GHz": 1e-9, "rad": 0.0349066, "km": 0.01,
             "nmi": 0.0054, "yd": 10.94}


@dataclass
class MappingGuess:
    """A proposed mapping: the TOML text and what was chosen or left out."""

    #: The column chosen for each role (``time``, ``lat``, ``north``, ``power``, ...)
    columns: dict[str, str] = field(default_factory=dict)
    #: The unit of each measurement kind found (from the column's name)
    units: dict[str, str] = field(default_factory=dict)
    time_unit: str | None = None  # The unit of epoch numbers (None: ISO-8601 text)
    #: Each choice that needs the user's eye (a placeholder sigma, a time since boot)
    notes: list[str] = field(default_factory=list)
    #: Latitudes and longitudes written as integers of 1e-7 degrees, altitudes of millimetres
    scaled_position: bool = False
    unused: list[str] = field(default_factory=list)  # The columns no role took

    def toml(self, source: str) -> str:
        """Return the proposal as a mapping file (TOML, every choice commented)."""
        c, lines = self.columns, [f"# Proposed by `tma import wide {source} --guess`: check "
                                  "every line, then --mapping THIS_FILE."]
        lines.append(f'time = "{c["time"]}"')
        if self.time_unit is not None:
            lines.append(f'time_unit = "{self.time_unit}"')
        if "sensor" in c:
            lines.append(f'sensor_column = "{c["sensor"]}"')
        if "heading" in c:
            lines.append(f'heading = "{c["heading"]}"         # deg true, for relative '
                         "bearings")
        if "lat" in c:
            lines += ["", "[position]", f'lat = "{c["lat"]}"', f'lon = "{c["lon"]}"']
            if self.scaled_position:
                lines.append('lat_lon_unit = "1e-7 deg"   # integers of 1e-7 degrees (as PX4 '
                             "before v1.14 writes them)")
            if "alt" in c:
                msl = "msl" in c["alt"].lower() or "sea" in c["alt"].lower()
                lines += [f'alt = "{c["alt"]}"',
                          f'altitude = "{"msl" if msl else "ellipsoid"}"   # what the '
                          "altitudes are above: check your log"]
                if self.scaled_position:
                    lines.append('alt_unit = "mm"   # integers of millimetres (as PX4 before '
                                 "v1.14 writes them): check your log")
        vertical = "down" if "down" in c else "up" if "up" in c else None
        if "north" in c and "east" in c:
            frame = "ned" if vertical != "up" else "enu"
            lines += ["", f"[velocity]                 # m/s, {frame}", f'frame = "{frame}"',
                      f'north = "{c["north"]}"', f'east = "{c["east"]}"']
            if vertical:
                lines.append(f'{vertical} = "{c[vertical]}"')
        for kind in ("bearing", "range", "frequency", "power"):
            if kind in c:
                unit = self.units[kind]
                sigma = _SIGMA[kind] * _SIGMA_IN.get(unit, 1.0)
                lines += ["", "[[measurement]]", f'column = "{c[kind]}"', f'kind = "{kind}"',
                          f'unit = "{unit}"',
                          f"sigma = {sigma:.6g}             # a placeholder: your "
                          "receiver's noise std, in the unit"]
        lines += ["", *(f"# note: {n}" for n in self.notes)]
        if self.unused:
            lines.append(f"# columns not used: {', '.join(self.unused)}")
        return "\n".join(lines).rstrip() + "\n"


def _key(name: str) -> str:
    return re.sub(r"[\s\[\]]", "", name.strip().lower())


def _unit(kind: str, name: str) -> str:
    key = _key(name)
    for suffix, unit in _UNIT_SUFFIXES.get(kind, ()):
        if key.endswith(suffix) or key.endswith(f"({suffix})"):
            return unit
    return _DEFAULT_UNIT[kind]


def _time_unit(name: str, first: str) -> tuple[str | None, str | None]:
    """Give the unit of epoch numbers (None for text), and a note when it is no clock time."""
    try:
        value = float(first)
    except ValueError:
        return None, None
    key = _key(name)
    named = ("us" if key.endswith(("usec", "_us", "timeus")) else
             "ms" if key.endswith(("_ms", "millisecond)", "msec")) else
             "ns" if key.endswith(("_ns", "nsec")) else None)
    dated = [u for u, per in EPOCH_UNITS.items() if LATEST_NS / 1e3 <= value * per < LATEST_NS]
    if (named is not None and named in dated) or (named is not None and not dated):
        unit = named
    else:
        unit = dated[0] if dated else "s"
    note = None if dated else (
        f"'{name}' starts at {first}: in {unit} that is no clock date (a time since boot?); "
        "the set's times stay right relative to each other, but t = 0 is shown as 1970 and "
        "no GPS or NMEA track can be joined by time")
    return unit, note


def guess_mapping(path: str | os.PathLike[str]) -> MappingGuess:
    """Propose a column mapping for a wide CSV or Parquet log from its header."""
    import pandas as pd

    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        table = pq.read_table(path).slice(0, 5)  # (an index pandas wrote is a column too)
        frame = table.to_pandas(ignore_metadata=True).astype(str)
    else:
        frame = pd.read_csv(path, dtype=str, nrows=5, encoding="utf-8-sig",
                            sep=csv_separator(path))
    names = [str(c) for c in frame.columns]
    keys = {_key(n): n for n in names}
    guess = MappingGuess()
    for role, known in _NAMES.items():
        found = next((keys[k] for k in known if k in keys
                      and keys[k] not in guess.columns.values()), None)
        if found is not None:
            guess.columns[role] = found
    c = guess.columns
    if "time" not in c:
        raise ValueError(f"{path}: no time column among {', '.join(names)} (looked for "
                         f"{', '.join(_NAMES['time'])}); write the mapping by hand "
                         "(docs/your-own-data.md)")
    if not any(k in c for k in _SIGMA):
        raise ValueError(f"{path}: no measurement column among {', '.join(names)} (looked "
                         f"for power, frequency, bearing and range names such as rssi_dbm, "
                         "freq_hz, bearing_deg, range_m); write the mapping by hand")
    if "lat" in c and "lon" not in c:
        del c["lat"]
    if "heading" in c and "bearing" not in c:
        del c["heading"]  # used only by relative bearings (and PX4's "heading" is in radians)
    if "lat" in c and len(frame):
        lat = pd.to_numeric(frame[c["lat"]], errors="coerce").abs().max()
        guess.scaled_position = bool(90.0 < lat <= 90e7 and "." not in frame[c["lat"]].iloc[0])
    first = str(frame[c["time"]].iloc[0]) if len(frame) else ""
    guess.time_unit, note = _time_unit(c["time"], first)
    if note:
        guess.notes.append(note)
    guess.units = {k: _unit(k, c[k]) for k in _SIGMA if k in c}
    if "lat" not in c:
        guess.notes.append("no latitude/longitude column: give [position] east/north columns "
                           "or a track file (track = \"own.gpx\")")
    if "north" not in c or "east" not in c:
        guess.notes.append("no velocity columns: velocities are derived from the positions")
    guess.notes.append("sigmas are placeholders: replace them by your receiver's noise std")
    guess.unused = [n for n in names if n not in c.values()]
    return guess
