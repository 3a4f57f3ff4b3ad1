"""Debrief replay files (``.rep``, ``.dsf``) as measurement sets.

The mapping (lines: :mod:`.debrief_lines`; frame and clock: :mod:`.logs`):

- **Own ship** (``ownship=``): the host track of the sensor lines used; needed when several
  tracks carry sensor lines.  Its track lines give the sensor's position and velocity
  (course and speed over the ground); a sensor line whose position is ``NULL`` takes the
  host track's position interpolated linearly at its time (refused outside the track).
  Without track lines (DSF files often have none) the sensor lines' own positions are the
  track, and the velocity is derived from them (:func:`~.logs.velocity_from_positions`).
- **Contact** (``contact=``): the sensor lines whose sensor name is the name, or whose label
  starts with it (Debrief labels usually name the contact first); needed when the own
  ship's sensor lines come from several sensors.
- **Rows.** Each bearing becomes a ``bearing`` row (degrees true, wrapped to [0, 360)) with
  sigma ``bearing_sigma`` (default :data:`DEFAULT_BEARING_SIGMA_DEG`: replay files carry no
  sigma); each range (yards) a ``range`` row (m) with ``range_sigma``; each ``;SENSOR2:``
  frequency a ``frequency`` row (Hz) with ``frequency_sigma``.  A ``;SENSOR3:`` line states
  its bearing's and frequency's accuracy: that is the row's sigma, unless ``bearing_sigma`` or
  ``frequency_sigma`` is given (the user's word wins).  Ambiguous bearings are not
  used (tmakit has no two-valued bearing); their count is recorded as metadata.
- **Frame.** Positions are on the sea surface (depth is not used: bearings are horizontal),
  so the set is 2-D unless ``dim=3``; the origin defaults to the own ship's first fix.
- **Clock.** Times are seconds since the file's first time (floored to the second),
  recorded as ``time_origin`` (UTC).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..data import MeasurementSet
from .debrief_lines import SensorLine, TrackLine, parse_replay_text
from .errors import MeasurementFileError
from .formats import Format, register_format
from .logs import (
    KNOT,
    YARD,
    Fixes,
    course_speed_velocity,
    interpolate_states,
    iso_utc,
    local_frame,
    relative_seconds,
    time_origin_ns,
    velocity_from_positions,
)

__all__ = ["DEFAULT_BEARING_SIGMA_DEG", "DEFAULT_FREQUENCY_SIGMA_HZ", "DEFAULT_RANGE_SIGMA_M",
           "REPLAY", "read_replay", "replay_tracks"]

#: Bearing noise standard deviation (deg) when none is given: replay files carry no sigma.
DEFAULT_BEARING_SIGMA_DEG = 1.0
#: Range noise standard deviation (m) when none is given.
DEFAULT_RANGE_SIGMA_M = 100.0
#: Frequency noise standard deviation (Hz) when none is given.
DEFAULT_FREQUENCY_SIGMA_HZ = 0.1


def _load(path: Path) -> tuple[list[TrackLine], list[SensorLine]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        text = path.read_text(encoding="latin-1")
    tracks, sensors, problems = parse_replay_text(text)
    if problems:
        raise MeasurementFileError(path, problems)
    return tracks, sensors


def replay_tracks(path: str | os.PathLike[str]) -> dict[str, dict[str, NDArray]]:
    """Read the track lines of a replay file, by track name.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.rep`` or ``.dsf`` file.

    Returns
    -------
    dict
        For each track: ``time_ns`` (UTC ns, int64), ``lat``, ``lon`` (deg), ``course``
        (deg true), ``speed`` (knots), ``line`` (line numbers), in time order.

    Raises
    ------
    MeasurementFileError
        If a line breaks the format (naming its line).
    """
    tracks, _ = _load(Path(path))
    out: dict[str, dict[str, NDArray]] = {}
    for name in dict.fromkeys(t.name for t in tracks):
        mine = sorted((t for t in tracks if t.name == name), key=lambda t: t.time_ns)
        out[name] = {"time_ns": np.array([t.time_ns for t in mine], np.int64),
                     "lat": np.array([t.lat for t in mine]),
                     "lon": np.array([t.lon for t in mine]),
                     "course": np.array([t.course for t in mine]),
                     "speed": np.array([t.speed_kn for t in mine]),
                     "line": np.array([t.line for t in mine], np.int64)}
    return out


def _choose(path: Path, sensors: list[SensorLine], ownship: str | None,
            contact: str | None) -> tuple[str, list[SensorLine]]:
    """Choose the own ship and the contact's sensor lines, or refuse listing the names."""
    hosts = list(dict.fromkeys(s.host for s in sensors))
    if not hosts:
        raise MeasurementFileError(path, ["no ;SENSOR:, ;SENSOR2: or ;SENSOR3: line: nothing "
                                          "measured"])
    if ownship is None:
        if len(hosts) > 1:
            raise MeasurementFileError(path, [
                f"sensor lines come from several tracks ({', '.join(hosts)}); choose the own "
                "ship with --ownship NAME"])
        ownship = hosts[0]
    if ownship not in hosts:
        raise MeasurementFileError(path, [
            f"own ship {ownship!r} has no sensor lines; tracks with sensor lines: "
            f"{', '.join(hosts)}"])
    mine = [s for s in sensors if s.host == ownship]
    names = list(dict.fromkeys(s.sensor for s in mine))
    if contact is None:
        if len(names) > 1:
            raise MeasurementFileError(path, [
                f"own ship {ownship!r} has sensor lines of several sensors ({', '.join(names)})"
                "; choose one with --contact NAME (a sensor name, or the first word of the "
                "labels)"])
        return ownship, mine
    chosen = [s for s in mine if contact in (s.sensor, (s.label.split() or [""])[0])]
    if not chosen:
        labels = list(dict.fromkeys(s.label.split()[0] for s in mine if s.label.split()))
        raise MeasurementFileError(path, [
            f"no sensor line of own ship {ownship!r} names the contact {contact!r}; sensor "
            f"names: {', '.join(names)}; first words of labels: {', '.join(labels) or 'none'}"])
    return ownship, chosen


