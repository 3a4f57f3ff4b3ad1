"""A sensor's own track from GPX (gpxpy) or NMEA 0183 (pynmea2), as :class:`~.logs.Fixes`."""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import MeasurementFileError, refuse_unreadable
from .logs import KNOT, Fixes, fix_problems, iso_utc

__all__ = ["read_gpx_fixes", "read_nmea_fixes", "read_track_fixes"]

_NS = 1_000_000_000


def _ns(stamp: dt.datetime) -> int:
    if stamp.tzinfo is None:
        stamp = stamp.replace(tzinfo=dt.UTC)
    return round(stamp.timestamp() * 1e6) * 1000


def read_gpx_fixes(path: str | os.PathLike[str]) -> Fixes:
    """Read the timed points of a GPX file."""
    import gpxpy
    import gpxpy.gpx

    path = Path(path)
    try:
        with open(path, encoding="utf-8") as f:
            gpx = gpxpy.parse(f)
    except (gpxpy.gpx.GPXException, ValueError) as e:
        raise MeasurementFileError(path, [f"not a readable GPX file ({e})"]) from None
    points: list[Any] = [p for t in gpx.tracks for s in t.segments for p in s.points]
    if not points:
        points = [p for r in gpx.routes for p in r.points] + list(gpx.waypoints)
    timed = [p for p in points if p.time is not None]
    if not timed:
        raise MeasurementFileError(path, [
            f"no GPX point with a time ({len(points)} points without <time>): a sensor track "
            "needs clock times to be joined to the measurements"])
    fixes = Fixes(np.array([_ns(p.time) for p in timed], np.int64),
                  np.array([p.latitude for p in timed], float),
                  np.array([p.longitude for p in timed], float),
                  np.array([0.0 if p.elevation is None else p.elevation for p in timed], float))
    return fixes.sorted()


def _nmea_record(msg: Any, day: dt.date | None) -> tuple[str, dt.datetime | None, dict]:
    """Return (type, time, fields) of one parsed sentence (time None when unknown)."""
    kind = msg.sentence_type
    if kind == "RMC":
        if getattr(msg, "status", "A") == "V":
            return "void", None, {}
        stamp = msg.datetime if msg.datestamp and msg.timestamp else None
        fields = {"lat": msg.latitude, "lon": msg.longitude}
        if msg.spd_over_grnd not in (None, "") and msg.true_course not in (None, ""):
            fields["sog"], fields["cog"] = float(msg.spd_over_grnd), float(msg.true_course)
        return kind, stamp, fields
    if kind == "GGA":
        if not msg.timestamp or day is None or not msg.gps_qual:
            return "nofix" if day is not None else "nodate", None, {}
        stamp = dt.datetime.combine(day, msg.timestamp)
        alt = float(msg.altitude) if msg.altitude not in (None, "") else 0.0
        if msg.geo_sep not in (None, ""):  # above the ellipsoid = above MSL + geoid height
            alt += float(msg.geo_sep)
        return kind, stamp, {"lat": msg.latitude, "lon": msg.longitude, "alt": alt}
    if kind == "VTG" and msg.true_track not in (None, "") and msg.spd_over_grnd_kts not in (
            None, ""):
        return kind, None, {"sog": float(msg.spd_over_grnd_kts), "cog": float(msg.true_track)}
    if kind == "HDT" and msg.heading not in (None, ""):
        return kind, None, {"heading": float(msg.heading)}
    return "other", None, {}


def _nmea_fixes(path: Path, lines: list[str]) -> tuple[dict[int, dict], list[str]]:
    """Parse the sentences into fields by time (ns), and the problems by line."""
    import pynmea2

    by_time: dict[int, dict] = {}
    problems: list[str] = []
    day: dt.date | None = None
    last: int | None = None
    undated = 0
    for number, raw in enumerate(lines, start=1):
        text = raw.strip()
        start = min((i for i in (text.find("$"), text.find("!")) if i >= 0), default=-1)
        if start < 0:
            continue  # not a sentence (loggers may prefix sentences with a time stamp)
        text = text[start:]
        try:
            msg = pynmea2.parse(text, check=True)
            kind, stamp, fields = _nmea_record(msg, day)
        except (pynmea2.ParseError, ValueError, TypeError, AttributeError) as e:
            problems.append(f"line {number}: cannot read the NMEA sentence ({e})")
            continue
        if kind == "RMC" and stamp is not None:
            day = stamp.date()
        undated += kind == "nodate"
        if stamp is not None:
            last = _ns(stamp)
            fix = by_time.setdefault(last, {"line": number})
            fix.update({k: v for k, v in fields.items() if not (kind == "RMC" and k in (
                "lat", "lon") and "alt" in fix)})
        elif kind in ("VTG", "HDT") and last is not None:
            by_time[last].update(fields)
    if undated and not by_time:
        problems.append(f"{undated} GGA sentences but no RMC sentence to give their date")
    return by_time, problems


def read_nmea_fixes(path: str | os.PathLike[str]) -> Fixes:
    """Read the fixes of an NMEA 0183 log (RMC, GGA, VTG, HDT; see the module text)."""
    from .logs import course_speed_velocity

    path = Path(path)
    lines = path.read_text(encoding="ascii", errors="replace").splitlines()
    by_time, problems = _nmea_fixes(path, lines)
    if problems:
        raise MeasurementFileError(path, problems)
    if not by_time:
        raise MeasurementFileError(path, ["no RMC or GGA fix with a date and time"])
    times = np.array(sorted(by_time), np.int64)
    fixes = [by_time[t] for t in times.tolist()]
    velocity: NDArray[np.float64] | None = None
    if all("sog" in f for f in fixes):
        velocity = course_speed_velocity(np.array([f["cog"] for f in fixes]),
                                         np.array([f["sog"] for f in fixes]) * KNOT)
    heading = np.array([f.get("heading", np.nan) for f in fixes], float)
    return Fixes(times, np.array([f["lat"] for f in fixes], float),
                 np.array([f["lon"] for f in fixes], float),
                 np.array([f.get("alt", 0.0) for f in fixes], float), velocity,
                 np.array([f["line"] for f in fixes], np.int64),
                 heading if np.isfinite(heading).any() else None)


def read_track_fixes(path: str | os.PathLike[str]) -> Fixes:
    """Read a sensor track by its suffix: ``.gpx`` (GPX), else NMEA 0183."""
    path = Path(path)
    if not path.exists():
        raise MeasurementFileError(path, ["no such track file"])
    refuse_unreadable(path)
    if path.suffix.lower() == ".gpx":
        fixes = read_gpx_fixes(path)
        found = fix_problems(fixes, lambda k, q: f"point at {iso_utc(int(fixes.time_ns[k]))}, {q}")
    else:
        fixes = read_nmea_fixes(path)
        lines = fixes.lines
        assert lines is not None
        found = fix_problems(fixes, lambda k, q: f"line {lines[k]}, {q}")
    if found:  # the rules of a measurement file (tmakit.rules) on the track's values
        raise MeasurementFileError(path, found)
    return fixes
