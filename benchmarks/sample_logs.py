"""Sample logs made by tmakit's own simulation, in real formats (docs, tests, figures)."""

from __future__ import annotations

import datetime as dt
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tmakit.core.geodesy import enu_to_geodetic
from tmakit.io.logs import KNOT

__all__ = ["SAMPLE_ORIGIN", "SAMPLE_START", "drone_sample", "gpx_nmea_sample",
           "replay_sample"]

#: (lat, lon, alt) of the samples' local plane (deg, deg, m): at sea off Brittany.
SAMPLE_ORIGIN = (47.95, -5.25, 0.0)
#: UTC clock time of t = 0 of the samples (ISO-8601).
SAMPLE_START = "2026-05-04T09:30:00"
_ZIGZAG = [{"duration": 590.0}, {"duration": 10.0, "turn_rate_deg_s": -9.0},
           {"duration": 590.0}, {"duration": 10.0, "turn_rate_deg_s": 9.0},
           {"duration": 590.0}, {"duration": 10.0, "turn_rate_deg_s": -9.0},
           {"duration": 590.0}, {"duration": 10.0, "turn_rate_deg_s": 9.0},
           {"duration": 590.0}, {"duration": 10.0, "turn_rate_deg_s": -9.0},
           {"duration": math.inf}]
_REPLAY_END = 3600.0


def _clock(t: NDArray[np.float64]) -> NDArray[Any]:
    start = np.datetime64(SAMPLE_START, "ns")
    return start + np.round(np.asarray(t) * 1e9).astype("timedelta64[ns]")


def _dms(value: float, hemispheres: str, width: int) -> str:
    hem = hemispheres[0] if value >= 0 else hemispheres[1]
    value = abs(value)
    d = int(value)
    m = int((value - d) * 60.0)
    s = (value - d - m / 60.0) * 3600.0
    if s >= 59.9995:
        m, s = m + 1, 0.0
    if m == 60:
        d, m = d + 1, 0
    return f"{d:0{width}d} {m:02d} {s:06.3f} {hem}"