def _host_fixes(path: Path, tracks: list[TrackLine], host: str,
                rows: list[SensorLine]) -> Fixes:
    """Return the host's fixes: its track lines, else the positions of its sensor lines."""
    mine = [t for t in tracks if t.name == host]
    if not mine:
        null = [s.line for s in rows if s.lat is None]
        if null:
            named = ", ".join(dict.fromkeys(t.name for t in tracks)) or "none"
            raise MeasurementFileError(path, [
                f"line {line}: sensor position NULL, but own ship {host!r} has no track lines "
                f"(tracks in the file: {named})" for line in null])
        return _sensor_line_fixes(rows)
    fixes = Fixes(np.array([t.time_ns for t in mine], np.int64), np.array([t.lat for t in mine]),
                  np.array([t.lon for t in mine]), np.zeros(len(mine)),
                  course_speed_velocity(np.array([t.course for t in mine]),
                                        np.array([t.speed_kn for t in mine]) * KNOT),
                  np.array([t.line for t in mine], np.int64)).sorted()
    same = np.flatnonzero(np.diff(fixes.time_ns) == 0)
    if same.size:
        assert fixes.lines is not None
        raise MeasurementFileError(path, [
            f"line {fixes.lines[k + 1]}: own ship {host!r} has a second fix at the time of "
            f"line {fixes.lines[k]}" for k in same])
    return fixes


def _sensor_line_fixes(rows: list[SensorLine]) -> Fixes:
    """Return fixes from the sensor lines' own positions (no velocity: derived from them)."""
    times = sorted({s.time_ns: s for s in rows}.items())
    return Fixes(np.array([t for t, _ in times], np.int64),
                 np.array([s.lat for _, s in times], float),
                 np.array([s.lon for _, s in times], float), np.zeros(len(times)), None,
                 np.array([s.line for _, s in times], np.int64))


