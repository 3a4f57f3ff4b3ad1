"""Wide logs (one row per sample, one column per quantity) as measurement sets.

The sensor's positions come from the log's own columns, or from an own track joined by time: GPX
(gpxpy) or NMEA 0183 (pynmea2; RMC, GGA, VTG, HDT, ZDA).
"""

from __future__ import annotations

import datetime as dt
import operator
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..data import MeasurementSet
from ..measurements import KINDS
from .checker import FORMAT_LINE
from .errors import MeasurementFileError, add_reader_notes, refuse_unreadable
from .formats import Format, register_format
from .logs import (
    KNOT,
    LATEST_NS,
    Fixes,
    LocalFrame,
    checked_rows,
    clock_time_problem,
    course_speed_velocity,
    csv_separator,
    fill_altitudes,
    fix_problems,
    interpolate_heading,
    interpolate_states,
    iso_utc,
    local_frame,
    one_fix_a_time,
    parse_clock_times,
    relative_seconds,
    time_origin_ns,
    velocity_from_positions,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .log_mapping import LogMapping

__all__ = ["GPX", "NMEA", "WIDE", "read_gpx_fixes", "read_nmea_fixes", "read_track_fixes",
           "read_track_log", "read_wide_log"]


class _Table:
    """The log's cells, the line of each row (CSV) and the problems found."""

    def __init__(self, path: Path, frame: pd.DataFrame, lines: NDArray[np.int64] | None) -> None:
        self.path, self.frame, self.lines = path, frame, lines
        self.problems: list[str] = []
        self.heading: NDArray[np.float64] | None = None  # deg true per row, for relative bearings

    def where(self, row: int, column: str) -> str:
        line = f" (line {self.lines[row]})" if self.lines is not None else ""
        return f"row {row + 1}{line}, column {column!r}"

    def need(self, column: str | None, purpose: str) -> bool:
        if column is None or column in self.frame.columns:
            return True
        self.problems.append(f"column {column!r} ({purpose}) is missing; the file has "
                             f"{', '.join(map(str, self.frame.columns))}")
        return False

    def numbers(self, column: str, what: str, required: bool = True) -> NDArray[np.float64]:
        import pandas as pd

        raw = self.frame[column]
        values = pd.to_numeric(raw, errors="coerce").to_numpy(float, na_value=np.nan)
        empty = raw.isna().to_numpy() | (raw.astype(str).str.strip() == "").to_numpy()
        bad = ~np.isfinite(values) & (~empty if not required else np.ones_like(empty))
        for k in np.flatnonzero(bad)[:25]:
            self.problems.append(f"{self.where(int(k), column)}: expected {what}, found "
                                 f"{raw.iloc[k]!r}")
        return values

    def fail(self) -> None:
        if self.problems:
            raise MeasurementFileError(self.path, self.problems)


def _load(path: Path) -> _Table:
    import pandas as pd

    if not path.exists():
        raise MeasurementFileError(path, ["no such file"])
    refuse_unreadable(path, binary=path.suffix.lower() in (".parquet", ".pq"))
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:  # (an index pandas wrote, df.set_index("utc"), is a column as written)
            frame = pq.read_table(path).to_pandas(ignore_metadata=True)
            return _Table(path, frame.reset_index(drop=True), None)
        except (OSError, ValueError, pa.ArrowException) as e:
            raise MeasurementFileError(path, [f"cannot be read as Parquet ({e})"]) from None
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        if f.readline().startswith(FORMAT_LINE):
            raise MeasurementFileError(path, [
                "is tmakit's own measurement file (its first line says so), not a wide log: "
                "read it without --mapping, --map or --format"])
    try:
        sep = csv_separator(path)
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skip_blank_lines=False,
                            encoding="utf-8-sig", sep=sep)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as e:
        raise MeasurementFileError(path, [f"cannot read the CSV table ({e})"]) from None
    if sep != ",":  # a spreadsheet's export may write decimal commas: 47,95 is 47.95
        frame = frame.replace(_DECIMAL_COMMA, r"\1.\2", regex=True)
    lines = np.arange(len(frame), dtype=np.int64) + 2
    keep = ~(frame.astype(str).apply(lambda c: c.str.strip() == "")).all(axis=1).to_numpy()
    return _Table(path, frame[keep].reset_index(drop=True), lines[keep])


_DECIMAL_COMMA = r"^(\s*[-+]?\d*),(\d+(?:[eE][-+]?\d+)?\s*)$"




