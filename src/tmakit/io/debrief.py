"""Debrief replay files (``.rep``, ``.dsf``) as measurement sets.

Track fixes, ``;SENSOR:``, ``;SENSOR2:``, ``;SENSOR3:``, ``;TMA_POS:`` and ``;TMA_RB:`` lines as
Debrief's documentation writes them; other ``;`` lines are skipped.  What was read otherwise than
written is said in the set's ``reader_notes`` (``docs/your-own-data.md``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..data import MeasurementSet
from .errors import MeasurementFileError, add_reader_notes
from .formats import Format, register_format
from .logs import (
    KNOT,
    YARD,
    Fixes,
    LocalFrame,
    checked_rows,
    course_speed_velocity,
    interpolate_states,
    iso_utc,
    listed,
    local_frame,
    one_fix_a_time,
    relative_seconds,
    reversed_window,
    seconds_of_time_text,
    time_origin_ns,
    velocity_from_positions,
)

__all__ = ["DEFAULT_BEARING_SIGMA_DEG", "DEFAULT_FREQUENCY_SIGMA_HZ", "DEFAULT_RANGE_SIGMA_M",
           "REPLAY", "LineProblem", "ParsedReplay", "SensorLine", "SolutionLine", "TrackLine",
           "parse_replay_text", "read_replay", "replay_solutions", "replay_tracks"]


_TOKEN = re.compile(r'"[^"]*"|\S+')
_NS = 1_000_000_000
_VERSIONS = {";SENSOR:": 1, ";SENSOR2:": 2, ";SENSOR3:": 3}
_SOLUTIONS = (";TMA_POS:", ";TMA_RB:")


# The lines as read: times in ns since the Unix epoch (UTC), angles in degrees (true), ``line``
# 1-based, ``file`` the file's name when several are read as one replay; None: not in the line.


@dataclass(frozen=True)
class TrackLine:
    """A track fix of a replay file (depth in m)."""

    line: int
    name: str
    time_ns: int
    lat: float
    lon: float
    course: float
    speed_kn: float
    depth: float
    file: str = ""


@dataclass(frozen=True)
class SensorLine:
    """A ``;SENSOR:``, ``;SENSOR2:`` or ``;SENSOR3:`` contact of the track ``host`` (Hz, yards).

    ``lat``, ``lon`` None: the host track's position at ``time_ns``; the accuracies are the
    standard deviations a ``;SENSOR3:`` line states.
    """

    line: int
    host: str
    time_ns: int
    lat: float | None
    lon: float | None
    bearing: float | None
    ambiguous: float | None
    frequency: float | None
    range_yd: float | None
    sensor: str
    label: str
    bearing_accuracy: float | None = None
    frequency_accuracy: float | None = None
    file: str = ""


@dataclass(frozen=True)
class SolutionLine:
    """A ``;TMA_POS:`` (position) or ``;TMA_RB:`` (from the vessel) solution point.

    The ellipse: its major axis ``orientation`` and semi-axes in yards; ``label``: the rest of
    the line.
    """

    line: int
    vessel: str
    time_ns: int
    lat: float | None
    lon: float | None
    bearing: float | None
    range_yd: float | None
    solution: str
    orientation: float | None
    maxima_yd: float | None
    minima_yd: float | None
    course: float
    speed_kn: float
    depth: float
    label: str
    file: str = ""


@dataclass(frozen=True)
class LineProblem:
    """A line that breaks the replay format, and the track it belongs to (None: unknown)."""

    line: int
    owner: str | None
    message: str
    file: str = ""


class LineError(ValueError):
    """One line that breaks the replay format (``line N: ...``)."""


def _name(token: str) -> str:
    return (token[1:-1] if len(token) >= 2 and token[0] == token[-1] == '"' else token).strip()


def _clock(date: str, clock: str) -> int:
    """``YYMMDD`` (or ``YYYYMMDD``) and ``HHMMSS[.SSS]`` as UTC nanoseconds."""
    import datetime as dt

    if not re.fullmatch(r"\d{5,6}|\d{8}", date):
        raise LineError(f"expected a date YYMMDD, found {date!r}")
    if not re.fullmatch(r"\d{1,6}(\.\d+)?", clock):
        raise LineError(f"expected a time HHMMSS or HHMMSS.SSS, found {clock!r}")
    # leading zeros may be left out, as Debrief reads them ("63503.91" is 06:35:03.91)
    date = date.zfill(6)
    whole, dot, frac = clock.partition(".")
    clock = whole.zfill(6) + dot + frac
    if len(date) == 6:
        yy = int(date[:2])
        year, rest = (2000 + yy if yy < 50 else 1900 + yy), date[2:]
    else:
        year, rest = int(date[:4]), date[4:]
    try:
        day = dt.datetime(year, int(rest[:2]), int(rest[2:4]), int(clock[:2]), int(clock[2:4]),
                          int(clock[4:6]), tzinfo=dt.UTC)
    except ValueError as e:
        raise LineError(f"date {date} time {clock}: {e}") from None
    frac = clock[7:] if "." in clock else ""
    ns = int((frac + "000000000")[:9]) if frac else 0
    return int(day.timestamp()) * _NS + ns


def _number(token: str, what: str, null: bool = False) -> float | None:
    if null and token.upper() in ("NULL", "NAN"):
        return None
    try:
        value = float(token)
    except ValueError:
        raise LineError(f"expected {what}, found {token!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise LineError(f"expected {what}, found {token!r}")
    return value


def _angle(tokens: list[str], at: int, hemispheres: str, limit: float, carries: list[str]) -> float:
    """Degrees from ``D M S H`` at ``tokens[at:at+4]``; a minute or second of 60 is a carry."""
    if len(tokens) < at + 4:
        raise LineError(f"expected a position D M S {'/'.join(hemispheres)}, found the end of "
                        "the line")
    d, m, s = (_number(t, "degrees, minutes and seconds") for t in tokens[at:at + 3])
    hem = tokens[at + 3].upper()
    if hem not in hemispheres:
        raise LineError(f"expected the hemisphere {' or '.join(hemispheres)}, found "
                        f"{tokens[at + 3]!r}")
    assert d is not None and m is not None and s is not None
    if not (0 <= m <= 60 and 0 <= s <= 60 and d >= 0):
        raise LineError(f"expected minutes and seconds in [0, 60), found {tokens[at + 1]} "
                        f"{tokens[at + 2]}")
    if m == 60 or s == 60:
        carries.append(" ".join(tokens[at:at + 4]))
    value = d + m / 60.0 + s / 3600.0
    if value > limit:
        raise LineError(f"expected at most {limit:g} degrees, found {value:g}")
    return -value if hem in "SW" else value


def _position(tokens: list[str], at: int, carries: list[str]) -> tuple[float, float]:
    return (_angle(tokens, at, "NS", 90.0, carries), _angle(tokens, at + 4, "EW", 180.0, carries))


def _track(tokens: list[str], line: int, carries: list[str]) -> TrackLine:
    if len(tokens) < 15:
        raise LineError(f"a track line has at least 15 fields (date, time, name, symbology, "
                        f"latitude D M S H, longitude D M S H, course, speed, depth), found "
                        f"{len(tokens)}")
    lat, lon = _position(tokens, 4, carries)
    course, speed = (_number(t, w) for t, w in zip(
        tokens[12:14], ("a course (degrees)", "a speed (knots)"), strict=True))
    depth = _number(tokens[14], "a depth (m) or NaN", null=True)  # not used: may be unknown
    assert course is not None and speed is not None
    return TrackLine(line, _name(tokens[2]), _clock(tokens[0], tokens[1]), lat, lon, course,
                     speed, float("nan") if depth is None else depth)


def _sensor(tokens: list[str], line: int, version: int, carries: list[str]) -> SensorLine:
    if len(tokens) < 5:
        raise LineError("a sensor line starts with date, time, host track, symbology and a "
                        "position (or NULL)")
    time_ns = _clock(tokens[0], tokens[1])
    lat = lon = None
    at = 5
    if tokens[4].upper() != "NULL":
        lat, lon = _position(tokens, 4, carries)
        at = 12
    names: tuple[tuple[str, str], ...] = (("bearing", "a bearing (degrees) or NULL"),
                                          ("range", "a range (yards) or NULL"))
    if version == 2:
        names = (names[0], ("ambiguous", "an ambiguous bearing (degrees) or NULL"),
                 ("frequency", "a frequency (Hz) or NULL"), names[1])
    elif version == 3:
        names = (names[0], ("bearing_accuracy", "a bearing accuracy (degrees) or NULL"),
                 ("frequency", "a frequency (Hz) or NULL"),
                 ("frequency_accuracy", "a frequency accuracy (Hz) or NULL"), names[1])
    if len(tokens) < at + len(names) + 1:
        raise LineError(f"expected {', '.join(n for n, _ in names)} and the sensor name after "
                        "the position, found the end of the line")
    values = {n: _number(tokens[at + i], what, null=True) for i, (n, what) in enumerate(names)}
    for n in ("bearing_accuracy", "frequency_accuracy"):
        value = values.get(n)
        if value is not None and not value > 0:
            raise LineError(f"expected {n.replace('_', ' ')} > 0 (a standard deviation) or "
                            f"NULL, found {tokens[at + [m for m, _ in names].index(n)]!r}")
    rest = tokens[at + len(names):]
    return SensorLine(line, _name(tokens[2]), time_ns, lat, lon, values["bearing"],
                      values.get("ambiguous"), values.get("frequency"), values["range"],
                      _name(rest[0]), " ".join(_name(t) for t in rest[1:]),
                      values.get("bearing_accuracy"), values.get("frequency_accuracy"))


def _solution(tokens: list[str], line: int, head: str, carries: list[str]) -> SolutionLine:
    if len(tokens) < 4:
        raise LineError("a solution line starts with date, time, vessel and symbology")
    time_ns = _clock(tokens[0], tokens[1])
    lat = lon = bearing = range_yd = None
    if head == ";TMA_POS:":
        lat, lon = _position(tokens, 4, carries)
        at = 12
    else:
        if len(tokens) < 6:
            raise LineError("expected a bearing (degrees) and a range (yards), found the end "
                            "of the line")
        bearing = _number(tokens[4], "a bearing (degrees)")
        range_yd = _number(tokens[5], "a range (yards)")
        at = 6
    if len(tokens) < at + 2:
        raise LineError("expected the solution's name and its ellipse (or NULL)")
    solution = _name(tokens[at])
    ellipse: list[float | None] = [None, None, None]
    at += 1
    if not tokens[at].upper().startswith("N"):
        if len(tokens) < at + 3:
            raise LineError("expected the ellipse's orientation, maxima and minima")
        ellipse = [_number(t, w) for t, w in zip(
            tokens[at:at + 3], ("an orientation (degrees)", "a maxima (yards)",
                                "a minima (yards)"), strict=True)]
        at += 3
    else:
        at += 1
    if len(tokens) < at + 3:
        raise LineError("expected course, speed and depth after the ellipse")
    course, speed, depth = (_number(t, w) for t, w in zip(
        tokens[at:at + 3], ("a course (degrees)", "a speed (knots)", "a depth (m)"),
        strict=True))
    assert course is not None and speed is not None and depth is not None
    return SolutionLine(line, _name(tokens[2]), time_ns, lat, lon, bearing, range_yd, solution,
                        ellipse[0], ellipse[1], ellipse[2], course, speed, depth,
                        " ".join(_name(t) for t in tokens[at + 3:]))


@dataclass
class ParsedReplay:
    """The lines of one or more replay files, parsed, in file order."""

    tracks: list[TrackLine]
    sensors: list[SensorLine]
    problems: list[LineProblem]
    carries: list[LineProblem]  # positions written with a minute or second of 60
    solutions: list[SolutionLine] = field(default_factory=list)


def _owner(tokens: list[str], head: str) -> str | None:
    """Return the track a line belongs to, if the line has that field (for problems)."""
    at = 3 if head in _VERSIONS or head in _SOLUTIONS else 2
    return _name(tokens[at]) if len(tokens) > at else None


def parse_replay_text(text: str, file: str = "") -> ParsedReplay:
    """Parse the text of a replay file."""
    out = ParsedReplay([], [], [], [])
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        tokens = _TOKEN.findall(line)  # fields are separated by spaces or tabs
        head = tokens[0].upper()
        carries: list[str] = []
        try:
            if head in _VERSIONS:
                s = _sensor(tokens[1:], number, _VERSIONS[head], carries)
                out.sensors.append(replace(s, file=file))
            elif head in _SOLUTIONS:
                out.solutions.append(replace(_solution(tokens[1:], number, head, carries),
                                             file=file))
            elif not line.startswith(";"):
                out.tracks.append(replace(_track(tokens, number, carries), file=file))
        except LineError as e:
            out.problems.append(LineProblem(number, _owner(tokens, head), str(e), file))
            continue
        out.carries += [LineProblem(number, _owner(tokens, head), c, file) for c in carries]
    return out


#: Bearing noise standard deviation (deg) when none is given: replay files carry no sigma.
DEFAULT_BEARING_SIGMA_DEG = 1.0
#: Range noise standard deviation (m) when none is given.
DEFAULT_RANGE_SIGMA_M = 100.0
#: Frequency noise standard deviation (Hz) when none is given.
DEFAULT_FREQUENCY_SIGMA_HZ = 0.1
#: Speed of sound in sea water (m/s) that carries a replay's tonals, unless told otherwise.
SOUND_SPEED_SEA_M_S = 1500.0


ReplayPaths = str | os.PathLike[str] | Sequence[str | os.PathLike[str]]
_KINDS = ("bearing", "range", "frequency")
#: How to give a sensor file its own ship's positions (the end of the refusals that need it).
_PAIR_HINT = ("give the own ship's track file in the same command, e.g. tma import rep OWN.rep "
              "SENSOR.dsf -o obs.parquet (the files are read as one replay, in any order)")
_SAME_DEG = 0.011 / 3600.0  # the files' 0.01" of arc (0.3 m)
#: The values of ``ranges=``: None (placeholders left out), ``use`` or ``ignore``.
_RANGES_CHOICES = ("use", "ignore")


def _paths(path: ReplayPaths) -> tuple[list[Path], Path]:
    """Return the files and the name that messages give them (``A.rep + B.dsf``)."""
    paths = ([Path(path)] if isinstance(path, str | os.PathLike) else [Path(p) for p in path])
    if not paths:
        raise ValueError("read_replay: no file given")
    return paths, Path(" + ".join(str(p) for p in paths))


def _load(paths: list[Path]) -> ParsedReplay:
    """Parse the files as one replay (each line tagged with its file when there are several)."""
    merged = ParsedReplay([], [], [], [])
    for p in paths:
        try:
            text = p.read_text(encoding="utf-8-sig")
        except UnicodeDecodeError:
            text = p.read_text(encoding="latin-1")
        one = parse_replay_text(text, p.name if len(paths) > 1 else "")
        for f in fields(ParsedReplay):
            getattr(merged, f.name).extend(getattr(one, f.name))
    return merged


def _load_valid(path: ReplayPaths) -> ParsedReplay:
    """Parse replay files, refusing every line that breaks the format."""
    paths, where = _paths(path)
    parsed = _load(paths)
    if parsed.problems:
        raise MeasurementFileError(where, [_problem(p) for p in parsed.problems])
    return parsed


def replay_tracks(path: ReplayPaths) -> dict[str, dict[str, NDArray]]:
    """Read the track lines of a replay file (or of several, as one replay), by track name."""
    parsed = _load_valid(path)
    out: dict[str, dict[str, NDArray]] = {}
    for name in dict.fromkeys(t.name for t in parsed.tracks):
        mine = sorted((t for t in parsed.tracks if t.name == name), key=lambda t: t.time_ns)
        out[name] = {"time_ns": np.array([t.time_ns for t in mine], np.int64),
                     "lat": np.array([t.lat for t in mine]),
                     "lon": np.array([t.lon for t in mine]),
                     "course": np.array([t.course for t in mine]),
                     "speed": np.array([t.speed_kn for t in mine]),
                     "line": np.array([t.line for t in mine], np.int64)}
    return out


def replay_solutions(path: ReplayPaths) -> list[SolutionLine]:
    """Read the TMA solution points of a replay file (``;TMA_POS:`` and ``;TMA_RB:`` lines)."""
    return _load_valid(path).solutions


def _problem(p: LineProblem) -> str:
    return f"{_at_line(p)}: {p.message}"


def _judge_problems(where: Path, parsed: ParsedReplay, host: str, notes: list[str]) -> None:
    """Refuse the problems in the own ship's lines (or lines of no known track); warn of others."""
    used = [p for p in parsed.problems if p.owner is None or p.owner == host]
    if used:
        raise MeasurementFileError(where, [_problem(p) for p in used])
    other = [f"{_problem(p)} (track {p.owner!r})" for p in parsed.problems]
    if other:
        notes.append(f"warning: {len(other)} line(s) of tracks not used break the format and "
                     f"are skipped: {listed(other)}")
    if parsed.carries:
        carried = [f"{_at_line(c)} {c.message}" for c in parsed.carries]
        notes.append(f"note: {len(carried)} position(s) written with 60 minutes or seconds read "
                     f"as a carry, as Debrief reads them: {listed(carried)}")