def _sensor_states(path: Path, rows: list[SensorLine], fixes: Fixes, frame: object,
                   origin_ns: int) -> NDArray[np.float64]:
    """Return each sensor line's state (m, m/s): its own position or the host's, interpolated."""
    t_fix = relative_seconds(fixes.time_ns, origin_ns)
    positions = frame.enu(fixes.lat, fixes.lon, fixes.alt)  # type: ignore[attr-defined]
    velocity = (fixes.velocity if fixes.velocity is not None
                else velocity_from_positions(t_fix, positions))
    host = np.column_stack([positions, velocity])
    t = relative_seconds(np.array([s.time_ns for s in rows], np.int64), origin_ns)
    states, outside = interpolate_states(t_fix, host, t)
    given = np.array([s.lat is not None for s in rows])
    if given.any():
        lat = np.array([s.lat for s in rows if s.lat is not None], float)
        lon = np.array([s.lon for s in rows if s.lon is not None], float)
        states[given, :3] = frame.enu(lat, lon, np.zeros(lat.shape))  # type: ignore[attr-defined]
    bad = outside & ~given
    if bad.any():
        span = f"{iso_utc(int(fixes.time_ns[0]))} to {iso_utc(int(fixes.time_ns[-1]))}"
        raise MeasurementFileError(path, [
            f"line {rows[k].line}: sensor position NULL at {iso_utc(rows[k].time_ns)}, outside "
            f"the host track {rows[k].host!r} ({span}); give the position on the line or "
            "add track lines" for k in np.flatnonzero(bad)])
    return states


def _rows(rows: list[SensorLine], states: NDArray[np.float64], t: NDArray[np.float64],
          sigmas: dict[str, float], asked: set[str]) -> tuple[list, list, list, list, list]:
    """Return the (time, kind, SI value, SI sigma, state) of each measured value.

    A ``;SENSOR3:`` line's accuracy is the sigma of its bearing or frequency unless the user
    gave that kind's sigma (``asked``); otherwise ``sigmas`` (SI) is used.
    """
    out: tuple[list, list, list, list, list] = ([], [], [], [], [])
    for k, s in enumerate(rows):
        stated = {"bearing": None if s.bearing_accuracy is None
                  else float(np.deg2rad(s.bearing_accuracy)),
                  "frequency": s.frequency_accuracy}
        for kind, value in (("bearing", s.bearing), ("range", s.range_yd),
                            ("frequency", s.frequency)):
            if value is None:
                continue
            si = {"bearing": lambda v: np.deg2rad(v % 360.0), "range": lambda v: v * YARD,
                  "frequency": lambda v: v}[kind](value)
            line_sigma = stated.get(kind)
            sigma = sigmas[kind] if line_sigma is None or kind in asked else line_sigma
            for col, item in zip(out, (t[k], kind, si, sigma, states[k]), strict=True):
                col.append(item)
    return out


def _default_sigmas(path: Path, bearing: float | None, range_: float | None,
                    frequency: float | None) -> tuple[dict[str, float], set[str]]:
    """Return the sigmas of lines stating none (deg, m, Hz) and the kinds the user gave."""
    given = {"bearing": bearing, "range": range_, "frequency": frequency}
    default = {"bearing": DEFAULT_BEARING_SIGMA_DEG, "range": DEFAULT_RANGE_SIGMA_M,
               "frequency": DEFAULT_FREQUENCY_SIGMA_HZ}
    sig = {k: default[k] if v is None else v for k, v in given.items()}
    bad = [f"{k} sigma {v!r}: expected a number > 0" for k, v in sig.items() if not v > 0]
    if bad:
        raise MeasurementFileError(path, bad)
    return sig, {k for k, v in given.items() if v is not None}


