"""A batch solution as Debrief lines, GeoJSON or KML (``tma estimate --export``).

Points every ``every`` seconds over the data's span, each with the answers tmakit prints.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..core.geodesy import enu_to_geodetic
from ..data import MeasurementSet
from ..results import EstimateResult
from ..results.answers import KNOT, Answer, estimate_answer
from ..results.context import clock_time, origin_of
from .logs import YARD
from .tables import atomic_write

__all__ = ["SOLUTION_SUFFIXES", "YARD", "check_solution_data", "geojson_document", "rep_lines",
           "solution_answers", "write_solution"]

#: The suffixes a solution is written to, by format.
SOLUTION_SUFFIXES = (".rep", ".geojson", ".kml")
#: At most this many points are written.
MAX_POINTS = 10_000


def solution_answers(meas: MeasurementSet, result: EstimateResult, every: float = 60.0,
                     sensor: str | None = None, level: float = 0.95) -> list[Answer]:
    """Give the solution's answers every ``every`` seconds over the data's span."""
    return [estimate_answer(result, meas, time=float(t), sensor=sensor, level=level)
            for t in solution_times(meas, every)]


def solution_times(meas: MeasurementSet, every: float) -> np.ndarray:
    """Give the solution points' times, every ``every`` s and the last; refuse too many."""
    if not every > 0:
        raise ValueError(f"the step between solution points must be > 0 s, got {every:g}")
    t0, t1 = float(meas.time.min()), float(meas.time.max())
    count = math.ceil((t1 - t0) / every) + 1  # (counted before np.arange allocates them)
    if count > MAX_POINTS:
        raise ValueError(f"{count:.6g} solution points at one every {every:g} s: more than "
                         f"{MAX_POINTS}; write fewer (a longer step, --export-every)")
    return np.append(np.arange(t0, t1, every), t1)


def _dms(value: float, hemispheres: str, width: int) -> str:
    """Degrees as Debrief writes them: ``DD MM SS.SSS H`` (``DDD`` for longitudes)."""
    hem = hemispheres[0] if value >= 0 else hemispheres[1]
    ms = round(abs(value) * 3_600_000)  # milliseconds of arc: no 60 after rounding
    d, rest = divmod(ms, 3_600_000)
    m, s = divmod(rest, 60_000)
    return f"{d:0{width}d} {m:02d} {s / 1000:06.3f} {hem}"


def _token(name: str) -> str:
    """Give a name as one token of a replay line (quoted where it has spaces; no quote inside)."""
    name = name.replace('"', "'").strip() or "-"
    return f'"{name}"' if re.search(r"\s", name) else name


def _solution_token(name: str) -> str:
    """Give a solution's name as Debrief reads it: one token, unquoted (spaces become ``_``)."""
    return re.sub(r"\s+", "_", name.strip()).replace('"', "'") or "TMAKIT"


def _stamp(clock: str) -> str:
    """``YYMMDD HHMMSS.SSS`` from an ISO UTC time."""
    t = dt.datetime.fromisoformat(clock.replace("Z", "+00:00"))
    return t.strftime("%y%m%d %H%M%S.") + f"{t.microsecond // 1000:03d}"


def _ellipse_tokens(a: Answer) -> str:
    e = a.ellipse
    if e is None or not all(map(math.isfinite, (e.semi_major, e.semi_minor, e.orientation_deg))):
        return "NULL"
    return f"{e.orientation_deg % 360:.1f} {e.semi_major / YARD:.1f} {e.semi_minor / YARD:.1f}"


def _motion_tokens(a: Answer) -> str:
    course = a.course_deg if a.course_deg is not None else 0.0
    speed = a.speed / KNOT if a.speed is not None else 0.0
    up = a.enu[2] if len(a.enu) > 2 and a.enu[2] is not None else 0.0
    depth = -float(up) if a.dim == 3 else 0.0
    return f"{course % 360:.1f} {speed:.2f} {depth:.1f}"