def _choose(path: Path, parsed: ParsedReplay, ownship: str | None,
            contact: str | None) -> tuple[str, list[SensorLine]]:
    """Choose the own ship and the contact's sensor lines, or refuse listing the names."""
    sensors = parsed.sensors
    hosts = list(dict.fromkeys(s.host for s in sensors))
    if not hosts:
        tracks = list(dict.fromkeys(t.name for t in parsed.tracks))
        raise MeasurementFileError(path, [
            "no ;SENSOR:, ;SENSOR2: or ;SENSOR3: line: nothing measured" + (
                f"; the tracks read ({listed(tracks)}) are positions: give an own ship's "
                f"track with its sensor file in one command (tma show SENSOR.dsf OWN.rep)"
                if tracks else "")])
    ownship = None if ownship is None else ownship.strip()
    contact = None if contact is None else contact.strip()
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
    subjects = {(s.label.split() or [""])[0] for s in mine}
    if contact is None and len(names) > 1 and len(subjects) == 1 and "" not in subjects:
        return ownship, mine  # several sensors, one contact named first in every label
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


def _in_window(where: Path, rows: list[SensorLine], window: Sequence[str | None] | None,
               origin_ns: int, span: tuple[int, int]) -> list[SensorLine]:
    """Keep the cuts within ``window`` (from, to), before any other check of them."""
    if window is None or all(w is None for w in window):
        return rows
    try:
        lo, hi = (None if text is None else origin_ns + round(
            seconds_of_time_text(text, option, origin_ns, span) * 1e9)
            for text, option in zip(window, ("--from", "--to"), strict=True))
    except ValueError as e:
        raise MeasurementFileError(where, [str(e)]) from None
    if lo is not None and hi is not None and lo > hi:  # the options' fault, not the file's
        raise ValueError(reversed_window(str(window[0]), str(window[1]), iso_utc(lo), iso_utc(hi)))
    kept = [s for s in rows if (lo is None or s.time_ns >= lo) and (hi is None or s.time_ns <= hi)]
    if not kept:
        raise ValueError(
            f"--from/--to: no cut between {window[0] or 'the start'} and "
            f"{window[1] or 'the end'} in {where}: the window is empty (the cuts span "
            f"{iso_utc(rows[0].time_ns)} to {iso_utc(rows[-1].time_ns)})")
    return kept


