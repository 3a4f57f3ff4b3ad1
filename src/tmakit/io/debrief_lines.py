"""The lines of a Debrief replay file (REP, and DSF: the same lines), parsed one by one.

Written from Debrief's documentation of the replay format: track fixes, ``;SENSOR:``,
``;SENSOR2:``, ``;SENSOR3:``, ``;TMA_POS:`` and ``;TMA_RB:`` lines; other ``;`` lines are skipped.
A position's ``60`` minutes or seconds is read as a carry, as Debrief does, with a note.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

__all__ = ["LineProblem", "ParsedReplay", "SensorLine", "SolutionLine", "TrackLine",
           "parse_replay_text"]

_TOKEN = re.compile(r'"[^"]*"|\S+')
_NS = 1_000_000_000
_VERSIONS = {";SENSOR:": 1, ";SENSOR2:": 2, ";SENSOR3:": 3}
_SOLUTIONS = (";TMA_POS:", ";TMA_RB:")


@dataclass(frozen=True)
class TrackLine:
    """A track fix of a replay file."""

    line: int  # Line number in the file (1-based)
    name: str  # The track's name
    time_ns: int  # Time, ns since the Unix epoch (UTC)
    #: lat, lon: Position, degrees
    lat: float
    lon: float
    #: course, speed_kn, depth: Course (degrees true), speed (knots) and depth (m)
    course: float
    speed_kn: float
    depth: float
    file: str = ""  # The file's name (for messages when several files are read as one replay)


@dataclass(frozen=True)
class SensorLine:
    """A ``;SENSOR:``, ``;SENSOR2:`` or ``;SENSOR3:`` contact (None: ``NULL`` in the file)."""

    line: int  # Line number in the file (1-based)
    host: str  # The track that holds the sensor
    time_ns: int  # Time, ns since the Unix epoch (UTC)
    #: lat, lon: The sensor's position, degrees (None: the host track's position at ``time_ns``)
    lat: float | None
    lon: float | None
    #: bearing, ambiguous: Bearing and its ambiguous twin, degrees true
    bearing: float | None
    ambiguous: float | None
    frequency: float | None  # Frequency, Hz
    range_yd: float | None  # Range, yards
    #: sensor, label: The sensor's name and the contact's label
    sensor: str
    label: str
    #: bearing_accuracy, frequency_accuracy: The standard deviations a ``;SENSOR3:`` line states
    #: (deg, Hz); None elsewhere
    bearing_accuracy: float | None = None
    frequency_accuracy: float | None = None
    file: str = ""  # The file's name (for messages when several files are read as one replay)


@dataclass(frozen=True)
class SolutionLine:
    """A ``;TMA_POS:`` or ``;TMA_RB:`` solution point (None where the line does not say)."""

    line: int  # Line number in the file (1-based)
    vessel: str  # The track the solution belongs to (Debrief's "ownship name")
    time_ns: int  # Time, ns since the Unix epoch (UTC)
    #: lat, lon: The solution's position, degrees (``;TMA_POS:``)
    lat: float | None
    lon: float | None
    #: bearing, range_yd: Its bearing (degrees true) and range (yards) from the vessel
    #: (``;TMA_RB:``)
    bearing: float | None
    range_yd: float | None
    solution: str  # The solution's name
    #: orientation, maxima_yd, minima_yd: The ellipse: its major axis (degrees true) and semi-axes
    #: (yards); None for ``NULL``
    orientation: float | None
    maxima_yd: float | None
    minima_yd: float | None
    #: course, speed_kn, depth: Course (degrees true), speed (knots), depth (m)
    course: float
    speed_kn: float
    depth: float
    label: str  # The rest of the line
    file: str = ""  # The file's name


@dataclass(frozen=True)
class LineProblem:
    """A line that breaks the replay format."""

    line: int  # Line number in the file (1-based)
    #: The track the line belongs to (a track line's name, a sensor line's host), None when the line
    #: does not get that far
    owner: str | None
    message: str  # What is wrong (``expected ..., found ...``)
    file: str = ""  # The file's name


class LineError(ValueError):
    """One line that breaks the replay format (``line N: ...``)."""


def _name(token: str) -> str:
    return (token[1:-1] if len(token) >= 2 and token[0] == token[-1] == '"' else token).strip()


def _clock(date: str, clock: str) -> int:
    """``YYMMDD`` (or ``YYYYMMDD``) and ``HHMMSS[.SSS]`` as UTC nanoseconds."""
    import datetime as dt

    if not re.fullmatch(r"\d{6}|\d{8}", date):
        raise LineError(f"expected a date YYMMDD, found {date!r}")
    if not re.fullmatch(r"\d{6}(\.\d+)?", clock):
        raise LineError(f"expected a time HHMMSS or HHMMSS.SSS, found {clock!r}")
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


def _angle(tokens: list[str], at: int, hemispheres: str, limit: float,
           carries: list[str]) -> float:
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
    return (_angle(tokens, at, "NS", 90.0, carries),
            _angle(tokens, at + 4, "EW", 180.0, carries))


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
    """The lines of one or more replay files, parsed."""

    tracks: list[TrackLine]  # The track fixes, in file order
    #: The ``;SENSOR:``, ``;SENSOR2:`` and ``;SENSOR3:`` contacts, in file order
    sensors: list[SensorLine]
    problems: list[LineProblem]  # Every line that breaks the format
    #: Each position written with a minute or second of 60 (a carry), as written
    carries: list[LineProblem]
    #: The ``;TMA_POS:`` and ``;TMA_RB:`` solution points, in file order
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