def _row_positions(tab: _Table, m: LogMapping) -> tuple[Fixes | None, NDArray | None]:
    """Return the rows' fixes (lat/lon) or ENU positions, from the position columns."""
    p = m.position
    assert p is not None
    cols = [c for c in (p.lat, p.lon, p.alt, p.east, p.north, p.up) if c]
    if not all([tab.need(c, "sensor position") for c in cols]):
        return None, None
    if p.geodetic:
        assert p.lat is not None and p.lon is not None
        lat = tab.numbers(p.lat, f"a latitude ({p.lat_lon_unit})") * p.lat_lon_scale
        lon = tab.numbers(p.lon, f"a longitude ({p.lat_lon_unit})") * p.lat_lon_scale
        alt = (tab.numbers(p.alt, f"an altitude ({p.alt_unit})") * p.alt_scale if p.alt
               else np.zeros(lat.shape))
        fixes = Fixes(np.zeros(lat.shape, np.int64), lat, lon, alt)
        if not tab.problems:  # the file's rules on the values read (tmakit.rules)
            columns = {"latitude": p.lat, "longitude": p.lon, "altitude": p.alt}
            found = fix_problems(fixes, lambda k, q: tab.where(k, columns[q] or q))
            big = np.abs(lat[np.isfinite(lat)])
            if found and p.lat_lon_unit == "deg" and big.size and np.all(big == np.round(big)) \
                    and 90.0 < big.max() <= 90e7:
                found.insert(0, f"column {p.lat!r} holds integers up to {big.max():.0f}: "
                             "latitudes in 1e-7 degrees (as PX4 before v1.14 writes them)? "
                             'Then give lat_lon_unit = "1e-7 deg" (and alt_unit = "mm" for '
                             "millimetres) in [position]")
            tab.problems += found
        return fixes, None
    assert p.east is not None and p.north is not None
    enu = np.column_stack([tab.numbers(p.east, "east (m)"), tab.numbers(p.north, "north (m)"),
                           tab.numbers(p.up, "up (m)") if p.up else np.zeros(len(tab.frame))])
    return None, enu


def _row_velocity(tab: _Table, m: LogMapping) -> NDArray[np.float64] | None:
    v = m.velocity
    if v is None:
        return None
    vertical = v.up or v.down
    if not all([tab.need(c, "sensor velocity") for c in (v.east, v.north, vertical)]):
        return None
    z = tab.numbers(vertical, "a velocity (m/s)") if vertical else np.zeros(len(tab.frame))
    out = np.column_stack([tab.numbers(v.east, "a velocity (m/s)"),
                           tab.numbers(v.north, "a velocity (m/s)"), z])
    if v.frame == "ned":
        out[:, 2] = -out[:, 2]
    return out


def _states(tab: _Table, m: LogMapping, t_ns: NDArray[np.int64], origin: Any, dim: int | None
            ) -> tuple[NDArray[np.float64], dict[str, str], int]:
    """Return each row's sensor state (m, m/s), the frame's metadata, the time origin (ns)."""
    track = read_track_fixes(m.track) if m.track else None
    fixes, enu = _row_positions(tab, m) if m.position is not None else (None, None)
    velocity = _row_velocity(tab, m)
    tab.fail()
    origin = origin if origin is not None else m.origin
    dim = dim if dim is not None else m.dim
    t0 = time_origin_ns(t_ns, *(() if track is None else (track.time_ns,)))
    t = relative_seconds(t_ns, t0)
    source = track if track is not None else fixes
    if source is None:  # east/north/up columns: no frame to build
        assert enu is not None
        pos, meta = enu, _enu_metadata(origin, m)
        if dim == 2:
            pos[:, 2] = 0.0
    else:
        if fixes is not None:
            fixes.time_ns = t_ns
        altitude = m.altitude or (m.position.altitude if m.position else "ellipsoid")
        frame = local_frame([source], origin, dim, altitude)
        meta = frame.metadata()
        if track is not None:
            states = _track_states(tab, track, frame, t, t0, m.velocity_window)
            meta["velocity_source"] = ("the track's speed and course over the ground"
                                       if track.velocity is not None else _derived(m))
            add_reader_notes(meta, *track.notes)
            return states, meta, t0
        assert fixes is not None
        pos = frame.enu(fixes.lat, fixes.lon, fixes.alt)
    if velocity is None:
        velocity = _derive_by_sensor(tab, m, t, pos)
        meta["velocity_source"] = _derived(m)
    else:
        meta["velocity_source"] = f"columns ({m.velocity.frame if m.velocity else ''})"
        if meta.get("dim_rule", "").startswith("2-D") or dim == 2:
            velocity[:, 2] = 0.0
    return np.column_stack([pos, velocity]), meta, t0


def _enu_metadata(origin: Any, m: LogMapping) -> dict[str, str]:
    if origin is None:
        return {}
    lat, lon, alt = (float(v) for v in origin)
    return {"origin_lat": repr(lat), "origin_lon": repr(lon), "origin_alt": repr(alt),
            "altitude_reference": m.altitude or "ellipsoid"}


def _derived(m: LogMapping) -> str:
    return (f"derived from positions: slope of a least-squares line through the fixes within "
            f"{m.velocity_window:g} s (centred)")