def _kinds(where: Path, kinds: Collection[str] | None) -> set[str]:
    if kinds is None:
        return set(_KINDS)
    unknown = sorted(set(kinds) - set(_KINDS))
    if unknown:
        raise MeasurementFileError(where, [f"kinds {', '.join(unknown)}: a replay file measures "
                                           f"{', '.join(_KINDS)}"])
    return set(kinds)


def _default_sigmas(path: Path, bearing: float | None, range_: float | None,
                    frequency: float | None) -> tuple[dict[str, float], set[str]]:
    """Return the sigmas of lines stating none (deg, m, Hz) and the kinds the user gave."""
    given: dict[str, float | None] = {"bearing": bearing, "range": range_,
                                      "frequency": frequency}
    default = {"bearing": DEFAULT_BEARING_SIGMA_DEG, "range": DEFAULT_RANGE_SIGMA_M,
               "frequency": DEFAULT_FREQUENCY_SIGMA_HZ}
    sig = {k: default[k] if v is None else v for k, v in given.items()}
    bad = [f"{k} sigma {v!r}: expected a number > 0" for k, v in sig.items() if not v > 0]
    bad += [f"{k} sigma {v!r}: expected {rules.sigma_ceiling_text(k)}" for k, v in sig.items()
            if v > (rules.sigma_ceiling(k) or np.inf)]
    if bad:
        raise MeasurementFileError(path, bad)
    return sig, {k for k, v in given.items() if v is not None}


