"""Sensor states from a measurement file.

ENU columns, or latitude/longitude with an ENU origin; and the sensor state at ``time_ref`` of range
differences: the sensor's own row at that time (the first one), else interpolated between its rows
as :class:`tmakit.sensors.RecordedTrack` does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, SENSOR_STATE_COLUMNS
from .contract import GEO_COLUMNS, Problems, number_text

__all__ = ["ORIGIN_KEYS", "QUERY_ROWS", "Layout", "SensorRecord", "fdoa_carriers",
           "geodetic_to_enu_in_place", "ref_of_sensor", "ref_sensor_state", "resolve_origin",
           "sensor_state"]


#: How a caller of the library gives the ENU origin (the command line replaces it with its flag).
ORIGIN_HINT = "origin=(lat, lon, alt) to read_measurements"


Numbers = dict[str, NDArray[np.float64]]
#: Metadata keys of the ENU origin (degrees, degrees, metres).
ORIGIN_KEYS = ("origin_lat", "origin_lon", "origin_alt")
#: Rows converted from latitude/longitude to ENU at a time (bounds the conversion's arrays).
_ENU_ROWS = 1 << 16


@dataclass(frozen=True)
class Layout:
    """How a file gives the sensor state."""

    geodetic: bool  # Positions as ``sensor_lat``/``sensor_lon`` (degrees) instead of ENU metres
    has_velocity: bool  # The file has both ``sensor_vx`` and ``sensor_vy``
    has_ref: bool  # The file has ``ref_sensor_*`` columns


def resolve_origin(origin: Any, metadata: Mapping[str, str], problems: Problems
                   ) -> tuple[tuple[float, float, float] | None, dict[str, str]]:
    """Return the ENU origin (lat, lon in deg, alt in m): the argument, else the file's."""
    if origin is not None:
        try:
            lat, lon, alt = (float(v) for v in origin)
        except (TypeError, ValueError):
            problems.file.append(f"origin {origin!r}: expected (lat, lon, alt) in degrees, "
                                 "degrees, metres")
            return None, {}
        return (lat, lon, alt), {k: repr(v) for k, v in
                                 zip(ORIGIN_KEYS, (lat, lon, alt), strict=True)}
    if "origin_lat" not in metadata and "origin_lon" not in metadata:
        problems.file.append(
            "sensor positions are given as sensor_lat/sensor_lon but no ENU origin is "
            f"known: pass {ORIGIN_HINT} or add metadata lines "
            "'# origin_lat: ...', '# origin_lon: ...', '# origin_alt: ...'")
        return None, {}
    values = []
    for key in ORIGIN_KEYS:
        text = metadata.get(key, "0" if key == "origin_alt" else "")
        try:
            values.append(float(text))
        except ValueError:
            if text:
                unit = "metres" if key == "origin_alt" else "degrees"
                problems.file.append(
                    f"metadata '{key}': expected a number ({unit}), found {text!r}")
            else:
                problems.file.append(
                    f"metadata '{key}' is missing: the ENU origin needs origin_lat and "
                    "origin_lon (and origin_alt)")
            return None, {}
    return (values[0], values[1], values[2]), {}


def sensor_state(num: Numbers, layout: Layout, origin: Any, problems: Problems
                 ) -> tuple[NDArray[np.float64], dict[str, str]]:
    """Each row's sensor ENU state ``(n, 6)`` (m, m/s), NaN where unknown."""
    n = len(problems.raw.frame)
    zeros = np.zeros(n)
    state = np.full((n, 6), np.nan)
    origin_metadata: dict[str, str] = {}
    if layout.geodetic:
        if "sensor_lat" in num and "sensor_lon" in num:
            enu_origin, origin_metadata = resolve_origin(origin, problems.raw.metadata,
                                                         problems)
            if enu_origin is not None:
                rule = _geodetic_positions(num, enu_origin, state, problems)
                if rule:
                    origin_metadata["dim_rule"] = rule
    else:
        for i, c in enumerate(("sensor_x", "sensor_y", "sensor_z")):
            state[:, i] = num.get(c, zeros if c == "sensor_z" else np.full(n, np.nan))
    for i, c in enumerate(("sensor_vx", "sensor_vy", "sensor_vz"), start=3):
        state[:, i] = num.get(c, zeros)
    return state, origin_metadata


