"""Where and when a measurement set is: its ENU origin, its clock-time origin, its sensors."""

from __future__ import annotations

import datetime as _dt

import numpy as np
from numpy.typing import NDArray

from ..core.geodesy import enu_to_geodetic
from ..data import MeasurementSet

#: Metadata key of the measurement set's clock-time origin (ISO-8601 UTC of t = 0 s).
TIME_ORIGIN_KEY = "time_origin"


def clock_time(meas: MeasurementSet | None, t: float) -> str | None:
    """Return the UTC clock time of ``t`` seconds when the set records its time origin."""
    if meas is None or TIME_ORIGIN_KEY not in meas.metadata or not np.isfinite(t):
        return None
    try:
        t0 = _dt.datetime.fromisoformat(meas.metadata[TIME_ORIGIN_KEY].replace("Z", "+00:00"))
    except ValueError:
        return None
    if t0.tzinfo is None:
        t0 = t0.replace(tzinfo=_dt.UTC)
    t_utc = (t0 + _dt.timedelta(seconds=float(t))).astimezone(_dt.UTC)
    return t_utc.strftime("%Y-%m-%dT%H:%M:%S.") + f"{t_utc.microsecond // 1000:03d}Z"


def origin_of(meas: MeasurementSet | None) -> tuple[float, float, float] | None:
    """Return the ENU origin ``(lat_deg, lon_deg, alt_m)`` recorded in the metadata, if any."""
    if meas is None or not {"origin_lat", "origin_lon"} <= set(meas.metadata):
        return None
    m = meas.metadata
    return float(m["origin_lat"]), float(m["origin_lon"]), float(m.get("origin_alt", 0.0))


def sensor_position(meas: MeasurementSet, sensor: str, t: float) -> NDArray[np.float64]:
    """Return a sensor's ENU position at time ``t`` from its rows."""
    if sensor not in meas.sensors:
        raise ValueError(f"no measurement of sensor {sensor!r} (sensors: "
                         f"{', '.join(meas.sensors)})")
    sel = None if len(meas.sensors) == 1 else meas.sensor_mask(sensor)
    rows = _bracketing_rows(meas.time, sel, t)
    times, states = meas.time[rows], meas.sensor_state[rows]
    order = np.argsort(times, kind="stable")
    times, states = times[order], states[order]
    if t <= times[0] or t >= times[-1] or times.size == 1:
        k = 0 if t <= times[0] else times.size - 1
        return states[k, :3] + states[k, 3:6] * (t - times[k])
    return np.array([np.interp(t, times, states[:, i]) for i in range(3)])


def _bracketing_rows(time: NDArray[np.float64], sel: NDArray[np.bool_] | None, t: float
                     ) -> NDArray[np.intp]:
    """Give, in file order, the selected rows at ``t`` and at the nearest times either side."""
    if sel is None and np.isfinite(t) and bool(np.all(time[1:] >= time[:-1])):  # in order: searched
        lo, hi = np.searchsorted(time, t, "left"), np.searchsorted(time, t, "right")
        near = (time[lo - 1] if lo > 0 else -np.inf, time[hi] if hi < time.size else np.inf)
        return np.arange(np.searchsorted(time, near[0], "left"),
                         np.searchsorted(time, near[1], "right"))

    def mask(side: NDArray[np.bool_]) -> NDArray[np.bool_]:
        return side if sel is None else side & sel

    before = np.max(time, where=mask(time < t), initial=-np.inf)
    after = np.min(time, where=mask(time > t), initial=np.inf)
    # (no selected time lies strictly between before and t, or t and after)
    return np.flatnonzero(mask((time >= before) & (time <= after)))


#: The altitude references a measurement set's metadata names, in words.
ALTITUDE_REFERENCES = {"ellipsoid": "WGS-84 ellipsoid", "msl": "mean sea level"}


def altitude_reference(meas: MeasurementSet | None) -> str:
    """Return what a measurement set's altitudes are measured from, in words."""
    ref = "ellipsoid" if meas is None else meas.metadata.get("altitude_reference", "ellipsoid")
    return ALTITUDE_REFERENCES.get(ref, ref)


def geodetic_fix(meas: MeasurementSet, t: float, state: NDArray[np.float64]
                 ) -> dict[str, object] | None:
    """Give an ENU position in lat/lon/alt, when the set records its ENU origin."""
    origin = origin_of(meas)
    if origin is None or not np.all(np.isfinite(state[:3])):
        return None
    lat, lon, alt = enu_to_geodetic(state[0], state[1], state[2], origin)
    return {"time": float(t), "lat": float(lat), "lon": float(lon), "alt": float(alt),
            "altitude_reference": altitude_reference(meas)}