def read_replay(path: ReplayPaths, *, origin: Sequence[float] | None = None,
                ownship: str | None = None, contact: str | None = None,
                bearing_sigma: float | Mapping[str, float] | None = None,
                range_sigma: float | None = None,
                frequency_sigma: float | None = None, dim: int | None = None,
                ranges: str | None = None, kinds: Collection[str] | None = None,
                window: Sequence[str | None] | None = None) -> MeasurementSet:
    """Read Debrief replay files (REP or DSF) as a measurement set (mapping: module text)."""
    paths, where = _paths(path)
    if ranges not in (None, *_RANGES_CHOICES):
        raise MeasurementFileError(where, [f"ranges {ranges!r}: expected use or ignore"])
    by_sensor = dict(bearing_sigma) if isinstance(bearing_sigma, Mapping) else {}
    one = None if isinstance(bearing_sigma, Mapping) else bearing_sigma
    sig, asked = _default_sigmas(where, one, range_sigma, frequency_sigma)
    wanted = _kinds(where, kinds)
    notes: list[str] = []
    cuts = _cuts(where, paths, ownship, contact, window, origin, dim, notes)
    no_range = (_placeholder_ranges(cuts.rows, ranges, notes) if "range" in wanted
                else np.ones(len(cuts.rows), bool))
    t = relative_seconds(np.array([s.time_ns for s in cuts.rows], np.int64), cuts.origin_ns)
    si = {"bearing": np.deg2rad(sig["bearing"]), "range": sig["range"],
          "frequency": sig["frequency"]}
    columns = _one_copy(_cut_rows(cuts.rows, cuts.states, t, si, asked, wanted, no_range,
                                  _sigma_by_sensor(where, cuts, by_sensor)), notes)
    times, kinds_, values, sigmas, st, lines, twins, tonals, names = columns
    if not times:
        raise MeasurementFileError(where, [
            f"the sensor lines of {cuts.host!r} measure nothing of {', '.join(sorted(wanted))} "
            "(every such field is NULL" + (", or a placeholder range" if no_range.any() else "")
            + ")"])
    metadata = _metadata(paths, cuts, contact, sig, int(np.isfinite(twins).sum()), notes)
    if by_sensor:
        metadata["bearing_sigma_by_sensor_deg"] = ", ".join(
            f"{k.strip()}={v:g}" for k, v in by_sensor.items())
    if "frequency" in kinds_:  # Debrief's frequencies are sonar tonals
        metadata["frequency_propagation_speed"] = repr(SOUND_SPEED_SEA_M_S)
        tonal_names = list(dict.fromkeys(t for t in tonals if t))
        add_reader_notes(metadata, f"note: frequencies are sonar tonals carried by sound at "
                         f"{SOUND_SPEED_SEA_M_S:g} m/s (sea water; --propagation-speed to "
                         f"change); {len(tonal_names)} tonal(s) ({listed(tonal_names)}), each "
                         "with its own unknown base frequency f0")
    raw = MeasurementSet.from_si(
        np.array(times), _sensor_ids(cuts.host, names, kinds_, metadata), np.array(kinds_),
        np.array(values),
        np.array(sigmas), np.array(st), metadata=metadata, check=False)
    raw = raw.with_ambiguous(np.array(twins))
    return _checked(where, raw.with_tonal(tonals) if "frequency" in kinds_ else raw, lines,
                    cuts.rows)