def _geodetic_positions(num: Numbers, origin: tuple[float, float, float],
                        state: NDArray[np.float64], problems: Problems) -> str:
    """Fill ENU positions from lat/lon/alt; return the surface rule's text if it flattened."""
    state[:, 0], state[:, 1] = num["sensor_lat"], num["sensor_lon"]
    state[:, 2] = num.get("sensor_alt", origin[2])
    state[problems.bad_rows(*GEO_COLUMNS), :3] = np.nan  # pymap3d refuses |lat| > 90
    try:
        return geodetic_to_enu_in_place(state, origin,
                                        problems.raw.metadata.get("dim", "").strip() == "3")
    except ValueError as err:
        state[:, :3] = np.nan
        problems.file.append(f"origin {origin}: {err}")
        return ""


def geodetic_to_enu_in_place(state: NDArray[np.float64], origin: tuple[float, float, float],
                             dim3: bool) -> str:
    """Convert latitude, longitude, altitude in ``state[:, :3]`` to ENU, block by block.

    Sensors on a surface (:func:`.logs.surface_dim`, NaN rows aside) are flattened to the origin's
    altitude, and the rule's text returned ("" in 3-D).
    """
    from ..core.geodesy import geodetic_to_enu
    from .logs import surface_dim

    n, alt0 = state.shape[0], origin[2]
    worst, spread = alt0, -1.0  # the altitude farthest from the origin's
    for lo in range(0, n, _ENU_ROWS):
        off = np.nan_to_num(np.abs(state[lo:lo + _ENU_ROWS, 2] - alt0), nan=-1.0)
        i = int(np.argmax(off))
        if off[i] > spread:
            worst, spread = float(state[lo + i, 2]), float(off[i])
    dim, rule = surface_dim(np.array([worst]), alt0, 3 if dim3 else None)
    for lo in range(0, n, _ENU_ROWS):
        block = state[lo:lo + _ENU_ROWS]
        alt = block[:, 2] if dim == 3 else np.where(np.isfinite(block[:, 2]), alt0, np.nan)
        with np.errstate(invalid="ignore"):
            e, nn, u = geodetic_to_enu(block[:, 0], block[:, 1], alt, origin)
        block[:, 0], block[:, 1], block[:, 2] = e, nn, (0.0 * u if dim == 2 else u)
    return rule if dim == 2 else ""