def rep_lines(answers: list[Answer], solution: str, label: str,
              range_bearing: bool = False) -> list[str]:
    """Give the Debrief lines of a solution (``;TMA_POS:``; ``;TMA_RB:`` when asked)."""
    lines = []
    for a in answers:
        assert a.clock is not None and a.geodetic is not None
        lat, lon = a.geodetic[0], a.geodetic[1]
        assert lat is not None and lon is not None
        head = f"{_stamp(a.clock)} {_token(a.sensor or 'TMAKIT')} @C"
        tail = f"{_solution_token(solution)} {_ellipse_tokens(a)} {_motion_tokens(a)} {label}"
        lines.append(f";TMA_POS: {head} {_dms(lat, 'NS', 2)} {_dms(lon, 'EW', 3)} {tail}")
        if range_bearing and a.range_m is not None and a.bearing_deg is not None:
            lines.append(f";TMA_RB: {head} {a.bearing_deg % 360:.2f} {a.range_m / YARD:.1f} {tail}")
    return lines


def _ellipse_ring(a: Answer, origin: tuple[float, float, float], n: int = 72
                  ) -> list[list[float]] | None:
    """Give the ellipse as a closed counter-clockwise ring of [lon, lat] (None: none)."""
    e = a.ellipse
    if e is None or None in a.enu[:2]:
        return None
    phi = np.radians(e.orientation_deg)
    u = np.linspace(0.0, 2.0 * np.pi, n + 1)  # counter-clockwise seen from above
    along, across = e.semi_major * np.cos(u), e.semi_minor * np.sin(u)
    # major axis along the bearing phi (clockwise from North): its unit (sin, cos)
    east = float(a.enu[0]) + along * np.sin(phi) - across * np.cos(phi)  # type: ignore[arg-type]
    north = float(a.enu[1]) + along * np.cos(phi) + across * np.sin(phi)  # type: ignore[arg-type]
    lat, lon, _ = enu_to_geodetic(east, north, np.zeros_like(east), origin)
    ring = [[float(x), float(y)] for x, y in zip(lon, lat, strict=True)]
    ring[-1] = ring[0]
    return ring


def _point_properties(a: Answer) -> dict[str, Any]:
    e = a.ellipse
    return {"time": a.clock, "t_s": a.time, "course_deg": a.course_deg,
            "speed_m_s": a.speed, "speed_kn": None if a.speed is None else a.speed / KNOT,
            "ellipse_level": None if e is None else e.level,
            "ellipse_semi_major_m": None if e is None else e.semi_major,
            "ellipse_semi_minor_m": None if e is None else e.semi_minor,
            "ellipse_orientation_deg": None if e is None else e.orientation_deg,
            "sensor": a.sensor, "range_m": a.range_m, "bearing_deg": a.bearing_deg}


def geojson_document(answers: list[Answer], origin: tuple[float, float, float],
                     properties: dict[str, Any]) -> dict[str, Any]:
    """Give the solution as an RFC 7946 FeatureCollection."""
    coords = [[float(a.geodetic[1]), float(a.geodetic[0])]  # type: ignore[index,arg-type]
              for a in answers]
    features: list[dict[str, Any]] = [{"type": "Feature", "properties": {**properties,
                                                                       "role": "track"},
                                       "geometry": {"type": "LineString",
                                                    "coordinates": coords}}]
    for a, c in zip(answers, coords, strict=True):
        features.append({"type": "Feature", "properties": {"role": "point",
                                                           **_point_properties(a)},
                         "geometry": {"type": "Point", "coordinates": c}})
        ring = _ellipse_ring(a, origin)
        if ring is not None:
            features.append({"type": "Feature", "properties": {"role": "ellipse",
                                                               "time": a.clock},
                             "geometry": {"type": "Polygon", "coordinates": [ring]}})
    return {"type": "FeatureCollection", "features": features}