def _sigma_by_sensor(where: Path, cuts: _Cuts, by_sensor: dict[str, float]) -> dict[str, float]:
    """Check per-sensor bearing sigmas (deg; names as in the file, or HOST/NAME): SI by name."""
    names = list(dict.fromkeys(s.sensor for s in cuts.rows))
    out, bad = {}, []
    for key, value in by_sensor.items():
        name = key.strip().removeprefix(f"{cuts.host}/")
        if name not in names:
            bad.append(f"bearing sigma of sensor {key!r}: no cut of own ship {cuts.host!r} is "
                       f"from it (sensors: {listed(names)})")
        elif not (isinstance(value, int | float) and value > 0):
            bad.append(f"bearing sigma of sensor {key!r}: {value!r}, expected a number > 0 (deg)")
        elif value > (rules.sigma_ceiling("bearing") or np.inf):
            bad.append(f"bearing sigma of sensor {key!r}: {value!r}, expected "
                       f"{rules.sigma_ceiling_text('bearing')}")
        else:
            out[name] = float(np.deg2rad(value))
    if bad:
        raise MeasurementFileError(where, bad)
    return out


def _one_copy(columns: tuple[list, ...], notes: list[str]) -> tuple[list, ...]:
    """Drop a sensor's values that repeat another's at every time both measure (copies)."""
    times, kinds, values, names = columns[0], columns[1], columns[2], columns[8]
    by_time: dict[tuple[float, str], dict[str, float]] = {}
    for t, kind, value, name in zip(times, kinds, values, names, strict=True):
        by_time.setdefault((t, kind), {}).setdefault(name, value)
    common: dict[tuple[str, str, str], list[bool]] = {}  # (copy, of, kind): equal at each time
    for (_, kind), seen in by_time.items():
        order = list(seen)
        for k, b in enumerate(order):
            for a in order[:k]:
                common.setdefault((b, a, kind), []).append(seen[a] == seen[b])
    copies = {key: len(eq) for key, eq in common.items() if len(eq) >= 3 and all(eq)
              and not any(key[1] == c[0] and key[2] == c[2] for c in common if all(common[c]))}
    if not copies:
        return columns
    drop = {(t, kind, name) for (t, kind), seen in by_time.items() for name in seen
            if any((name, a, kind) in copies for a in seen)}
    notes.append("note: a sensor of the own ship repeats another's values at every time both "
                 "measure (copies of one cut, read once as a cut written twice): " + listed(
                     [f"{n} {kind}(s) of {b} repeat {a}" for (b, a, kind), n in copies.items()]))
    keep = [i for i, key in enumerate(zip(times, kinds, names, strict=True)) if key not in drop]
    return tuple([col[i] for i in keep] for col in columns)