def ref_sensor_state(num: Numbers, state: NDArray[np.float64], sensor: NDArray[np.object_],
                     is_rd: NDArray[np.bool_], ref_given: NDArray[np.bool_], layout: Layout,
                     problems: Problems, ref_name: NDArray[np.object_] | None = None,
                     named: NDArray[np.bool_] | None = None) -> NDArray[np.float64]:
    """Sensor state at time_ref ``(n, 6)`` of the range-difference rows (NaN on others).

    ``named`` rows (tdoa/fdoa naming their ``ref_name`` without its state) take the named
    sensor's state at their time from that sensor's rows, as range differences take their own.
    """
    n = state.shape[0]
    ref = np.full((n, 6), np.nan)
    for i, c in enumerate(REF_STATE_COLUMNS):
        col = num.get(c, np.zeros(n) if i >= 2 else np.full(n, np.nan))
        given = ref_given if named is None else ref_given & ~named
        ref[given, i] = col[given]
    if "time" not in num or ("time_ref" not in num and named is None):
        return ref
    time_ref = num.get("time_ref", num["time"])
    need = (is_rd & ~ref_given & np.isfinite(time_ref)
            & ~problems.bad_rows("time", "sensor", "time_ref"))
    if named is not None:
        named = named & ~problems.bad_rows("time", "ref_sensor")
    if not np.any(need) and (named is None or not np.any(named)):
        return ref
    state_cols = [c for c in (*SENSOR_STATE_COLUMNS, *GEO_COLUMNS) if c in num]
    usable = (~problems.bad_rows("time", "sensor", *state_cols)
              & np.all(np.isfinite(state), axis=1))
    if not np.any(usable):  # no position at all (no origin, bad cells): reported already
        return ref
    for s in dict.fromkeys(sensor[need]):
        ref_of_sensor(s, np.flatnonzero(need & (sensor == s)),
                       np.flatnonzero(usable & (sensor == s)), num["time"], time_ref, state,
                       ref, layout.has_velocity, problems)
    if named is not None and ref_name is not None:
        for s in dict.fromkeys(ref_name[named]):
            ref_of_sensor(s, np.flatnonzero(named & (ref_name == s)),
                           np.flatnonzero(usable & (sensor == s)), num["time"], num["time"],
                           state, ref, layout.has_velocity, problems, "ref_sensor")
    return ref


def fdoa_carriers(num: Numbers, kind: NDArray[np.object_], metadata: Mapping[str, str],
                  problems: Problems) -> dict[str, str]:
    """Bring fdoa rows with their own ``carrier`` to the file's one carrier (metadata).

    A row measured at carrier ``f`` is the row that carrier ``F`` would give times ``F / f``
    (value and sigma: the FDOA is ``-(f / c)`` times the range-rate difference), so rows of
    several carriers (a frequency-hopping emitter) become one set at the file's carrier
    (its ``fdoa_carrier`` metadata, else the first row's).  Returns the metadata to add.
    """
    if "carrier" not in num:
        return {}
    own = num["carrier"]
    rows = np.flatnonzero((kind == "fdoa") & np.isfinite(own) & (own > 0))
    stated = metadata.get("fdoa_carrier", "").strip()
    try:
        common = float(stated) if stated else (float(own[rows[0]]) if rows.size else None)
    except ValueError:
        return {}  # refused by the metadata's own check
    if common is None:
        return {}
    for row in np.flatnonzero((kind == "fdoa") & np.isnan(own)) if not stated else ():
        problems.cell(int(row), "carrier", "a carrier (Hz): other fdoa rows give theirs and "
                      "the file states no fdoa_carrier")
    scale = common / own[rows]
    for c in ("value", "sigma"):
        if c in num:
            num[c][rows] *= scale
    return {"fdoa_carrier": repr(common)}


def ref_of_sensor(sensor: str, rows: NDArray[np.intp], mine: NDArray[np.intp] | None,
                  t: NDArray[np.float64], time_ref: NDArray[np.float64],
                  state: NDArray[np.float64], ref: NDArray[np.float64], has_velocity: bool,
                  problems: Problems, column: str = "time_ref") -> None:
    """Fill ``ref[rows]`` from the sensor's usable rows ``mine`` (exact time, else interpolated)."""
    record = SensorRecord(t, state, mine, has_velocity)
    missing = record.fill(rows, time_ref, ref)
    if not np.any(missing):
        return
    times = record.times
    known = (f"its rows span {number_text(times[0])} to {number_text(times[-1])} s"
             if times.shape[0] > 0 else "it has no other usable rows")
    for row in rows[missing]:
        at = number_text(time_ref[row])
        if column == "ref_sensor":
            problems.cell(int(row), column, f"a sensor whose position at the row's time is "
                          f"known ('{sensor}': {known}; or give the ref_sensor_* columns)",
                          f"{sensor} (no position of it known at {at} s)")
        else:
            problems.cell(int(row), column,
                          f"a time at which sensor '{sensor}' has a known position ({known}; "
                          "or give the ref_sensor_* columns)",
                          f"{at} (no sensor position known at time_ref {at} s)")