def _sensor_ids(tab: _Table, m: LogMapping) -> NDArray[np.str_]:
    if m.sensor_column and tab.need(m.sensor_column, "sensor id"):
        return tab.frame[m.sensor_column].astype(str).str.strip().to_numpy(str)
    return np.full(len(tab.frame), m.sensor)


def _derive_by_sensor(tab: _Table, m: LogMapping, t: NDArray[np.float64],
                      pos: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.zeros_like(pos)
    ids = _sensor_ids(tab, m)
    for s in dict.fromkeys(ids.tolist()):
        rows = np.flatnonzero(ids == s)
        rows = rows[np.argsort(t[rows], kind="stable")]
        out[rows] = velocity_from_positions(t[rows], pos[rows], m.velocity_window)
    return out


def _track_states(tab: _Table, track: Fixes, frame: LocalFrame, t: NDArray[np.float64],
                  t0: int, window: float) -> NDArray[np.float64]:
    tf = relative_seconds(track.time_ns, t0)
    pos = frame.enu(track.lat, track.lon, track.alt)
    vel = track.velocity if track.velocity is not None else velocity_from_positions(tf, pos, window)
    vel = np.array(vel, float)
    if frame.dim == 2:
        vel[:, 2] = 0.0
    states, outside = interpolate_states(tf, np.column_stack([pos, vel]), t)
    if track.heading is not None and tab.heading is None:
        tab.heading = interpolate_heading(tf, track.heading, t)
    span = f"{iso_utc(int(track.time_ns[0]))} to {iso_utc(int(track.time_ns[-1]))}"
    out = np.flatnonzero(outside)
    if out.size == t.size:  # none inside: a clock of another zone or day, not a few rows
        tab.problems.append(
            f"every measurement time ({iso_utc(t0 + round(float(t.min()) * 1e9))} to "
            f"{iso_utc(t0 + round(float(t.max()) * 1e9))}, {t.size} rows) is outside the own "
            f"track ({span}): is the log's clock local time read as UTC (give the zone in the "
            "times, e.g. 2026-05-04T11:30:00+02:00), or the track of another day?")
    for k in out[:25] if out.size < t.size else []:
        tab.problems.append(f"{tab.where(int(k), 'time')}: time "
                            f"{iso_utc(t0 + round(float(t[k]) * 1e9))} is outside the own "
                            f"track ({span})")
    tab.fail()
    _gap_warning(track, tf, t, t0)
    return states


def _gap_warning(track: Fixes, tf: NDArray[np.float64], t: NDArray[np.float64], t0: int) -> None:
    """Warn of measurements between fixes far apart (a receiver off, a track's segments)."""
    if tf.size < 3:
        return
    step = np.diff(tf)
    long = max(60.0, 10.0 * float(np.median(step)))
    at = np.clip(np.searchsorted(tf, t, side="right") - 1, 0, tf.size - 2)
    inside = (step[at] > long) & (t > tf[at]) & (t < tf[at + 1])
    if inside.any():
        worst = int(at[inside][np.argmax(step[at[inside]])])
        track.notes.append(
            f"warning: {int(inside.sum())} measurements fall where the own track has no fix "
            f"for more than {long:g} s (the longest gap: {step[worst]:g} s, from "
            f"{iso_utc(int(track.time_ns[worst]))}): their positions are interpolated in a "
            "straight line across the gap, which the sensor may not have followed")


def read_wide_log(path: str | os.PathLike[str], *, mapping: Any = None,
                  origin: Any = None, dim: int | None = None,
                  track: str | None = None) -> MeasurementSet:
    """Read a wide CSV/Parquet log through a column mapping (see the module text)."""
    from .log_mapping import LogMapping, MappingError, load_mapping

    path = Path(path)
    try:
        if mapping is None:
            raise MappingError("a wide log needs a column mapping (a TOML file: --mapping, or "
                               "--map/--measure on the command line)")
        m = mapping if isinstance(mapping, LogMapping) else load_mapping(mapping, track)
    except MappingError as e:
        raise MeasurementFileError(path, [str(e)]) from None
    if track is not None:
        m = m.model_copy(update={"track": str(track)})
    tab = _load(path)
    tab.need(m.time, "time")
    for spec in m.measurement:
        tab.need(spec.column, f"{spec.kind} in {spec.unit}")
        tab.need(spec.sigma_column, f"sigma of {spec.column}")
        tab.need(spec.ambiguous, f"the ambiguous twin of {spec.column}")
    if m.heading and tab.need(m.heading, "heading (deg true)"):
        tab.heading = tab.numbers(m.heading, "a heading (deg)", required=False)
    tab.fail()
    if m.heading and tab.heading is not None:
        h = tab.heading
        for k in np.flatnonzero(np.isfinite(h) & ~KINDS["bearing"].check_values(h))[:25]:
            tab.problems.append(f"{tab.where(int(k), m.heading)}: expected "
                                f"{KINDS['bearing'].describe_values()}, found {float(h[k])!r}")
    t_ns, bad = parse_clock_times(tab.frame[m.time].tolist(), m.time_unit)
    for k in np.flatnonzero(bad)[:25]:
        tab.problems.append(f"{tab.where(int(k), m.time)}: "
                            f"{clock_time_problem(tab.frame[m.time].iloc[k], m.time_unit)}")
    tab.fail()
    try:
        states, meta, t0 = _states(tab, m, t_ns, origin, dim)
    except ValueError as e:
        if isinstance(e, MeasurementFileError):
            raise
        raise MeasurementFileError(path, [str(e)]) from None
    return _assemble(tab, m, relative_seconds(t_ns, t0), states,
                     {"source": f"wide log {path.name}", "time_origin": iso_utc(t0), **meta})


def _headings(tab: _Table, column: str, rows: NDArray[np.intp]) -> NDArray[np.float64]:
    """Return the heading (deg) of each row of a relative bearing, or record the problem."""
    heading = tab.heading[rows] if tab.heading is not None else np.full(rows.size, np.nan)
    for k in rows[~np.isfinite(heading)][:25]:
        tab.problems.append(f"{tab.where(int(k), column)}: a bearing relative to the heading "
                            "needs the heading at its time (mapping key heading = COLUMN, or "
                            "HDT sentences in the NMEA track)")
    return heading


def _twins(tab: _Table, column: str, unit: str, rows: NDArray[np.intp]) -> NDArray[np.float64]:
    """Return the ambiguous twin (in the unit) of each bearing row; refuse a missing one."""
    twin = tab.numbers(column, f"an ambiguous bearing in {unit}", required=False)[rows]
    degrees = twin if unit == "deg" else np.degrees(twin)
    for k in rows[~np.isfinite(twin)][:25]:
        tab.problems.append(f"{tab.where(int(k), column)}: the bearing in this row has no "
                            "ambiguous twin (a towed array gives both; leave the bearing empty "
                            "too, or map the column without ambiguous)")
    bad = np.flatnonzero(np.isfinite(twin) & ~KINDS["bearing"].check_values(degrees))
    for i in bad[:25]:
        tab.problems.append(f"{tab.where(int(rows[i]), column)}: expected "
                            f"{KINDS['bearing'].describe_values()}, found {float(twin[i]):.6g}")
    return twin


def _column_sensors(m: LogMapping, metadata: dict[str, str]) -> dict[str, str]:
    """Name columns' own sensors: its ``sensor`` key, else its name where columns share a kind."""
    named = {s.column: s.sensor for s in m.measurement if s.sensor is not None}
    kinds = [s.kind for s in m.measurement if s.sensor is None and s.kind != "frequency"]
    shared = [s for s in m.measurement if s.sensor is None and s.kind != "frequency"
              and kinds.count(s.kind) > 1]
    if shared:
        base = "ID" if m.sensor_column else m.sensor
        note = (f"note: {len(shared)} columns measure one kind on one sensor "
                f"({', '.join(s.column for s in shared)}): each is a sensor of its own on the "
                f"same platform ({', '.join(f'{base}/{s.column}' for s in shared)}), fitted "
                "together; a measurement's sensor key names it")
        add_reader_notes(metadata, note)
        prefix = "" if m.sensor_column else f"{m.sensor}/"  # a sensor column's ids prefix them
        named.update({s.column: prefix + s.column for s in shared})
    return named


def _assemble(tab: _Table, m: LogMapping, t: NDArray[np.float64], states: NDArray[np.float64],
              metadata: dict[str, str]) -> MeasurementSet:
    """Make the set: the cells checked as read by the file's rules, then made true and wrapped."""
    from .log_mapping import UNITS

    ids = _sensor_ids(tab, m)
    if m.sensor_column and m.sensor_column in tab.frame.columns:  # (an id is text, not blank)
        raw = tab.frame[m.sensor_column]
        blank = (raw.isna() | (raw.astype(str).str.strip() == "")).to_numpy()
        tab.problems += [f"{tab.where(int(k), m.sensor_column)}: expected a sensor id (text), "
                         "found an empty cell" for k in np.flatnonzero(blank)[:25]]
    own = _column_sensors(m, metadata)
    parts: list[tuple[NDArray, ...]] = []
    where: list[str] = []
    for spec in m.measurement:
        value = tab.numbers(spec.column, f"a {spec.kind} in {spec.unit}", required=False)
        sigma = (tab.numbers(spec.sigma_column, f"a sigma in {spec.unit}", required=False)
                 if spec.sigma_column else np.full(value.shape, spec.sigma))
        rows = np.flatnonzero(np.isfinite(value))
        scale, offset = UNITS[spec.kind][spec.unit]
        twin = (_twins(tab, spec.ambiguous, spec.unit, rows) * scale if spec.ambiguous
                else np.full(rows.size, np.nan))
        sensor = ids[rows] if spec.column not in own else np.char.add(
            ids[rows], "/" + own[spec.column]) if m.sensor_column else np.full(
            rows.size, own[spec.column])
        parts.append((t[rows], sensor, np.full(rows.size, spec.kind),
                      value[rows] * scale + offset, sigma[rows] * scale, states[rows], rows,
                      twin, np.full(rows.size, spec.column if spec.kind == "frequency" else "")))
        where += [tab.where(int(k), spec.column) for k in rows]
    tab.fail()
    cols = [np.concatenate([p[i] for p in parts]) for i in range(9)]  # (a column: a tonal)
    if cols[0].size == 0:
        raise MeasurementFileError(tab.path, ["every measurement cell is empty: nothing measured"])
    time, sensor, kind, value, sigma, state = cols[:6]
    raw = MeasurementSet.from_si(time, sensor, kind, value, sigma, state, metadata=metadata,
                                 check=False, tonal=cols[8] if "frequency" in kind else None)
    meas, kept, merged = checked_rows(tab.path, raw, where)  # the cells as read
    true = np.array(meas.value_si)
    twin = cols[7][kept]
    spec_of = np.concatenate([np.full(p[0].size, i) for i, p in enumerate(parts)])[kept]
    for i, spec in enumerate(m.measurement):
        mine = np.flatnonzero(spec_of == i)
        if spec.reference == "relative":
            heading = np.deg2rad(_headings(tab, spec.column, cols[6][kept[mine]]))
            true[mine] += heading
            twin[mine] += heading
        if spec.kind == "bearing":
            true[mine] = np.mod(true[mine], 2 * np.pi)
            twin[mine] = np.mod(twin[mine], 2 * np.pi)
    tab.fail()
    meas.value_si = true
    if np.any(~np.isnan(twin)):
        meas = meas.with_ambiguous(twin)
        meas.metadata["ambiguous_bearings"] = str(int(np.count_nonzero(~np.isnan(twin))))
    if merged:
        meas.metadata["duplicates_merged"] = str(merged)
    rules.check_set(meas)  # the file rules on the set as written
    return meas


def read_track_log(path: str | os.PathLike[str], *, measurements: Any = None,
                   mapping: Any = None, origin: Any = None,
                   dim: int | None = None) -> MeasurementSet:
    """Read a GPX or NMEA own track joined by time to a wide measurement log."""
    if measurements is None:
        raise MeasurementFileError(path, [
            "an own track gives the sensor's positions only: give the measurement log too "
            "(tma import gpx|nmea TRACK LOG --mapping MAP.toml; measurements= in Python)"])
    return read_wide_log(measurements, mapping=mapping, origin=origin, dim=dim, track=str(path))


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
    points: list[tuple[Any, str]] = [
        (p, f"track {i + 1} segment {j + 1} point {k + 1}") for i, t in enumerate(gpx.tracks)
        for j, s in enumerate(t.segments) for k, p in enumerate(s.points)]
    if not points:
        points = [(p, f"route {i + 1} point {k + 1}") for i, r in enumerate(gpx.routes)
                  for k, p in enumerate(r.points)]
        points += [(p, f"waypoint {k + 1}") for k, p in enumerate(gpx.waypoints)]
    timed = sorted(((p, at) for p, at in points if p.time is not None),
                   key=lambda item: _ns(item[0].time))
    if not timed:
        raise MeasurementFileError(path, [
            f"no GPX point with a time ({len(points)} points without <time>): a sensor track "
            "needs clock times to be joined to the measurements" if points else
            "no GPX point (no <trkpt>, <rtept> or <wpt>): a sensor track needs timed points"])
    notes = ([f"note: {len(points) - len(timed)} of {len(points)} GPX points have no <time> "
              "and are left out"] if len(timed) < len(points) else [])
    timed = _one_point_a_time(path, timed, notes)
    time_ns = np.array([_ns(p.time) for p, _ in timed], np.int64)
    alt, filled = fill_altitudes(time_ns, np.array(
        [np.nan if p.elevation is None else p.elevation for p, _ in timed], float), "no <ele>")
    return Fixes(time_ns, np.array([p.latitude for p, _ in timed], float),
                 np.array([p.longitude for p, _ in timed], float), alt, notes=notes + filled)


_point = operator.attrgetter("latitude", "longitude", "elevation")


def _gpx_position(p: Any) -> str:
    ele = "" if p.elevation is None else f", ele {p.elevation!r} m"
    return f"lat {p.latitude!r}, lon {p.longitude!r}{ele}"


def _one_point_a_time(path: Path, timed: list[tuple[Any, str]], notes: list[str]
                      ) -> list[tuple[Any, str]]:
    """Keep one of each point written twice; refuse two different positions at one time."""
    kept, repeats = one_fix_a_time(  # (a time no clock gives, 1901 say: refused by fix_problems)
        path, timed, lambda pa: t if 0 <= (t := _ns(pa[0].time)) < LATEST_NS else None,
        lambda a, b: _point(a[0]) == _point(b[0]),
        lambda a, b: f"{b[1]}: two different positions at {iso_utc(_ns(b[0].time))}: {a[1]} "
                     f"({_gpx_position(a[0])}) and {b[1]} ({_gpx_position(b[0])}); a sensor is "
                     "at one place at a time (two recordings in one file? give the one of the "
                     "sensor that measured; points logged faster than the times' resolution? "
                     "give the times to a fraction of a second)")
    if repeats:
        more = " and more" if len(repeats) > 5 else ""
        notes.append(f"note: {len(repeats)} GPX point(s) written twice (same time and position) "
                     f"read once: {'; '.join(f'{a[1]} repeats {b[1]}' for a, b in repeats[:5])}"
                     f"{more}")
    return kept


#: The NMEA sentences read, with the fewest fields of a whole one (NMEA 0183 2.x; a sentence
#: without a checksum and fewer fields was cut short). Others (GSV, GSA, GLL, proprietary
#: ``$P...``, AIS ``!AIVDM``, a logger's text) are skipped, as gpsd and GPSBabel skip them.
_NMEA_READ = {"RMC": 11, "GGA": 14, "VTG": 8, "HDT": 2, "ZDA": 6}
_HALF_DAY_S = 43_200


@dataclass
class _Sentence:
    """One sentence read: its line, type, time of day and date (None when not given), fields."""

    line: int
    kind: str
    clock: dt.time | None
    date: dt.date | None
    fields: dict[str, float]
    talker: str = ""


def _nmea_text(raw: str) -> tuple[str | None, bool]:
    """Return a line's sentence if it is of a type read, and whether one was cut short on it."""
    parts = raw.split("$")  # loggers may prefix sentences with a time stamp or a device name
    if len(parts) < 2:
        return None, False
    read = [_nmea_address(p) in _NMEA_READ for p in parts[1:]]
    return ("$" + parts[-1].strip() if read[-1] else None), any(read[:-1])


def _nmea_address(part: str) -> str:
    """Return the sentence type of a sentence's text after ``$`` ('' for proprietary ones)."""
    address = part.split(",", 1)[0].split("*", 1)[0]
    return address[2:] if len(address) == 5 and not address.startswith("P") else ""


def _nmea_record(msg: Any, line: int) -> _Sentence | str | None:
    """Return a sentence's time, date and fields, or why an RMC or GGA holds no fix."""
    kind = msg.sentence_type
    if kind == "RMC":
        if getattr(msg, "status", "A") == "V":
            return "RMC sentences void (status V)"
        if not msg.lat or not msg.lon or not msg.timestamp:
            return "RMC sentences without a time or position"
        if not isinstance(msg.datestamp, dt.date):
            raise ValueError(f"expected the date as DDMMYY, found {msg.datestamp!r}")
        fields = {"lat": msg.latitude, "lon": msg.longitude}
        if msg.spd_over_grnd not in (None, "") and msg.true_course not in (None, ""):
            fields["sog"], fields["cog"] = float(msg.spd_over_grnd), float(msg.true_course)
        return _Sentence(line, kind, msg.timestamp, msg.datestamp, fields)
    if kind == "GGA":
        if not msg.gps_qual:
            return "GGA sentences without a fix (quality 0)"
        if not msg.timestamp or not msg.lat or not msg.lon:
            return "GGA sentences without a time or position"
        alt = float(msg.altitude) if msg.altitude not in (None, "") else np.nan
        if msg.geo_sep not in (None, ""):  # above the ellipsoid = above MSL + geoid height
            alt += float(msg.geo_sep)
        return _Sentence(line, kind, msg.timestamp, None,
                         {"lat": msg.latitude, "lon": msg.longitude, "alt": alt})
    if kind == "ZDA":
        if not msg.timestamp or not msg.day or not msg.month or not msg.year:
            return None
        return _Sentence(line, kind, msg.timestamp, dt.date(int(msg.year), int(msg.month),
                                                              int(msg.day)), {})
    if kind == "VTG" and msg.true_track not in (None, "") and msg.spd_over_grnd_kts not in (
            None, ""):
        return _Sentence(line, kind, None, None, {"sog": float(msg.spd_over_grnd_kts),
                                                  "cog": float(msg.true_track)})
    if kind == "HDT" and msg.heading not in (None, ""):
        return _Sentence(line, kind, None, None, {"heading": float(msg.heading)})
    return None


def _seconds_of_day(clock: dt.time) -> float:
    return clock.hour * 3600 + clock.minute * 60 + clock.second + clock.microsecond / 1e6


def _dated(sentences: list[_Sentence]) -> list[tuple[_Sentence, dt.datetime | None]]:
    """Date each sentence: its own, else the last dated one's, +-1 day across midnight (12 h)."""
    out: list[tuple[_Sentence, dt.datetime | None]] = []
    first = next((s for s in sentences if s.date is not None), None)
    ref = first
    for s in sentences:
        if s.date is not None:
            ref = s
        if s.clock is None or ref is None:
            out.append((s, None))
            continue
        assert ref.clock is not None and ref.date is not None
        day = s.date
        if day is None:
            gap = _seconds_of_day(s.clock) - _seconds_of_day(ref.clock)
            day = ref.date + dt.timedelta(days=(gap < -_HALF_DAY_S) - (gap > _HALF_DAY_S))
        out.append((s, dt.datetime.combine(day, s.clock)))
    return out


def _nmea_fixes(path: Path, lines: list[str]) -> tuple[dict[int, dict], list[str], list[str]]:
    """Parse the sentences into fields by time (ns); the problems and notes by line."""
    import pynmea2

    problems: list[str] = []
    cut: list[int] = []
    sentences: list[_Sentence] = []
    no_fix: dict[str, int] = {}
    for number, raw in enumerate(lines, start=1):
        text, cut_short = _nmea_text(raw)
        if cut_short:
            cut.append(number)
        if text is None:
            continue
        try:
            msg = pynmea2.parse(text, check=False)  # a checksum given is checked
            if "*" not in text and len(msg.data) < _NMEA_READ[msg.sentence_type]:
                cut.append(number)
                continue
            record = _nmea_record(msg, number)
        except (pynmea2.ParseError, ValueError, TypeError, AttributeError) as e:
            problems.append(f"line {number}: cannot read the NMEA sentence ({e})")
            continue
        if isinstance(record, str):
            no_fix[record] = no_fix.get(record, 0) + 1
        elif record is not None:
            record.talker = msg.talker
            sentences.append(record)
    dated = _dated(sentences)
    one, notes = _one_receiver(dated)
    problems += one
    by_time: dict[int, dict] = {}
    last: int | None = None
    undated = 0
    for s, stamp in dated:
        undated += s.kind == "GGA" and stamp is None
        if s.kind in ("RMC", "GGA") and stamp is not None:
            last = _ns(stamp)
            fix = by_time.setdefault(last, {"line": s.line})
            fix.update({k: v for k, v in s.fields.items() if not (
                s.kind == "RMC" and k in ("lat", "lon") and "alt" in fix)})
        elif s.kind in ("VTG", "HDT") and last is not None:
            by_time[last].update(s.fields)
    if not by_time and not problems:
        found = [f"{n} {why}" for why, n in no_fix.items()]
        if undated:
            found.append(f"{undated} GGA fixes but no valid RMC or ZDA sentence to give their "
                         "date")
        problems.append("no fix with a date and time" + (
            f": {'; '.join(found)}" if found else " (no RMC or GGA sentence)"))
    notes += [f"note: {len(cut)} NMEA sentences without a checksum and cut short (line "
              f"{', line '.join(map(str, cut[:5]))}{' and more' if len(cut) > 5 else ''}) "
              "are left out"] if cut else []
    return by_time, problems, notes


#: Two positions at one time farther apart than this (m) are not one receiver's fix.
SAME_FIX_M = 1.0


def _one_receiver(dated: list[tuple[_Sentence, dt.datetime | None]]
                  ) -> tuple[list[str], list[str]]:
    """Refuse the fixes of two receivers in one log; note talkers that agree (one receiver).

    Two RMC/GGA positions at one time more than :data:`SAME_FIX_M` apart, or two talkers
    whose fixes interleave without a common time, are two receivers: the track would jump
    between them.
    """
    at: dict[int, list[_Sentence]] = {}
    for s, stamp in dated:
        if s.kind in ("RMC", "GGA") and stamp is not None:
            at.setdefault(_ns(stamp), []).append(s)
    problems: list[str] = []
    for t, fixes in at.items():
        a, b = max(((a, b) for a in fixes for b in fixes), key=lambda ab: _apart(*ab))
        if _apart(a, b) > SAME_FIX_M:
            problems.append(f"line {a.line} (${a.talker}{a.kind}) and line {b.line} "
                            f"(${b.talker}{b.kind}): two positions {_apart(a, b):.0f} m apart "
                            f"at {iso_utc(t)}")
    spans: dict[str, list[int]] = {}
    for t in sorted(at):
        for s in at[t]:
            spans.setdefault(s.talker, []).append(t)
    talkers = sorted(spans)
    if problems:
        more = f" (and {len(problems) - 3} more times)" if len(problems) > 3 else ""
        drop = (f" (grep -v '\\${talkers[-1]}' leaves out talker {talkers[-1]}'s lines)"
                if len(talkers) > 1 else "")
        return ["; ".join(problems[:3]) + more + ": a log of two receivers (talker"
                f"{'s' if len(talkers) > 1 else ''} {', '.join(talkers)})? A sensor is at one "
                f"place at a time: give one receiver's sentences{drop}"], []
    if len(talkers) < 2:
        return [], []
    shared = set.intersection(*(set(v) for v in spans.values()))
    overlap = max(v[0] for v in spans.values()) <= min(v[-1] for v in spans.values())
    if overlap and not shared:
        first = ", ".join(f"{k} from line {next(s.line for s in at[spans[k][0]] if s.talker == k)}"
                          for k in talkers)
        return [f"the fixes of talkers {' and '.join(talkers)} interleave in time without one "
                f"common time ({first}): a log of two receivers? A sensor is at one place at a "
                "time: give one receiver's sentences"], []
    return [], [f"note: talkers {' and '.join(talkers)} give positions within {SAME_FIX_M:g} m "
                f"of each other at their {len(shared)} common times: read as one receiver"
                if shared else f"note: talkers {' and '.join(talkers)} give fixes one after "
                "the other (no common time): read as one track"]


def _apart(a: _Sentence, b: _Sentence) -> float:
    """Give the horizontal distance of two fixes (m; local flat earth, enough near 1 m)."""
    north = np.radians(a.fields["lat"] - b.fields["lat"]) * 6_371_000.0
    east = (np.radians((a.fields["lon"] - b.fields["lon"] + 180.0) % 360.0 - 180.0) * 6_371_000.0
            * np.cos(np.radians(a.fields["lat"])))
    return float(np.hypot(north, east))


def read_nmea_fixes(path: str | os.PathLike[str]) -> Fixes:
    """Read the fixes of an NMEA 0183 log (RMC, GGA, VTG, HDT, ZDA; see the module text)."""
    path = Path(path)
    # lines as an editor counts them: str.splitlines would also split at the control bytes
    # (\x1c-\x1e, \x0b, \x0c) of a receiver's binary messages between the sentences
    lines = re.split(r"\r\n|\r|\n", path.read_text(encoding="ascii", errors="replace"))
    by_time, problems, notes = _nmea_fixes(path, lines)
    if problems:
        raise MeasurementFileError(path, problems)
    times = np.array(sorted(by_time), np.int64)
    fixes = [by_time[t] for t in times.tolist()]
    velocity: NDArray[np.float64] | None = None
    if all("sog" in f for f in fixes):
        velocity = course_speed_velocity(np.array([f["cog"] for f in fixes]),
                                         np.array([f["sog"] for f in fixes]) * KNOT)
    heading = np.array([f.get("heading", np.nan) for f in fixes], float)
    has_alt = any("alt" in f for f in fixes)
    alt, filled = fill_altitudes(times, np.array(
        [f.get("alt", np.nan if has_alt else 0.0) for f in fixes], float), "RMC without GGA")
    return Fixes(times, np.array([f["lat"] for f in fixes], float),
                 np.array([f["lon"] for f in fixes], float), alt, velocity,
                 np.array([f["line"] for f in fixes], np.int64),
                 heading if np.isfinite(heading).any() else None, notes + filled)


def _has_sentences(path: Path) -> bool:
    """Whether a file's first bytes hold an NMEA sentence's start (``$GPRMC``, ``$GNGGA``)."""
    from ..core.input_files import SNIFF_BYTES

    with open(path, "rb") as f:
        head = f.read(SNIFF_BYTES)
    return re.search(rb"\$[A-Z]{2}(RMC|GGA|VTG|HDT|ZDA),", head) is not None


def read_track_fixes(path: str | os.PathLike[str]) -> Fixes:
    """Read a sensor track by its suffix: ``.gpx`` (GPX), else NMEA 0183."""
    path = Path(path)
    if not path.exists():
        raise MeasurementFileError(path, ["no such track file"])
    gpx = path.suffix.lower() == ".gpx"
    refuse_unreadable(path, binary=True)  # an NMEA log may hold a receiver's binary messages
    if gpx or not _has_sentences(path):  # (u-blox UBX, SiRF) between its sentences, as gpsd
        refuse_unreadable(path)  # reads them; a file without a sentence is refused as binary
    if gpx:
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


#: Wide logs: read with ``format="wide"`` and a mapping (CSV or Parquet; no suffix of its own).
WIDE = register_format(Format("wide", "wide log", (), read_wide_log, None,
                              options=("mapping", "dim", "track")))
#: GPX own tracks joined to a measurement log (``measurements=``, ``mapping=``).
GPX = register_format(Format("gpx", "GPX", (".gpx",), read_track_log, None,
                             options=("measurements", "mapping", "dim")))
#: NMEA 0183 own tracks joined to a measurement log (``measurements=``, ``mapping=``).
NMEA = register_format(Format("nmea", "NMEA 0183", (".nmea", ".nme"), read_track_log, None,
                              options=("measurements", "mapping", "dim")))