def _sensor_ids(host: str, names: list[str], kinds: list[str],
                metadata: dict[str, str]) -> NDArray[np.str_]:
    """Name each value's sensor: the own ship, or HOST/SENSOR where two sensors share a kind."""
    by_kind: dict[str, set[str]] = {}
    for name, kind in zip(names, kinds, strict=True):
        if kind != "frequency":  # each sensor's frequencies are a tonal of their own already
            by_kind.setdefault(kind, set()).add(name)
    shared = sorted(k for k, n in by_kind.items() if len(n) > 1)
    if not shared:
        return np.full(len(names), host)
    told = list(dict.fromkeys(names))
    ids = listed([f"{host}/{n}" for n in told])
    add_reader_notes(metadata, f"note: {len(told)} sensors of own ship {host!r} ({listed(told)}) "
                     f"measure {' and '.join(shared)}: each is a sensor of its own ({ids}), at "
                     "the positions its cuts state, else the own ship's (a sensor set apart, a "
                     "towed array astern, needs its positions in its cuts), and their cuts are "
                     "fitted together (--contact NAME fits one)")
    return np.array([f"{host}/{n}" for n in names])


def _one_run_per_sensor(rows: list[SensorLine], parsed: ParsedReplay, host: str,
                        files: list[str], notes: list[str]) -> list[SensorLine]:
    """Keep one run of each sensor whose cuts come from several files with other values."""
    by_sensor: dict[str, dict[str, list[SensorLine]]] = {}
    for s in rows:
        by_sensor.setdefault(s.sensor, {}).setdefault(s.file, []).append(s)
    with_track = {t.file for t in parsed.tracks if t.name == host}
    dropped: set[tuple[str, str]] = set()
    for sensor, runs in by_sensor.items():
        if len(runs) < 2:
            continue
        ranked = sorted(runs, key=lambda f: (f in with_track,
                                             files.index(f) if f in files else len(files)))
        chosen = {(s.time_ns, s.bearing, s.ambiguous, s.frequency, s.range_yd)
                  for s in runs[ranked[0]]}
        times = {c[0] for c in chosen}
        for other in ranked[1:]:
            mine = runs[other]
            differ = sum(s.time_ns in times and (s.time_ns, s.bearing, s.ambiguous,
                                                   s.frequency, s.range_yd) not in chosen
                         for s in mine)
            if not differ:
                continue
            dropped.add((sensor, other))
            notes.append(
                f"note: {other} holds another run of sensor {sensor!r} of {host!r} than "
                f"{ranked[0]} ({differ} of its {len(mine)} cuts at the times of "
                f"{ranked[0]}'s have other values): Debrief reads them as two sensors named "
                f"{sensor!r}; one fit takes one, the run of {ranked[0]} (a sensor file is "
                f"preferred to a replay that holds the own ship's track); the {len(mine)} cuts "
                f"of {other} are not used (give {other} without {ranked[0]} to fit that run)")
    return [s for s in rows if (s.sensor, s.file) not in dropped]