def _write_kml(path: Path, answers: list[Answer], origin: tuple[float, float, float],
               name: str, description: str) -> None:
    import simplekml

    kml = simplekml.Kml(name=name)
    track = kml.newlinestring(name=f"{name}: track", description=description,
                              coords=[(a.geodetic[1], a.geodetic[0])  # type: ignore[index]
                                      for a in answers])
    track.style.linestyle.color = simplekml.Color.red
    track.style.linestyle.width = 2
    for a in answers:
        p = _point_properties(a)
        words = ", ".join(f"{k} {v:.6g}" if isinstance(v, float) else f"{k} {v}"
                          for k, v in p.items() if v is not None)
        pt = kml.newpoint(name=a.clock, description=words,
                          coords=[(a.geodetic[1], a.geodetic[0])])  # type: ignore[index]
        pt.timestamp.when = a.clock
        ring = _ellipse_ring(a, origin)
        if ring is not None:
            poly = kml.newpolygon(name=f"{p['ellipse_level']:.0%} ellipse {a.clock}",
                                  outerboundaryis=[tuple(c) for c in ring])
            poly.style.polystyle.fill = 0
            poly.style.linestyle.color = simplekml.Color.red
    path.write_text(kml.kml(), encoding="utf-8")


def check_solution_data(path: str | Path, meas: MeasurementSet, every: float = 60.0) -> None:
    """Refuse (ValueError) data that cannot place a solution, time it (.rep) or space it."""
    try:
        solution_times(meas, every)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    if origin_of(meas) is None:
        raise ValueError(f"{path}: the measurements have no ENU origin (latitude/longitude): "
                         "give --origin LAT,LON[,ALT]")
    if Path(path).suffix.lower() == ".rep" and clock_time(meas, 0.0) is None:
        raise ValueError(f"{path}: Debrief lines need clock times and the measurements have "
                         "no time origin")


def write_solution(path: str | Path, meas: MeasurementSet, result: EstimateResult, *,
                   every: float = 60.0, sensor: str | None = None, range_bearing: bool = False,
                   name: str | None = None, level: float = 0.95, force: bool = False) -> Path:
    """Write a batch solution as Debrief lines (``.rep``), GeoJSON (``.geojson``) or KML."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SOLUTION_SUFFIXES:
        raise ValueError(f"{path}: unknown solution format {suffix or '(no suffix)'!r}; "
                         f"expected {', '.join(SOLUTION_SUFFIXES)}")
    if result.status != "converged" or not np.all(np.isfinite(result.estimate)):
        raise ValueError(f"{path}: not written: the estimate is {result.status}, no solution")
    check_solution_data(path, meas, every)
    origin = origin_of(meas)
    assert origin is not None
    answers = solution_answers(meas, result, every, sensor, level)
    if any(a.geodetic is None or None in a.geodetic[:2] for a in answers):
        raise ValueError(f"{path}: not written: the data do not determine the position")
    solution = name or "TMAKIT"
    dof = f" chi2/dof {result.chi2 / result.dof:.2f}" if result.dof > 0 else ""
    label = f"tmakit {result.method} {result.motion.name}{dof}"
    with atomic_write(path, force=force, keep_suffix=True) as tmp:
        if suffix == ".rep":
            lines = [f";; {label}: solution {solution}, {level:.0%} ellipses (semi-axes, yd), "
                     "speeds in knots", *rep_lines(answers, solution, label, range_bearing)]
            tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
        elif suffix == ".geojson":
            props = {"name": solution, "method": result.method, "motion": result.motion.name,
                     "status": result.status, "chi2": result.chi2, "dof": result.dof,
                     "ellipse_level": level}
            tmp.write_text(json.dumps(geojson_document(answers, origin, props), indent=1),
                           encoding="utf-8")
        else:
            _write_kml(tmp, answers, origin, solution, label)
    return path
