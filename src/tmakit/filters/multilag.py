"""Multi-lag measurement vectors (Chen & Sun, §2.2).

Update ``k`` uses the bearings at samples ``k, k - N1, k - N2, k - N3`` and the range differences
between consecutive ones, each predicted from the state at ``k`` propagated back to its sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..data import MeasurementSet

#: Default lags (samples) of the multi-lag vectors (the paper gives none: docs/tracking.md).
DEFAULT_LAGS: tuple[int, ...] = (8, 16, 24, 32, 40, 48, 56)

#: Times closer than this (s) are the same sample.
TIME_TOL = 1e-6


def _check_lags(lags: Sequence[int]) -> tuple[int, ...]:
    try:
        out = tuple(int(v) for v in lags)
    except (TypeError, ValueError):
        raise ValueError(f"lags must be whole numbers of samples; got {lags!r}") from None
    if not out or any(v < 1 for v in out) or any(b <= a for a, b in pairwise(out)):
        raise ValueError(f"lags must be increasing whole numbers >= 1 (N1 < N2 < ...); "
                         f"got {list(lags)!r}")
    if any(v != float(w) for v, w in zip(out, lags, strict=True)):
        raise ValueError(f"lags must be whole numbers of samples; got {list(lags)!r}")
    return out


def _index_of(times: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index in the sorted sample grid ``times`` of each of ``t`` (-1 if not on the grid)."""
    pos = np.clip(np.searchsorted(times, t - TIME_TOL), 0, times.size - 1)
    ok = np.abs(times[pos] - t) <= TIME_TOL
    return np.where(ok, pos, -1)


class _SensorData:
    """The bearings and lag-1 range differences of one sensor on its sample grid."""

    def __init__(self, meas: MeasurementSet, sensor: str) -> None:
        sel = meas.sensor == sensor
        bear = np.flatnonzero(sel & (meas.kind == "bearing"))
        rd = np.flatnonzero(sel & (meas.kind == "range_difference"))
        parts = [meas.time[bear], meas.time[rd], meas.time_ref[rd]]
        t = np.sort(np.concatenate(parts))
        keep = np.concatenate([[True], np.diff(t) > TIME_TOL]) if t.size else t.astype(bool)
        self.times = t[keep]
        m = self.times.size
        self.bearing = np.full(m, -1, dtype=np.int64)
        if bear.size:
            dup = np.bincount(_index_of(self.times, meas.time[bear]), minlength=m)
            if np.any(dup > 1):
                t_dup = self.times[np.flatnonzero(dup > 1)[0]]
                raise ValueError(f"sensor {sensor!r} has two bearings at t={t_dup:g} s; "
                                 "multi-lag vectors need one per sample")
            self.bearing[_index_of(self.times, meas.time[bear])] = bear
        # link[j]: the row of the range difference from sample j-1 to sample j, or -1.
        self.link = np.full(m, -1, dtype=np.int64)
        if rd.size:
            end = _index_of(self.times, meas.time[rd])
            start = _index_of(self.times, meas.time_ref[rd])
            one = (end >= 1) & (start == end - 1)
            if not np.any(one):
                raise ValueError(f"sensor {sensor!r}: multi-lag vectors are built from lag-1 "
                                 "range differences (time_ref one sample before time); "
                                 "none found")
            self.link[end[one]] = rd[one]
        self.sensor = sensor