def _checked(path: Path, raw: MeasurementSet, lines: list[str],
             rows: list[SensorLine]) -> MeasurementSet:
    """Apply the file's rules to the lines as read, then wrap the bearings to [0, 360)."""
    try:
        meas, _, merged = checked_rows(path, raw, lines)
    except MeasurementFileError as e:
        twice = [p for p in e.problems if "two values at one time" in p]
        contacts = list(dict.fromkeys(s.label.split()[0] for s in rows if s.label.split()))
        if not twice or len(contacts) < 2:  # two sensors of one kind have ids of their own
            raise
        other = twice[0].partition("at the time of ")[2].partition(" (")[0]
        raise MeasurementFileError(path, [  # cuts of several contacts at one time
            f"the cuts read name {len(contacts)} contacts ({listed(contacts)}), two of them "
            f"at one time ({twice[0].split(':')[0]} and {other}): one fit cannot take "
            "two contacts' cuts; choose one with --contact NAME (the first word of the "
            "labels)"]) from None
    bearing = meas.kind_mask("bearing")
    meas.value_si = np.where(bearing, np.mod(meas.value_si, 2 * np.pi), meas.value_si)
    if meas.ambiguous_si is not None:
        meas = meas.with_ambiguous(np.mod(meas.ambiguous_si, 2 * np.pi))
    if merged:
        meas.metadata["duplicates_merged"] = str(merged)
    rules.check_set(meas)  # the file rules, once the rows are in time order
    return meas


@dataclass
class _Cuts:
    """The cuts used, their sensor states, and what they were read with."""

    host: str
    rows: list[SensorLine]
    states: NDArray[np.float64]
    fixes: Fixes
    frame: LocalFrame
    origin_ns: int


def _cuts(where: Path, paths: list[Path], ownship: str | None, contact: str | None,
          window: Sequence[str | None] | None, origin: Sequence[float] | None,
          dim: int | None, notes: list[str]) -> _Cuts:
    """Parse, choose the own ship and contact, apply the window, and place every cut."""
    parsed = _load(paths)
    try:
        host, rows = _choose(where, parsed, ownship, contact)
    except MeasurementFileError as e:  # the lines that break the format may be why
        if not parsed.problems:
            raise
        raise MeasurementFileError(where, [*map(_problem, parsed.problems), *(
            e.problems if parsed.sensors else [])]) from None
    _judge_problems(where, parsed, host, notes)
    every = np.array([t.time_ns for t in parsed.tracks] + [s.time_ns for s in parsed.sensors],
                     np.int64)
    origin_ns = time_origin_ns(every)
    rows = _in_window(where, sorted(rows, key=lambda s: s.time_ns), window, origin_ns,
                      (int(every.min()), int(every.max())))
    rows = _one_run_per_sensor(rows, parsed, host, [p.name for p in paths], notes)
    fixes = _host_fixes(where, parsed.tracks, host, rows, notes)
    try:
        frame = local_frame([fixes], origin, dim, "msl")
    except ValueError as e:
        raise MeasurementFileError(where, [str(e)]) from None
    rows, states = _sensor_states(where, rows, fixes, frame, origin_ns, notes)
    return _Cuts(host, rows, states, fixes, frame, origin_ns)


def _metadata(paths: list[Path], cuts: _Cuts, contact: str | None, sig: dict[str, float],
              ambiguous: int, notes: list[str]) -> dict[str, str]:
    """Return the set's metadata (the ambiguous bearings' note joins the notes)."""
    if ambiguous:
        notes.append(f"note: {ambiguous} cut(s) carry a second, ambiguous bearing (;SENSOR2:, "
                     "the mirror of a towed array's bearing about its axis): both are read; "
                     "tma estimate and tma track choose the side of each own-ship leg by "
                     "likelihood (Python: tk.resolve_ambiguity), a fit of the set as it is takes "
                     "the first bearing; tma crlb takes the side as known")
    names = " + ".join(p.name for p in paths)
    metadata = {"source": f"Debrief replay {names}, own ship {cuts.host}"
                + (f", contact {contact.strip()}" if contact else ""),
                "time_origin": iso_utc(cuts.origin_ns), **cuts.frame.metadata(),
                "velocity_source": "the own ship's course and speed" if cuts.fixes.velocity
                is not None else "derived from the sensor lines' positions (10 s line fit)",
                "bearing_sigma_deg": repr(sig["bearing"]),
                "range_sigma_m": repr(sig["range"]),
                "frequency_sigma_hz": repr(sig["frequency"]),
                "sigma_from_file": str(sum(s.bearing_accuracy is not None
                                           or s.frequency_accuracy is not None
                                           for s in cuts.rows)),
                "ambiguous_bearings": str(ambiguous)}
    add_reader_notes(metadata, *notes)
    return metadata


#: Debrief replay files: ``.rep`` and ``.dsf`` (the same line format).
REPLAY = register_format(Format("rep", "Debrief replay", (".rep", ".dsf"), read_replay, None,
                                several=True, options=(
                                    "ownship", "contact", "bearing_sigma", "range_sigma",
                                    "frequency_sigma", "dim", "ranges", "kinds", "window")))


def _at_line(item: TrackLine | SensorLine | LineProblem) -> str:
    """Name a line: ``line N``, or ``FILE line N`` when several files are read."""
    return f"{item.file} line {item.line}" if item.file else f"line {item.line}"


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