#: Times looked up at a time (bounds the temporaries of a look-up: about 100 bytes each).
QUERY_ROWS = 1 << 16


def _non_decreasing(t: NDArray[np.float64]) -> bool:
    """Tell whether ``t`` never decreases (NaN: no), checked a block at a time."""
    for lo in range(0, max(t.shape[0] - 1, 0), QUERY_ROWS):
        seg = t[lo:lo + QUERY_ROWS + 1]
        if not np.all(seg[1:] >= seg[:-1]):
            return False
    return True


class SensorRecord:
    """A sensor's usable rows in time order, to look its state up at given times.

    Parameters
    ----------
    t : numpy.ndarray
        Every row's time (s).
    state : numpy.ndarray, shape (n, 6)
        Every row's sensor state (ENU m, m/s).
    mine : numpy.ndarray of int or None
        The sensor's usable rows in file order; None for every row.
    has_velocity : bool
        The file gives sensor velocities (else interpolated velocities are 0).
    """

    def __init__(self, t: NDArray[np.float64], state: NDArray[np.float64],
                 mine: NDArray[np.intp] | None, has_velocity: bool) -> None:
        times = t if mine is None else t[mine]
        self.state, self.has_velocity = state, has_velocity
        # row of the file of each entry of self.times (None: the entry's own index)
        self.index: NDArray[np.intp] | None = mine
        if not _non_decreasing(times):  # one entry per time (the first row), in time order
            times, first = np.unique(times, return_index=True)
            self.index = first if mine is None else mine[first]
        #: The sensor's times (s), non-decreasing (a time may repeat).
        self.times: NDArray[np.float64] = times
        self._spline: Any = None

    def _rows(self, k: NDArray[np.intp]) -> NDArray[np.intp]:
        """Give the file rows of entries ``k`` of :attr:`times`."""
        return k if self.index is None else self.index[k]

    def fill(self, rows: NDArray[np.intp], time_ref: NDArray[np.float64],
             ref: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Fill ``ref[rows]`` with the state at ``time_ref[rows]``; flag rows without one."""
        missing = np.ones(rows.shape[0], dtype=bool)
        m = self.times.shape[0]
        if m == 0:
            return missing
        for lo in range(0, rows.shape[0], QUERY_ROWS):
            r = rows[lo:lo + QUERY_ROWS]
            tr = time_ref[r]
            at = np.searchsorted(self.times, tr)  # the first entry at or after time_ref
            found = self.times[np.minimum(at, m - 1)] == tr
            ref[r[found]] = self.state[self._rows(at[found])]
            inside = ~found & (tr >= self.times[0]) & (tr <= self.times[-1])
            if np.any(inside):
                ref[r[inside]] = self._between(at[inside], tr[inside])
            missing[lo:lo + QUERY_ROWS] = ~found & ~inside
        return missing

    def _between(self, at: NDArray[np.intp], tr: NDArray[np.float64]) -> NDArray[np.float64]:
        """Interpolate at times ``tr`` strictly between entries ``at - 1`` and ``at``."""
        from ..sensors import RecordedTrack

        if self.has_velocity:  # cubic Hermite: each piece from its two rows only
            before = np.searchsorted(self.times, self.times[at - 1])  # first of that time
            k = np.unique(np.concatenate((before, at)))
            rows = self._rows(k)
            return RecordedTrack(self.times[k], self.state[rows, :3],
                                 self.state[rows, 3:]).states(tr)
        if self._spline is None:  # a spline through every distinct time
            t = self.times
            k = np.flatnonzero(np.concatenate(([True], t[1:] != t[:-1])))
            self._spline = RecordedTrack(t[k], self.state[self._rows(k), :3])
        out = self._spline.states(tr)
        out[:, 3:] = 0.0  # like the sensor velocities, absent from the file
        return out
