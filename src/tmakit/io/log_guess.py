"""Propose a column mapping for a wide log from its header (``tma import wide FILE --guess``)."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from .logs import EPOCH_UNITS, LATEST_NS

__all__ = ["MappingGuess", "guess_mapping"]

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
            if "alt" in c:
                msl = "msl" in c["alt"].lower() or "sea" in c["alt"].lower()
                lines += [f'alt = "{c["alt"]}"',
                          f'altitude = "{"msl" if msl else "ellipsoid"}"   # what the '
                          "altitudes are above: check your log"]
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
        frame = pd.read_parquet(path).head(5).astype(str)
    else:
        frame = pd.read_csv(path, dtype=str, nrows=5, encoding="utf-8-sig")
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
