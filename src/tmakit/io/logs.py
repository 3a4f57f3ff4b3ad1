"""What the readers of real logs share: clock times, the local frame, the surface rule, the rules.

As ``docs/your-own-data.md`` says; each problem is named by its place in the log.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..measurements import KINDS
from ..results.answers import KNOT

if TYPE_CHECKING:  # pragma: no cover
    from ..data import MeasurementSet

__all__ = ["EPOCH_UNITS", "KNOT", "LATEST_NS", "PLAUSIBLE_YEARS", "SURFACE_TOLERANCE_M",
           "VELOCITY_WINDOW_S", "YARD", "Fixes", "LocalFrame", "checked_rows",
           "clock_time_problem", "clock_times", "course_speed_velocity", "csv_separator",
           "fill_altitudes", "fix_problems", "interpolate_heading", "interpolate_states",
           "iso_utc", "listed", "local_frame", "one_fix_a_time", "parse_clock_times",
           "relative_seconds", "reversed_window", "seconds_of_time_text", "surface_dim",
           "time_origin_ns",
           "velocity_from_positions"]


#: Sensors whose altitudes all lie within this many metres of the origin's are on a surface
#: (2-D) unless 3-D is asked for: GPS altitude noise is a few metres (1 sigma) and a ship's
#: antenna moves less; a climbing drone or an aircraft leaves the band.
SURFACE_TOLERANCE_M = 25.0
#: Default width (s) of the centred window of the velocity-from-positions fit.
VELOCITY_WINDOW_S = 10.0
ALTITUDE_REFERENCES = ("ellipsoid", "msl")
_NS = 1_000_000_000


@dataclass
class Fixes:
    """A platform's navigation fixes."""

    time_ns: NDArray[np.int64]  # UTC time of each fix (ns since 1970-01-01); shape (n,)
    #: lat, lon: Latitude and longitude (deg, WGS-84); shape (n,)
    lat: NDArray[np.float64]
    lon: NDArray[np.float64]
    alt: NDArray[np.float64]  # Altitude (m, in the frame's altitude reference); shape (n,)
    #: Velocity east, north, up (m/s); None when the log gives none; shape (n, 3)
    velocity: NDArray[np.float64] | None = None
    #: Line of each fix in its file (for messages); shape (n,)
    lines: NDArray[np.int64] | None = None
    #: True heading (deg; NaN where unknown), for bearings relative to the heading; shape (n,)
    heading: NDArray[np.float64] | None = None
    #: What the reader left out or read in another way than written (``note: ...``)
    notes: list[str] = field(default_factory=list)

    def sorted(self) -> Fixes:
        """Return the fixes in time order (stable)."""
        order = np.argsort(self.time_ns, kind="stable")
        return Fixes(self.time_ns[order], self.lat[order], self.lon[order], self.alt[order],
                     None if self.velocity is None else self.velocity[order],
                     None if self.lines is None else self.lines[order],
                     None if self.heading is None else self.heading[order], list(self.notes))


@dataclass(frozen=True)
class LocalFrame:
    """The local ENU frame of a log, and its dimension."""

    origin: tuple[float, float, float]  # The frame's origin (deg, deg, m)
    altitude_reference: str  # ``ellipsoid`` or ``msl``: what the altitudes mean
    dim: int  # 2 (sensors on a surface: z = 0) or 3
    rule: str  # One sentence saying why the frame is 2-D or 3-D
    #: Where the origin comes from: ``the first fix`` (the default) or ``given``
    origin_source: str = "given"

    def metadata(self) -> dict[str, str]:
        """Return the frame as metadata of a measurement set."""
        lat, lon, alt = self.origin
        return {"origin_lat": repr(lat), "origin_lon": repr(lon), "origin_alt": repr(alt),
                "altitude_reference": self.altitude_reference, "dim_rule": self.rule,
                "origin_source": self.origin_source}

    def enu(self, lat: NDArray[np.float64], lon: NDArray[np.float64],
            alt: NDArray[np.float64]) -> NDArray[np.float64]:
        """Convert fixes to ENU positions ``(n, 3)`` (m); ``up`` is 0 in a 2-D frame."""
        from ..core.geodesy import geodetic_to_enu

        lat = np.asarray(lat, float)
        height = np.full(lat.shape, self.origin[2]) if self.dim == 2 else np.asarray(alt, float)
        e, n, u = geodetic_to_enu(lat, np.asarray(lon, float), height, self.origin)
        out = np.column_stack([e, n, u])
        if self.dim == 2:
            out[:, 2] = 0.0
        return out