def _host_fixes(path: Path, tracks: list[TrackLine], host: str, rows: list[SensorLine],
               notes: list[str]) -> Fixes:
    """Return the host's fixes: its track lines, else the positions its sensor lines state."""
    mine = [t for t in tracks if t.name == host]
    stated = [s for s in rows if s.lat is not None]
    null = [s for s in rows if s.lat is None]
    if not mine and null and not stated:
        named = ", ".join(dict.fromkeys(t.name for t in tracks)) or "none"
        lines = listed([_at_line(s) for s in null], sep=", ")
        raise MeasurementFileError(path, [
            f"sensor positions NULL ({lines}), but own ship {host!r} has no track lines "
            f"(tracks read: {named}): {_PAIR_HINT}"])
    by_time: list[TrackLine | SensorLine] = sorted(mine or stated, key=lambda x: x.time_ns)
    kept, repeats = one_fix_a_time(
        path, by_time, lambda x: x.time_ns, _same,
        lambda a, b: f"{_at_line(b)}: own ship {host!r} has two different fixes at "
                     f"{iso_utc(b.time_ns)}: {_at_line(a)} ({_values(a)}) and {_at_line(b)} "
                     f"({_values(b)})")
    if repeats:
        notes.append(f"note: own ship {host!r}: {len(repeats)} fix(es) written twice (same time "
                     f"and values) read once: "
                     + listed([f"{_at_line(a)} repeats {_at_line(b)}" for a, b in repeats]))
    fixes = [t for t in kept if isinstance(t, TrackLine)]  # (all of them when mine)
    velocity = None if not mine else course_speed_velocity(
        np.array([t.course for t in fixes]), np.array([t.speed_kn for t in fixes]) * KNOT)
    return Fixes(np.array([k.time_ns for k in kept], np.int64),
                 np.array([k.lat for k in kept], float), np.array([k.lon for k in kept], float),
                 np.zeros(len(kept)), velocity, np.array([k.line for k in kept], np.int64))


def _sensor_states(path: Path, rows: list[SensorLine], fixes: Fixes, frame: LocalFrame,
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
        named = listed([_at_line(rows[k]) for k in bad.tolist()], sep=", ")
        message = (f"{bad.size} cut(s) with a NULL position fall outside the own ship's track "
                   f"{rows[bad[0]].host!r} ({span}) and are left out: {named}")
        if bad.size == len(rows):
            raise MeasurementFileError(path, [f"{message}; no cut is left: {_PAIR_HINT}"])
        notes.append(f"warning: {message}")
        keep = np.ones(len(rows), bool)
        keep[bad] = False
        return [s for s, k in zip(rows, keep, strict=True) if k], states[keep]
    return rows, states


def _placeholder_ranges(rows: list[SensorLine], ranges: str | None,
                       notes: list[str]) -> NDArray[np.bool_]:
    """Mark the cuts whose range is left out (a placeholder, or ``ranges="ignore"``)."""
    value = np.array([np.nan if s.range_yd is None else s.range_yd for s in rows], float)
    stated = np.isfinite(value)
    if ranges == "use" or not stated.any():
        return np.zeros(len(rows), bool)
    if ranges == "ignore":
        notes.append(f"note: {int(stated.sum())} range(s) left out (--ranges ignore)")
        return stated
    drop = stated & (value == 0)
    if drop.any():
        notes.append(f"note: {int(drop.sum())} range(s) of 0 yd left out: a placeholder, not a "
                     "measurement (--ranges use to fit them anyway)")
    rest = value[stated & ~drop]
    if rest.size >= 2 and np.all(rest == rest[0]):
        notes.append(f"note: the {rest.size} ranges left out: every cut states {rest[0]:g} yd, "
                     "a plotting default rather than a measurement (--ranges use to fit them "
                     "anyway)")
        drop = stated
    return drop


def _cut_rows(rows: list[SensorLine], states: NDArray[np.float64], t: NDArray[np.float64],
             sigmas: dict[str, float], asked: set[str], kinds: Collection[str],
             no_range: NDArray[np.bool_], bearing_by_sensor: dict[str, float]
             ) -> tuple[list, list, list, list, list, list, list, list, list]:
    """Return the (time, kind, SI value, SI sigma, state, line, twin, tonal, sensor) of each."""
    out: tuple[list, ...] = ([], [], [], [], [], [], [], [], [])
    for k, s in enumerate(rows):
        stated = {"bearing": None if s.bearing_accuracy is None
                  else float(np.deg2rad(s.bearing_accuracy)),
                  "frequency": s.frequency_accuracy}
        for kind, value in (("bearing", s.bearing), ("range", s.range_yd),
                            ("frequency", s.frequency)):
            if value is None or kind not in kinds or (kind == "range" and no_range[k]):
                continue
            si = (float(np.deg2rad(value)) if kind == "bearing"
                  else value * YARD if kind == "range" else value)
            line_sigma = stated.get(kind)
            sigma = sigmas[kind] if line_sigma is None or kind in asked else line_sigma
            if kind == "bearing" and s.sensor in bearing_by_sensor:  # the user's, by sensor
                sigma = bearing_by_sensor[s.sensor]
            twin = (float(np.deg2rad(s.ambiguous)) if kind == "bearing"
                    and s.ambiguous is not None else np.nan)
            tonal = s.sensor if kind == "frequency" else ""  # a sensor's tonal line
            for col, item in zip(out, (t[k], kind, si, sigma, states[k], _at_line(s), twin,
                                       tonal, s.sensor), strict=True):
                col.append(item)
    return out  # type: ignore[return-value]