def _course_speed(v: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return np.rad2deg(np.arctan2(v[:, 0], v[:, 1])) % 360.0, np.hypot(v[:, 0], v[:, 1])


def _replay_scenario(seed_rng: np.random.Generator) -> Any:
    from tmakit.scenario.files import scenario_from_dict

    course = seed_rng.uniform(0.0, 360.0)
    speed = seed_rng.uniform(8.0, 14.0) * KNOT
    bearing0 = np.deg2rad(seed_rng.uniform(20.0, 70.0))
    r0 = seed_rng.uniform(6000.0, 9000.0)
    c = np.deg2rad(course)
    data = {"name": "replay-sample", "title": "own ship zig-zag, CV contact",
            "target": {"motion": "cv2d", "truth": {
                "x": r0 * np.sin(bearing0), "y": r0 * np.cos(bearing0),
                "vx": speed * np.sin(c), "vy": speed * np.cos(c)}},
            "sensors": [{"type": "legs", "id": "OWNSHIP", "start": [0.0, 0.0],
                         "heading_deg": 45.0, "speed": 8.0, "legs": _ZIGZAG}],
            "measurements": [{"kind": "bearing", "sensor": "OWNSHIP", "sigma": 0.5,
                              "times": {"start": 5.0, "stop": _REPLAY_END, "step": 5.0}}]}
    return scenario_from_dict(data, "replay sample"), course, speed / KNOT


def replay_sample(seed: int = 0) -> tuple[str, dict[str, float]]:
    """Make a Debrief replay file: own ship, a contact's bearings, the contact's true track."""
    rng = np.random.default_rng(seed)
    scn, course, speed_kn = _replay_scenario(rng)
    meas = scn.simulate(rng=rng)
    lines = [";; tmakit sample: own ship OWNSHIP, contact CONTACT, simulated "
             f"(seed {seed}); bearings noise 0.5 deg"]
    t_own = np.arange(0.0, _REPLAY_END + 1.0, 30.0)
    own = scn.sensors["OWNSHIP"].states(t_own)
    t_con = np.arange(0.0, _REPLAY_END + 1.0, 60.0)
    con = scn.target_states(t_con)
    rows: list[tuple[float, str | None, str | None, Any]] = [
        (t, "OWNSHIP", "@A", s) for t, s in zip(t_own, own, strict=True)]
    rows += [(t, "CONTACT", "@C", s) for t, s in zip(t_con, con, strict=True)]
    rows += [(t, None, None, b) for t, b in zip(meas.time, meas.value, strict=True)]
    rows.sort(key=lambda r: (r[0], r[1] is None))
    stamps = _clock(np.array([r[0] for r in rows]))
    for (_, name, symbol, item), stamp in zip(rows, stamps, strict=True):
        day = np.datetime_as_string(stamp, unit="ms")
        date, clock = day[2:10].replace("-", ""), day[11:].replace(":", "")
        if name is None:
            lines.append(f";SENSOR: {date} {clock} OWNSHIP @B NULL {float(item):.2f} NULL sonar "
                         "CONTACT held on sonar")
            continue
        lat, lon, _ = enu_to_geodetic(item[0], item[1], 0.0, SAMPLE_ORIGIN)
        crs, spd = _course_speed(item[None, 3:5])
        lines.append(f"{date} {clock} {name} {symbol} {_dms(float(lat), 'NS', 2)} "
                     f"{_dms(float(lon), 'EW', 3)} {crs[0]:.2f} {spd[0] / KNOT:.2f} 0.00")
    return "\n".join(lines) + "\n", {"course": course, "speed": speed_kn}


#: The drone's altitude and the transmitter's, above mean sea level (m): 90 m apart.
DRONE_ALTITUDE, TRANSMITTER_ALTITUDE = 120.0, 30.0


def _drone_scenario(rng: np.random.Generator) -> Any:
    from tmakit.scenario.files import scenario_from_dict

    heading, speed, rate = float(rng.uniform(0.0, 360.0)), 15.0, 3.0
    radius = speed / math.radians(rate)  # of the circle flown after the first minute
    h = math.radians(heading)
    centre = 60.0 * speed * np.array([math.sin(h), math.cos(h)]) + radius * np.array(
        [math.cos(h), -math.sin(h)])
    where = rng.uniform(0.0, 2 * np.pi)
    x, y = centre + radius * math.sqrt(rng.uniform(0.0, 1.0)) * np.array(
        [math.sin(where), math.cos(where)])
    data = {"name": "drone-sample", "title": "drone circling above a transmitter on the ground",
            "target": {"motion": "static3d", "truth": {"x": float(x), "y": float(y),
                                                       "z": TRANSMITTER_ALTITUDE}},
            "emitter": {"carrier_hz": 433.92e6, "power_constant_db": -30.0},
            "sensors": [{"type": "legs", "id": "drone", "start": [0.0, 0.0, DRONE_ALTITUDE],
                         "heading_deg": heading, "speed": speed,
                         "legs": [{"duration": 60.0},
                                  {"duration": math.inf, "turn_rate_deg_s": rate}]}],
            "measurements": [
                {"kind": "power", "sensor": "drone", "sigma": 2.0,
                 "times": {"start": 0.0, "stop": 179.0, "step": 1.0}},
                {"kind": "frequency", "sensor": "drone", "sigma": 1.0,
                 "times": {"start": 0.0, "stop": 179.0, "step": 1.0}}]}
    return scenario_from_dict(data, "drone sample")


DRONE_MAPPING = """\
# How tmakit reads drone.csv (tma import wide drone.csv --mapping drone.toml -o obs.parquet)
time = "utc"                 # ISO-8601 UTC
sensor = "drone"
velocity_window = 10.0       # s, used only when [velocity] is absent

[position]
lat = "lat"
lon = "lon"
alt = "alt_m"
altitude = "msl"

[velocity]                   # north-east-down, m/s
frame = "ned"
north = "vn"
east = "ve"
down = "vd"

[[measurement]]
column = "rssi_dbm"
kind = "power"
unit = "dBm"
sigma = 2.0

[[measurement]]
column = "freq_hz"
kind = "frequency"
unit = "Hz"
sigma = 1.0
"""


def drone_sample(seed: int = 0) -> tuple[str, str, dict[str, float]]:
    """Make a drone receiver log and its mapping (a stationary 433.92 MHz transmitter)."""
    rng = np.random.default_rng(seed)
    scn = _drone_scenario(rng)
    meas = scn.simulate(rng=rng)
    power, freq = meas.select(kind="power"), meas.select(kind="frequency")
    t = power.time
    st = power.sensor_state
    e = st[:, 0] + rng.normal(0, 0.5, t.shape)
    n = st[:, 1] + rng.normal(0, 0.5, t.shape)
    lat, lon, _ = enu_to_geodetic(e, n, 0.0, SAMPLE_ORIGIN)
    alt = st[:, 2] + rng.normal(0, 2.0, t.shape)
    v = st[:, 3:5] + rng.normal(0, 0.03, (t.shape[0], 2))
    stamps = np.datetime_as_string(_clock(t), unit="ms")
    lines = ["utc,lat,lon,alt_m,vn,ve,vd,rssi_dbm,freq_hz"]
    for k in range(t.shape[0]):
        lines.append(f"{stamps[k]}Z,{lat[k]:.8f},{lon[k]:.8f},{alt[k]:.2f},{v[k, 1]:.3f},"
                     f"{v[k, 0]:.3f},{rng.normal(0, 0.03):.3f},{power.value[k]:.2f},"
                     f"{freq.value[k]:.2f}")
    tlat, tlon, talt = enu_to_geodetic(scn.truth["x"], scn.truth["y"], scn.truth["z"],
                                       SAMPLE_ORIGIN)
    return "\n".join(lines) + "\n", DRONE_MAPPING, {"lat": float(tlat), "lon": float(tlon),
                                                     "alt": round(float(talt), 3)}


BEARINGS_MAPPING = """\
# How tmakit reads bearings.csv: the boat's positions come from its own track, joined by time
# (tma import gpx own.gpx bearings.csv --mapping bearings.toml -o obs.parquet)
time = "epoch_s"             # seconds since 1970-01-01 UTC
sensor = "boat"
track = "own.gpx"            # relative to this file; the command line's track file wins

[[measurement]]
column = "bearing_deg"
kind = "bearing"
unit = "deg"
sigma = 1.0
"""


def _nmea_lines(t: NDArray[np.float64], states: NDArray[np.float64]) -> list[str]:
    import pynmea2

    lat, lon, _ = enu_to_geodetic(states[:, 0], states[:, 1], 0.0, SAMPLE_ORIGIN)
    course, speed = _course_speed(states[:, 3:5])
    out = []
    for k, stamp in enumerate(_clock(t)):
        text = np.datetime_as_string(stamp, unit="ms")
        hms = text[11:].replace(":", "")[:9]
        dmy = text[8:10] + text[5:7] + text[2:4]
        la, lo = abs(float(lat[k])), abs(float(lon[k]))
        lat_f = f"{int(la):02d}{(la - int(la)) * 60:09.6f}"
        lon_f = f"{int(lo):03d}{(lo - int(lo)) * 60:09.6f}"
        ns, ew = ("N" if lat[k] >= 0 else "S"), ("E" if lon[k] >= 0 else "W")
        sog, cog = f"{speed[k] / KNOT:.3f}", f"{course[k]:.2f}"
        out += [str(pynmea2.RMC("GP", "RMC", (hms, "A", lat_f, ns, lon_f, ew, sog, cog, dmy,
                                                "", "", "A"))),
                str(pynmea2.GGA("GP", "GGA", (hms, lat_f, ns, lon_f, ew, "1", "09", "0.9",
                                                "2.1", "M", "49.3", "M", "", ""))),
                str(pynmea2.VTG("GP", "VTG", (cog, "T", "", "M", sog, "N",
                                                f"{speed[k] * 3.6:.3f}", "K", "A"))),
                str(pynmea2.HDT("HE", "HDT", (f"{course[k]:.1f}", "T")))]
    return out


def gpx_nmea_sample(seed: int = 0) -> tuple[str, str, str, str, dict[str, float]]:
    """Make a boat's own track (GPX and NMEA) and a CSV of bearings to a fixed beacon."""
    import gpxpy.gpx

    from tmakit.scenario.files import scenario_from_dict

    rng = np.random.default_rng(seed)
    b, r = rng.uniform(0, 2 * np.pi), rng.uniform(3000.0, 5000.0)
    legs = [{"duration": 290.0}, {"duration": 10.0, "turn_rate_deg_s": 9.0}] * 4
    scn = scenario_from_dict({
        "name": "boat-sample", "target": {"motion": "static2d", "truth": {
            "x": r * np.sin(b), "y": r * np.cos(b)}},
        "sensors": [{"type": "legs", "id": "boat", "start": [0.0, 0.0], "heading_deg": 0.0,
                     "speed": 5.0, "legs": [*legs, {"duration": math.inf}]}],
        "measurements": [{"kind": "bearing", "sensor": "boat", "sigma": 1.0,
                          "times": {"start": 10.0, "stop": 1190.0, "step": 10.0}}]},
        "boat sample")
    meas = scn.simulate(rng=rng)
    t = np.arange(0.0, 1201.0, 5.0)
    st = scn.sensors["boat"].states(t)
    lat, lon, _ = enu_to_geodetic(st[:, 0], st[:, 1], 0.0, SAMPLE_ORIGIN)
    gpx = gpxpy.gpx.GPX()
    segment = gpxpy.gpx.GPXTrackSegment()
    for k, stamp in enumerate(_clock(t)):
        when = stamp.astype("datetime64[us]").item().replace(tzinfo=dt.UTC)
        segment.points.append(gpxpy.gpx.GPXTrackPoint(round(float(lat[k]), 8),
                                                      round(float(lon[k]), 8), 2.0, when))
    track = gpxpy.gpx.GPXTrack(name="boat")
    track.segments.append(segment)
    gpx.tracks.append(track)
    epoch = (_clock(meas.time) - np.datetime64("1970-01-01T00:00:00", "ns")) / np.timedelta64(
        1, "ms") / 1000.0
    csv = "epoch_s,bearing_deg\n" + "".join(
        f"{e:.3f},{v:.2f}\n" for e, v in zip(epoch, meas.value, strict=True))
    tlat, tlon, _ = enu_to_geodetic(scn.truth["x"], scn.truth["y"], 0.0, SAMPLE_ORIGIN)
    return (gpx.to_xml(), "\n".join(_nmea_lines(t, st)) + "\n", csv, BEARINGS_MAPPING,
            {"lat": float(tlat), "lon": float(tlon)})