def surface_dim(alt: NDArray[np.float64], origin_alt: float, dim: int | None,
                tolerance: float = SURFACE_TOLERANCE_M) -> tuple[int, str]:
    """Decide whether sensors are on a surface (2-D) or not (3-D): the surface rule."""
    if dim not in (None, 2, 3):
        raise ValueError(f"dim must be 2 or 3, not {dim!r}")
    spread = float(np.max(np.abs(np.asarray(alt, float) - origin_alt))) if len(alt) else 0.0
    if dim is not None:
        return dim, f"{dim}-D as asked (sensor altitudes within {spread:.1f} m of the origin's)"
    if spread <= tolerance:
        return 2, (f"2-D: sensor altitudes within {spread:.1f} m of the origin's (tolerance "
                   f"{tolerance:g} m), a surface; ask for dim 3 to keep heights")
    return 3, (f"3-D: sensor altitudes differ from the origin's by up to {spread:.1f} m "
               f"(more than the surface tolerance {tolerance:g} m)")


def local_frame(fixes: Sequence[Fixes], origin: Sequence[float] | None, dim: int | None,
                altitude_reference: str = "ellipsoid") -> LocalFrame:
    """Build a log's frame: the origin (default the first fix) and the surface rule."""
    if altitude_reference not in ALTITUDE_REFERENCES:
        raise ValueError(f"altitude reference {altitude_reference!r}: expected one of "
                         f"{', '.join(ALTITUDE_REFERENCES)}")
    source = "given"
    if origin is None:
        source = "the first fix"
        first = next((f for f in fixes if len(f.time_ns)), None)
        if first is None:
            raise ValueError("no position fix: the origin cannot default to the first fix")
        k = int(np.argmin(first.time_ns))
        origin = (float(first.lat[k]), float(first.lon[k]), float(first.alt[k]))
    try:
        lat0, lon0, alt0 = (float(v) for v in origin)
    except (TypeError, ValueError):
        raise ValueError(f"origin {origin!r}: expected (lat, lon, alt) in degrees, degrees, "
                         "metres") from None
    from ..core.units import REACH_M
    from ..rules import LATITUDE, LONGITUDE, geo_within, state_within_reach

    for value, ok, expected in ((lat0, geo_within(np.array([lat0]), "sensor_lat"), LATITUDE),
                                (lon0, geo_within(np.array([lon0]), "sensor_lon"), LONGITUDE),
                                (alt0, state_within_reach(np.array([alt0]), 2),
                                 f"an altitude within [-{REACH_M:g}, {REACH_M:g}] m")):
        if not ok.all():
            raise ValueError(f"origin {origin!r}: expected {expected}, found {value!r}")
    alts = np.concatenate([np.asarray(f.alt, float) for f in fixes]) if fixes else np.zeros(0)
    d, rule = surface_dim(alts, alt0, dim)
    return LocalFrame((lat0, lon0, alt0), altitude_reference, d, rule, source)