def read_replay(path: str | os.PathLike[str], *, origin: Sequence[float] | None = None,
                ownship: str | None = None, contact: str | None = None,
                bearing_sigma: float | None = None, range_sigma: float | None = None,
                frequency_sigma: float | None = None, dim: int | None = None,
                **_: object) -> MeasurementSet:
    """Read a Debrief replay file (REP or DSF) as a measurement set (mapping: module text).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    origin : (lat, lon, alt), optional
        ENU origin (deg, deg, m); default the own ship's first fix.
    ownship, contact : str, optional
        The own ship's track name and the contact (sensor name or first word of the labels);
        needed when the file holds several.
    bearing_sigma : float, optional
        Bearing noise (deg); default a ``;SENSOR3:`` line's bearing accuracy, else
        :data:`DEFAULT_BEARING_SIGMA_DEG`.
    range_sigma : float, optional
        Range noise (m), default :data:`DEFAULT_RANGE_SIGMA_M`.
    frequency_sigma : float, optional
        Frequency noise (Hz); default a ``;SENSOR3:`` line's frequency accuracy, else
        :data:`DEFAULT_FREQUENCY_SIGMA_HZ`.
    dim : int, optional
        3 to keep the set 3-D (default 2: the sea surface).
    **_
        Options of other readers, ignored.

    Returns
    -------
    MeasurementSet
        Rows of the own ship's sensor (id: the own ship's name); metadata ``time_origin``,
        the frame (``origin_*``, ``altitude_reference``, ``dim_rule``), ``source``,
        ``bearing_sigma_deg``, ``range_sigma_m``, ``frequency_sigma_hz`` (the defaults used
        where a line states no accuracy), ``sigma_from_file`` (lines that state one) and
        ``ambiguous_bearings_unused``.

    Raises
    ------
    MeasurementFileError
        For a line that breaks the format, an own ship or contact that is ambiguous or absent
        (listing the names present), or a NULL position outside the host track.
    """
    path = Path(path)
    sig, asked = _default_sigmas(path, bearing_sigma, range_sigma, frequency_sigma)
    tracks, sensors = _load(path)
    host, rows = _choose(path, sensors, ownship, contact)
    fixes = _host_fixes(path, tracks, host, rows)
    try:
        frame = local_frame([fixes], origin, dim, "msl")
    except ValueError as e:
        raise MeasurementFileError(path, [str(e)]) from None
    origin_ns = time_origin_ns(np.array([t.time_ns for t in tracks] + [s.time_ns for s in sensors],
                                        np.int64))
    rows = sorted(rows, key=lambda s: s.time_ns)
    states = _sensor_states(path, rows, fixes, frame, origin_ns)
    t = relative_seconds(np.array([s.time_ns for s in rows], np.int64), origin_ns)
    si = {"bearing": np.deg2rad(sig["bearing"]), "range": sig["range"],
          "frequency": sig["frequency"]}
    times, kinds, values, sigmas, st = _rows(rows, states, t, si, asked)
    if not times:
        raise MeasurementFileError(path, [f"the sensor lines of {host!r} measure nothing (every "
                                          "bearing, range and frequency is NULL)"])
    metadata = {"source": f"Debrief replay {path.name}, own ship {host}"
                + (f", contact {contact}" if contact else ""),
                "time_origin": iso_utc(origin_ns), **frame.metadata(),
                "velocity_source": "the own ship's course and speed" if fixes.velocity
                is not None else "derived from the sensor lines' positions (10 s line fit)",
                "bearing_sigma_deg": repr(sig["bearing"]),
                "range_sigma_m": repr(sig["range"]),
                "frequency_sigma_hz": repr(sig["frequency"]),
                "sigma_from_file": str(sum(s.bearing_accuracy is not None
                                           or s.frequency_accuracy is not None for s in rows)),
                "ambiguous_bearings_unused": str(sum(s.ambiguous is not None for s in rows))}
    meas = MeasurementSet.from_si(np.array(times), np.full(len(times), host), np.array(kinds),
                                  np.array(values), np.array(sigmas), np.array(st),
                                  metadata=metadata, check=False).sorted()
    rules.check_set(meas)  # the file rules, once the rows are in time order
    return meas


#: Debrief replay files: ``.rep`` and ``.dsf`` (the same line format).
REPLAY = register_format(Format("rep", "Debrief replay", (".rep", ".dsf"), read_replay, None))
