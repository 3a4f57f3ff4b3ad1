"""The own ship's fixes of a Debrief replay, and the sensor's state at each cut."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .debrief_lines import LineProblem, SensorLine, TrackLine
from .errors import MeasurementFileError
from .logs import (
    KNOT,
    Fixes,
    LocalFrame,
    course_speed_velocity,
    interpolate_states,
    iso_utc,
    relative_seconds,
    velocity_from_positions,
)

__all__ = ["PAIR_HINT", "at_line", "host_fixes", "listed", "sensor_states"]

#: How to give a sensor file its own ship's positions (the end of the refusals that need it).
PAIR_HINT = ("give the own ship's track file in the same command, e.g. tma import rep OWN.rep "
             "SENSOR.dsf -o obs.parquet (the files are read as one replay, in any order)")
_SAME_DEG = 0.011 / 3600.0  # the files' 0.01" of arc (0.3 m)


def at_line(item: TrackLine | SensorLine | LineProblem) -> str:
    """Name a line: ``line N``, or ``FILE line N`` when several files are read."""
    return f"{item.file} line {item.line}" if item.file else f"line {item.line}"


def listed(items: Sequence[str], most: int = 5, sep: str = "; ") -> str:
    """Join the first ``most`` items, then say how many more there are."""
    return sep.join(items[:most]) + (f" and {len(items) - most} more" if len(items) > most
                                     else "")


def _values(item: TrackLine | SensorLine) -> str:
    text = f"{item.lat:.6f}, {item.lon:.6f}"
    if isinstance(item, TrackLine):
        text += f", course {item.course:g}, speed {item.speed_kn:g} kn"
    return text


def _same(a: TrackLine | SensorLine, b: TrackLine | SensorLine) -> bool:
    assert a.lat is not None and b.lat is not None and a.lon is not None and b.lon is not None
    close = abs(a.lat - b.lat) <= _SAME_DEG and abs(a.lon - b.lon) <= _SAME_DEG
    if isinstance(a, TrackLine) and isinstance(b, TrackLine):
        close = close and abs(a.course - b.course) <= 0.01 and abs(a.speed_kn - b.speed_kn) <= 0.01
    return close


def _unique(path: Path, lines: Sequence[TrackLine | SensorLine], host: str,
            notes: list[str]) -> list[TrackLine | SensorLine]:
    """Keep one of each fix written twice; refuse two different fixes at one time."""
    ordered = sorted(lines, key=lambda x: x.time_ns)
    kept: list[TrackLine | SensorLine] = []
    repeats: list[str] = []
    problems: list[str] = []
    for item in ordered:
        if kept and kept[-1].time_ns == item.time_ns:
            if _same(kept[-1], item):
                repeats.append(f"{at_line(item)} repeats {at_line(kept[-1])}")
            else:
                problems.append(
                    f"{at_line(item)}: own ship {host!r} has two different fixes at "
                    f"{iso_utc(item.time_ns)}: {at_line(kept[-1])} ({_values(kept[-1])}) and "
                    f"{at_line(item)} ({_values(item)})")
            continue
        kept.append(item)
    if problems:
        raise MeasurementFileError(path, problems)
    if repeats:
        notes.append(f"note: own ship {host!r}: {len(repeats)} fix(es) written twice (same time "
                     f"and values) read once: {listed(repeats)}")
    return kept


def host_fixes(path: Path, tracks: list[TrackLine], host: str, rows: list[SensorLine],
               notes: list[str]) -> Fixes:
    """Return the host's fixes: its track lines, else the positions its sensor lines state."""
    mine = [t for t in tracks if t.name == host]
    if not mine:
        stated = [s for s in rows if s.lat is not None]
        null = [s for s in rows if s.lat is None]
        if null and not stated:
            named = ", ".join(dict.fromkeys(t.name for t in tracks)) or "none"
            lines = listed([at_line(s) for s in null], sep=", ")
            raise MeasurementFileError(path, [
                f"sensor positions NULL ({lines}), but own ship {host!r} has no track lines "
                f"(tracks read: {named}): {PAIR_HINT}"])
        fixes = _unique(path, stated, host, notes)
        return Fixes(np.array([s.time_ns for s in fixes], np.int64),
                     np.array([s.lat for s in fixes], float),
                     np.array([s.lon for s in fixes], float), np.zeros(len(fixes)), None,
                     np.array([s.line for s in fixes], np.int64))
    kept = [t for t in _unique(path, mine, host, notes) if isinstance(t, TrackLine)]
    return Fixes(np.array([t.time_ns for t in kept], np.int64),
                 np.array([t.lat for t in kept]), np.array([t.lon for t in kept]),
                 np.zeros(len(kept)),
                 course_speed_velocity(np.array([t.course for t in kept]),
                                       np.array([t.speed_kn for t in kept]) * KNOT),
                 np.array([t.line for t in kept], np.int64))


def sensor_states(path: Path, rows: list[SensorLine], fixes: Fixes, frame: LocalFrame,
                  origin_ns: int, notes: list[str]
                  ) -> tuple[list[SensorLine], NDArray[np.float64]]:
    """Return the cuts kept and each one's sensor state (m, m/s)."""
    t_fix = relative_seconds(fixes.time_ns, origin_ns)
    positions = frame.enu(fixes.lat, fixes.lon, fixes.alt)
    velocity = (fixes.velocity if fixes.velocity is not None
                else velocity_from_positions(t_fix, positions))
    t = relative_seconds(np.array([s.time_ns for s in rows], np.int64), origin_ns)
    states, outside = interpolate_states(t_fix, np.column_stack([positions, velocity]), t)
    given = np.array([s.lat is not None for s in rows], bool)
    if given.any():
        lat = np.array([s.lat for s in rows if s.lat is not None], float)
        lon = np.array([s.lon for s in rows if s.lon is not None], float)
        states[given, :3] = frame.enu(lat, lon, np.zeros(lat.shape))
    bad = np.flatnonzero(outside & ~given)
    if bad.size:
        span = f"{iso_utc(int(fixes.time_ns[0]))} to {iso_utc(int(fixes.time_ns[-1]))}"
        named = listed([at_line(rows[k]) for k in bad.tolist()], sep=", ")
        message = (f"{bad.size} cut(s) with a NULL position fall outside the own ship's track "
                   f"{rows[bad[0]].host!r} ({span}) and are left out: {named}")
        if bad.size == len(rows):
            raise MeasurementFileError(path, [f"{message}; no cut is left: {PAIR_HINT}"])
        notes.append(f"warning: {message}")
        keep = np.ones(len(rows), bool)
        keep[bad] = False
        return [s for s, k in zip(rows, keep, strict=True) if k], states[keep]
    return rows, states