def time_origin_ns(*times: NDArray[np.int64]) -> int:
    """Return the time origin: the earliest time given, floored to the whole second."""
    first = min(int(np.min(t)) for t in times if len(t))
    return (first // _NS) * _NS


def relative_seconds(time_ns: NDArray[np.int64], origin_ns: int) -> NDArray[np.float64]:
    """Give seconds since the time origin (the difference is taken in integers, then scaled)."""
    return (np.asarray(time_ns, np.int64) - np.int64(origin_ns)).astype(float) / _NS


def iso_utc(time_ns: int) -> str:
    """Return a UTC time as ISO-8601 text with a ``Z`` (fractions of a second when present)."""
    secs, frac = divmod(int(time_ns), _NS)
    stamp = np.datetime64(secs, "s").astype(str)
    if frac:
        stamp += f".{frac:09d}".rstrip("0")
    return stamp + "Z"


def clock_times(metadata: dict[str, str], t: NDArray[np.float64]) -> NDArray[np.datetime64] | None:
    """Return the UTC clock times of set times ``t`` (s), from the ``time_origin`` metadata."""
    text = metadata.get("time_origin")
    if not text:
        return None
    origin, bad = parse_clock_times([text])
    if bad[0]:
        return None
    ns = np.int64(origin[0]) + np.round(np.asarray(t, float) * _NS).astype(np.int64)
    return ns.astype("datetime64[ns]")


def velocity_from_positions(t: NDArray[np.float64], pos: NDArray[np.float64],
                            window: float = VELOCITY_WINDOW_S) -> NDArray[np.float64]:
    """Estimate velocities from positions: a local straight-line fit per fix."""
    n = t.shape[0]
    out = np.zeros_like(pos, dtype=float)
    if n < 2:
        return out
    half = max(window / 2.0, 0.0)
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    for k in range(n):
        a, b = int(lo[k]), int(hi[k])
        if b - a < 2:  # widen to the nearest neighbours
            a, b = max(0, k - 1), min(n, k + 2)
        tt = t[a:b] - t[k]
        dt = tt - tt.mean()
        den = float(dt @ dt)
        if den > 0:
            out[k] = dt @ (pos[a:b] - pos[a:b].mean(axis=0)) / den
    return out


def interpolate_states(t_fix: NDArray[np.float64], states: NDArray[np.float64],
                       t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Interpolate platform states linearly in time (each component), and mark times outside."""
    out = np.column_stack([np.interp(t, t_fix, states[:, j]) for j in range(states.shape[1])])
    eps = 1e-9 * max(1.0, float(np.max(np.abs(t_fix)))) if len(t_fix) else 0.0
    outside = (t < t_fix[0] - eps) | (t > t_fix[-1] + eps) if len(t_fix) else np.ones(t.shape, bool)
    return out, outside


def listed(items: Sequence[str], most: int = 5, sep: str = "; ") -> str:
    """Join the first ``most`` items, then say how many more there are."""
    return sep.join(items[:most]) + (f" and {len(items) - most} more" if len(items) > most else "")


_Fix = TypeVar("_Fix")


def one_fix_a_time(path: object, fixes: Sequence[_Fix], key: Callable[[_Fix], Hashable | None],
                   same: Callable[[_Fix, _Fix], bool], twice: Callable[[_Fix, _Fix], str]
                   ) -> tuple[list[_Fix], list[tuple[_Fix, _Fix]]]:
    """Keep one of each fix (in time order) written twice; refuse two different at one time."""
    from .errors import MeasurementFileError

    kept: list[_Fix] = []
    repeats: list[tuple[_Fix, _Fix]] = []
    problems: list[str] = []
    for fix in fixes:
        k = key(fix)
        if kept and k is not None and key(kept[-1]) == k:
            if same(kept[-1], fix):
                repeats.append((fix, kept[-1]))
            else:
                problems.append(twice(kept[-1], fix))
            continue
        kept.append(fix)
    if problems:
        raise MeasurementFileError(path, problems)  # type: ignore[arg-type]
    return kept, repeats


def csv_separator(path: Path) -> str:
    """Give a CSV log's field separator: ``,``, or ``;`` or a tab when its header has those."""
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        header = f.readline()
    return max((",", ";", "\t"), key=header.count) if header.count(",") == 0 else ","


def fill_altitudes(time_ns: NDArray[np.int64], alt: NDArray[np.float64], what: str
                   ) -> tuple[NDArray[np.float64], list[str]]:
    """Fill unknown altitudes linearly in time (0 only when none is known: the surface rule)."""
    alt = np.array(alt, float)
    unknown = np.isnan(alt)
    if not unknown.any():
        return alt, []
    if unknown.all():
        return np.zeros_like(alt), []
    t = np.asarray(time_ns, np.int64)
    alt[unknown] = np.interp(t[unknown].astype(float), t[~unknown].astype(float), alt[~unknown])
    return alt, [f"note: the altitude of {int(unknown.sum())} of {alt.size} fixes ({what}) "
                 "interpolated in time from the fixes that give one"]


def interpolate_heading(t_fix: NDArray[np.float64], heading_deg: NDArray[np.float64],
                        t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Interpolate headings (deg) at times ``t`` along the shorter turn; NaN headings skipped."""
    known = np.isfinite(heading_deg)
    if not known.any():
        return np.full(np.shape(t), np.nan)
    h = np.unwrap(np.deg2rad(heading_deg[known]))
    return np.rad2deg(np.interp(t, t_fix[known], h)) % 360.0


def course_speed_velocity(course_deg: NDArray[np.float64], speed: NDArray[np.float64]
                          ) -> NDArray[np.float64]:
    """Give the ENU velocity from course and speed over the ground (vertical 0)."""
    c = np.deg2rad(np.asarray(course_deg, float))
    s = np.asarray(speed, float)
    return np.column_stack([s * np.sin(c), s * np.cos(c), np.zeros_like(s)])


#: One yard in m.
YARD = 0.9144


#: Nanoseconds per unit of an epoch time column (a mapping's ``time_unit``).
EPOCH_UNITS = {"s": 1_000_000_000, "ms": 1_000_000, "us": 1_000, "ns": 1}
_UNIT_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
#: Clock times are refused outside these years (UTC): an epoch number in another unit than
#: the one stated lands far outside them (milliseconds read as seconds: year 58000).
PLAUSIBLE_YEARS = (1970, 2200)
#: The end of the plausible years, ns since 1970 (UTC).
LATEST_NS = int((np.datetime64(f"{PLAUSIBLE_YEARS[1]}-01-01", "ns")
                  - np.datetime64("1970-01-01", "ns")).astype(np.int64))


def parse_clock_times(values: Sequence[object], unit: str = "s"
                      ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Read clock times: ISO-8601 text (UTC unless it names a zone) or epoch numbers."""
    import pandas as pd

    per = EPOCH_UNITS[unit]
    series = pd.Series(list(values), dtype=object)
    numbers = pd.to_numeric(series, errors="coerce")
    out = np.zeros(len(series), dtype=np.int64)
    bad = np.zeros(len(series), dtype=bool)
    as_float = numbers.to_numpy(float, na_value=np.nan)
    is_number = np.isfinite(as_float)
    if is_number.any():
        with np.errstate(invalid="ignore", over="ignore"):
            inside = is_number & (as_float >= 0) & (as_float * per < LATEST_NS)
        if pd.api.types.is_integer_dtype(numbers.dtype):  # exact, whatever the unit
            out[inside] = numbers.to_numpy(np.int64)[inside] * per
        else:
            v = as_float[inside]
            whole = np.floor(v)
            out[inside] = (whole.astype(np.int64) * per
                           + np.round((v - whole) * per).astype(np.int64))
        bad |= is_number & ~inside
    text = ~is_number
    if text.any():
        stamps = pd.to_datetime(series[text].astype(str).str.strip(), utc=True, errors="coerce",
                                format="ISO8601")
        # pandas keeps a stamp beyond datetime64[ns]'s years (1677-2262) at a coarser unit:
        # the plausible years are picked before the conversion to ns.
        ok = (stamps.notna() & (stamps >= pd.Timestamp(PLAUSIBLE_YEARS[0], 1, 1, tz="UTC"))
              & (stamps < pd.Timestamp(PLAUSIBLE_YEARS[1], 1, 1, tz="UTC"))).to_numpy()
        ns = stamps[ok].dt.tz_convert("UTC").dt.tz_localize(None).astype("datetime64[ns]")
        out[np.flatnonzero(text)[ok]] = ns.to_numpy().astype(np.int64)
        bad[np.flatnonzero(text)[~ok]] = True
    return out, bad


def clock_time_problem(cell: object, unit: str = "s") -> str:
    """Say what a clock time cell should have been, and what it seems to be."""
    low, high = PLAUSIBLE_YEARS
    expected = (f"expected an ISO-8601 time or epoch {_UNIT_NAMES[unit]} (since 1970-01-01 "
                f"UTC) between {low} and {high}")
    try:
        v = float(str(cell))
    except ValueError:
        return f"{expected}, found {cell!r}"
    if not np.isfinite(v):
        return f"{expected}, found {cell!r}"
    fits = [u for u, per in EPOCH_UNITS.items()
            if LATEST_NS / 1e3 <= v * per < LATEST_NS]  # a date after 1970 + 0.23 years
    hint = (f" (as epoch {_UNIT_NAMES[fits[0]]} it is a date: give time_unit = "
            f"\"{fits[0]}\" in the mapping)" if fits and fits[0] != unit else "")
    return f"{expected}, found {cell!r}{hint}"


#: Problems listed per rule (as the wide-log reader lists its cells).
_LISTED = 25
#: What each column of a set is, in the words of a log's problem.
_SET_COLUMNS = {"time": "time", "value": "value", "sigma": "sigma", "time_ref": "time_ref",
                "sensor_x": "sensor east position", "sensor_y": "sensor north position",
                "sensor_z": "sensor height", "sensor_vx": "sensor east velocity",
                "sensor_vy": "sensor north velocity", "sensor_vz": "sensor up velocity"}
_ROW = re.compile(r"^row (\d+), column '(\w+)': ")


def fix_problems(fixes: Fixes, where: Callable[[int, str], str]) -> list[str]:
    """Check a track's fixes by the rules of a measurement file (:mod:`tmakit.rules`)."""
    checks: list[tuple[NDArray[np.float64], str, str, Callable]] = [
        (fixes.lat, "latitude", rules.LATITUDE, lambda v: rules.geo_within(v, "sensor_lat")),
        (fixes.lon, "longitude", rules.LONGITUDE, lambda v: rules.geo_within(v, "sensor_lon")),
        (fixes.alt, "altitude", rules.POSITION, lambda v: rules.state_within_reach(v, 2))]
    if fixes.velocity is not None:
        checks += [(fixes.velocity[:, j], "velocity", rules.VELOCITY,
                    lambda v: rules.state_within_reach(v, 3)) for j in range(3)]
    found: list[str] = []
    for values, name, expected, ok in checks:
        values = np.asarray(values, float)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.isfinite(values) & ok(values)))
        found += [f"{where(int(k), name)}: expected {expected}, found {float(values[k])!r}"
                  for k in bad[:_LISTED]]
    if fixes.heading is not None:
        h = np.asarray(fixes.heading, float)
        bad = np.flatnonzero(~np.isnan(h) & ~KINDS["bearing"].check_values(h))
        found += [f"{where(int(k), 'heading')}: expected {KINDS['bearing'].describe_values()}"
                  f", found {float(h[k])!r}" for k in bad[:_LISTED]]
    t = np.asarray(fixes.time_ns, np.int64)
    bad = np.flatnonzero((t < 0) | (t >= LATEST_NS))
    found += [f"{where(int(k), 'time')}: expected a date between {PLAUSIBLE_YEARS[0]} and "
              f"{PLAUSIBLE_YEARS[1]}" for k in bad[:_LISTED]]
    return found


def checked_rows(path: object, meas: MeasurementSet, where: Sequence[str]
                 ) -> tuple[MeasurementSet, NDArray[np.intp], int]:
    """Check a log's rows by the rules of a measurement file, and merge repeated rows."""
    from .errors import MeasurementFileError

    rank_of_code = np.zeros(len(meas.sensor_names), dtype=np.intp)
    for rank, name in enumerate(meas.sensors):
        rank_of_code[meas.sensor_names.index(name)] = rank
    order = np.lexsort((meas.time, rank_of_code[meas.sensor_code]))
    ordered = meas.take(order)
    found = [_readdressed(p, where, order) for p in rules.column_problems(
        ordered.time, ordered.sensor_code, ordered.kind_code, ordered.value, ordered.sigma,
        ordered.sensor_state, ordered.time_ref, order=False)]
    far, expected = rules.far_times(ordered.time)
    found += [f"{where[order[k]]}: time: expected {expected}, found {ordered.time[k]:.10g} s"
              for k in np.flatnonzero(far)[:_LISTED]]
    drop = []
    for row, first in rules.duplicate_rows(ordered.time, ordered.stream_code(),
                                          ordered.kind_code, ordered.time_ref):
        if (ordered.value[row] == ordered.value[first]
                and ordered.sigma[row] == ordered.sigma[first]):
            drop.append(row)
        elif len(found) < 3 * _LISTED:
            found.append(f"{where[order[row]]}: a second {ordered.kind[row]} of sensor "
                         f"'{ordered.sensor[row]}' at the time of {where[order[first]]} "
                         f"({float(ordered.value[row])!r} against "
                         f"{float(ordered.value[first])!r}): two values at one time cannot "
                         "both be measurements (a time rounded to the second? give its "
                         "fractions)")
    if found:
        raise MeasurementFileError(path, found)  # type: ignore[arg-type]
    keep = np.setdiff1d(np.arange(len(ordered)), np.array(drop, dtype=np.intp))
    return ordered.take(keep), order[keep], len(drop)


def _readdressed(problem: str, where: Sequence[str], order: NDArray[np.intp]) -> str:
    """Name a rules problem (``row N, column 'c': ...``) by the row's place in its log."""
    m = _ROW.match(problem)
    if m is None:
        return problem
    row, column = int(m.group(1)) - 1, m.group(2)
    if column == "value":  # the place names the cell
        return f"{where[order[row]]}: {problem[m.end():]}"
    return f"{where[order[row]]}, {_SET_COLUMNS.get(column, column)}: {problem[m.end():]}"


_CLOCK = re.compile(r"(\d{1,2}):(\d{2})(?::(\d{2}(?:\.\d+)?))?")


def _clock_seconds(text: str, match: re.Match[str], option: str) -> float:
    hours, minutes = int(match[1]), int(match[2])
    seconds = float(match[3]) if match[3] else 0.0
    if hours > 23 or minutes > 59 or seconds >= 60:
        raise ValueError(f"{option} {text!r}: expected a clock time HH:MM or HH:MM:SS (UTC), "
                         "hours 0-23, minutes and seconds 0-59")
    return hours * 3600.0 + minutes * 60.0 + seconds


def reversed_window(start: str, stop: str, start_at: str, stop_at: str) -> str:
    """Say that ``--from`` comes after ``--to`` (each with the time it reads as)."""
    return (f"--from {start} is after --to {stop} ({start_at} > {stop_at}): the window ends "
            "before it starts, so it is empty; give its start with --from and its end with --to")


def seconds_of_time_text(text: str, option: str, origin_ns: int | None,
                         span_ns: tuple[int, int] | None) -> float:
    """Read a time option as seconds since the set's time origin."""
    try:
        seconds = float(text)
    except ValueError:
        pass
    else:
        if not math.isfinite(seconds):
            raise ValueError(f"{option} {text!r}: expected a finite time (s)")
        return seconds
    clock = _CLOCK.fullmatch(text.strip())
    when = None
    if clock is None:
        try:
            when = dt.datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(f"{option} {text!r}: expected seconds, an ISO-8601 clock time (e.g. "
                             "2024-05-01T12:30:00Z) or a clock time of the data's day (e.g. "
                             "12:30 or 12:30:15, UTC)") from None
    if origin_ns is None:
        raise ValueError(f"{option} {text!r}: a clock time needs the file's time origin "
                         "(time_origin), which this file does not give; give seconds")
    if clock is not None:
        of_day = _clock_seconds(text, clock, option)
        if span_ns is None:
            raise ValueError(f"{option} {text!r}: a clock time without a date needs the data's "
                             "day; give the date, e.g. 2024-05-01T12:30:00Z")
        first_day, last_day = (int(t) // (86400 * _NS) for t in span_ns)
        if first_day != last_day:
            raise ValueError(
                f"{option} {text!r}: the data span more than one UTC day ({iso_utc(span_ns[0])} "
                f"to {iso_utc(span_ns[1])}), so a clock time without a date is ambiguous; give "
                f"the date, e.g. {iso_utc(first_day * 86400 * _NS)[:10]}T{text.strip()}Z")
        return (first_day * 86400 * _NS - origin_ns) / _NS + of_day
    assert when is not None
    when = when if when.tzinfo else when.replace(tzinfo=dt.UTC)
    whole = dt.datetime.fromtimestamp(origin_ns // _NS, dt.UTC)
    return (when - whole).total_seconds() - (origin_ns % _NS) / _NS