def multilag_groups(meas: MeasurementSet, lags: Sequence[int] = DEFAULT_LAGS, *,
                    reuse_inflation: bool = False,
                    start: int = 0) -> list[tuple[float, MeasurementSet]]:
    """Form the multi-lag measurement vectors of ``meas`` (module text; lag-1 links summed).

    Parameters
    ----------
    meas : MeasurementSet
        Per-pulse bearings and lag-1 range differences; other kinds pass on at their time.
    lags : sequence of int, optional
        ``N1 < N2 < ...`` (samples, >= 1).
    reuse_inflation : bool, optional
        Multiply each row's variance by how many updates use its data (not in the paper).
    start : int, optional
        First sample index (>= 0) that gets an update.

    Returns
    -------
    list of (float, MeasurementSet)
        ``(t_k (s), rows)`` for :meth:`~tmakit.filters.TrackingFilter.run_groups`.

    Raises
    ------
    ValueError
        On bad lags or start, no rows, two bearings at a sample, or no lag-1 differences.

    References
    ----------
    Chen & Sun, §2.2 (the vectors), eq. 1 (their noise).
    """
    lags = _check_lags(lags)
    if len(meas) == 0:
        raise ValueError("no measurements to build multi-lag vectors from")
    if start < 0:
        raise ValueError(f"start must be >= 0; got {start}")
    pair = ("bearing", "range_difference")
    sensors = [s for s in meas.sensors if np.any((meas.sensor == s) & np.isin(meas.kind, pair))]
    data = {s: _SensorData(meas, s) for s in sensors}
    other = np.flatnonzero(~np.isin(meas.kind, pair))
    offsets = np.array((0, *lags))
    # Per sensor: the sample sets of every update, then how often each datum is used.
    plans: dict[str, list[tuple[int, NDArray[np.int64]]]] = {}
    use_b: dict[str, NDArray[np.float64]] = {}
    use_i: dict[str, NDArray[np.float64]] = {}
    for s, d in data.items():
        plans[s], use_b[s], use_i[s] = _sensor_plan(d, offsets, start)

    # Assemble the updates in time order (all sensors' vectors at one time go together).
    by_time: dict[float, list[tuple[str, int, NDArray[np.int64]]]] = {}
    for s, plan in plans.items():
        for k, pts in plan:
            by_time.setdefault(round(float(data[s].times[k]), 9), []).append((s, k, pts))
    other_times = np.round(meas.time[other], 9)
    for t in other_times:
        by_time.setdefault(float(t), [])

    value_si, sigma_si = meas.value_si, meas.sigma_si
    groups: list[tuple[float, MeasurementSet]] = []
    for t in sorted(by_time):
        # (time, sensor, kind, value, sigma, sensor state, time_ref, reference state)
        rows: list[tuple] = []
        for s, _k, pts in by_time[t]:
            inflation = (use_b[s], use_i[s]) if reuse_inflation else None
            rows += _vector_rows(meas, s, data[s], pts, inflation, value_si, sigma_si)
        parts = [_rows_to_set(rows, meas.metadata)] if rows else []
        extra = other[np.abs(other_times - t) <= TIME_TOL] if other.size else other
        if extra.size:
            parts.append(meas.take(extra))
        if not parts:
            continue
        group = parts[0] if len(parts) == 1 else MeasurementSet.concatenate(parts,
                                                                             meas.metadata)
        groups.append((max(t, float(np.max(group.time))), group))
    return groups


def _sensor_plan(d: _SensorData, offsets: NDArray[np.int64], start: int
                 ) -> tuple[list[tuple[int, NDArray[np.int64]]], NDArray[np.float64],
                            NDArray[np.float64]]:
    """Plan one sensor's updates ``(k, samples)`` from sample ``start`` on."""
    m = d.times.size
    plan = []
    nb = np.zeros(m)
    ni = np.zeros(m)
    for k in range(min(start, m), m):
        pts = np.unique(np.clip(k - offsets, 0, None))[::-1]  # k first, descending
        plan.append((k, pts))
        nb[pts[d.bearing[pts] >= 0]] += 1
        if pts.size > 1:
            ni[pts[-1] + 1:k + 1] += 1
    return plan, nb, ni


def _vector_rows(meas: MeasurementSet, s: str, d: _SensorData, pts: NDArray[np.int64],
                 inflation: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
                 value_si: NDArray[np.float64], sigma_si: NDArray[np.float64]) -> list[tuple]:
    """Build the rows of one sensor's multi-lag vector over samples ``pts`` (descending)."""
    nan6 = np.full(6, np.nan)
    rows: list[tuple] = []
    for p in pts:
        row = d.bearing[p]
        if row >= 0:
            infl = inflation[0][p] if inflation is not None else 1.0
            rows.append((meas.time[row], s, "bearing", value_si[row],
                         sigma_si[row] * np.sqrt(infl), meas.sensor_state[row],
                         np.nan, nan6))
    for a, b in pairwise(pts):  # sample a later than sample b
        links = d.link[b + 1:a + 1]
        if np.any(links < 0):
            continue
        var = float(np.sum(sigma_si[links] ** 2))
        infl = float(np.mean(inflation[1][b + 1:a + 1])) if inflation is not None else 1.0
        last, first = links[-1], links[0]
        rows.append((meas.time[last], s, "range_difference",
                     float(np.sum(value_si[links])), float(np.sqrt(var * infl)),
                     meas.sensor_state[last], meas.time_ref[first],
                     meas.ref_sensor_state[first]))
    return rows


def _rows_to_set(rows: list[tuple], metadata: dict[str, str]) -> MeasurementSet:
    """Build a measurement set from rows in SI."""
    cols = list(zip(*rows, strict=True))
    n = len(rows)
    out = MeasurementSet.from_si(
        np.array(cols[0], dtype=float), np.array(cols[1]), np.array(cols[2]),
        np.array(cols[3], dtype=float), np.array(cols[4], dtype=float),
        np.array(cols[5], dtype=float).reshape(n, 6), np.array(cols[6], dtype=float),
        np.array(cols[7], dtype=float).reshape(n, 6), dict(metadata), check=False)
    rules.check_set(out, order=False)  # the rows of an update, not in a file's time order
    return out
