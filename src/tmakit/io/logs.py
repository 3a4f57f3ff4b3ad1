"""What the readers of real logs share: clock times, the local frame, the surface rule, velocities.

The readers of Debrief, GPX, NMEA and wide logs (:mod:`.debrief`, :mod:`.nav_tracks`,
:mod:`.wide_log`) turn a platform's fixes (UTC clock time, latitude, longitude, altitude) into
tmakit's sensor states (ENU m, m/s) and seconds, all in the same way:

- **Clock time.** Times are read as UTC nanoseconds (integers), within plausible years
  (:mod:`.epoch_times`).  The set's time origin is the
  first time of the file, floored to the whole second; ``t`` (s) is the difference, computed
  in integers before it becomes a float, so absolute epoch times never enter the numerics.
  The origin is recorded as ``time_origin`` (ISO-8601 UTC) in the set's metadata.
- **Local frame.** The ENU origin is the first fix (or the one given), recorded as
  ``origin_lat``, ``origin_lon``, ``origin_alt`` with ``altitude_reference`` (``ellipsoid``
  or ``msl``).  tmakit has no geoid model: heights above mean sea level are used as they are,
  which shifts the local frame by the geoid height, a constant to within a metre over tens
  of kilometres; the reference says what the origin's (and the output's) altitudes mean.
- **The surface rule** (:func:`surface_dim`).  Sensors whose altitudes all lie within
  :data:`SURFACE_TOLERANCE_M` of the origin's altitude are on a surface (a ship, a level
  flight with GPS noise): the set is 2-D, sensor ``z`` and ``vz`` are 0, the Earth's
  curvature (which puts a point 10 km away 7.8 m below the origin's tangent plane) is not
  mistaken for height.  ``dim=3`` keeps the heights; ``dim=2`` flattens any heights.
- **Velocity from positions** (:func:`velocity_from_positions`) when a log gives none: the
  slope of a least-squares straight line through the fixes within a centred window
  (:data:`VELOCITY_WINDOW_S`) of each fix.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .epoch_times import parse_clock_times

__all__ = [
    "KNOT",
    "SURFACE_TOLERANCE_M",
    "VELOCITY_WINDOW_S",
    "YARD",
    "Fixes",
    "LocalFrame",
    "clock_times",
    "course_speed_velocity",
    "interpolate_heading",
    "interpolate_states",
    "iso_utc",
    "local_frame",
    "parse_clock_times",
    "relative_seconds",
    "surface_dim",
    "time_origin_ns",
    "velocity_from_positions",
]

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

    def sorted(self) -> Fixes:
        """Return the fixes in time order (stable)."""
        order = np.argsort(self.time_ns, kind="stable")
        return Fixes(self.time_ns[order], self.lat[order], self.lon[order], self.alt[order],
                     None if self.velocity is None else self.velocity[order],
                     None if self.lines is None else self.lines[order],
                     None if self.heading is None else self.heading[order])


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
                altitude_reference: str = "ellipsoid",
                tolerance: float = SURFACE_TOLERANCE_M) -> LocalFrame:
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
    d, rule = surface_dim(alts, alt0, dim, tolerance)
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


def clock_times(metadata: dict[str, str], t: NDArray[np.float64]
                ) -> NDArray[np.datetime64] | None:
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
    outside = (t < t_fix[0] - eps) | (t > t_fix[-1] + eps) if len(t_fix) else np.ones(
        t.shape, bool)
    return out, outside


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


#: One knot in m/s (1852 m per hour).
KNOT = 1852.0 / 3600.0
#: One yard in m.
YARD = 0.9144


