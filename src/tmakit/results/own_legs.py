"""A sensor's path cut into straight legs and turns, and what bearings-only range needs.

Angles from a sensor holding course and speed do not give range until it manoeuvres (Nardone &
Aidala 1981; Fogel & Gavish 1988).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet

LEG_TURN_DEG = 5.0
"""A course change (deg) beyond which a new leg starts."""

LEG_SPEED_CHANGE = 0.1
"""A relative speed change beyond which a new leg starts (with at least 0.5 m/s)."""

HOLDS_COURSE_SPEED = 0.5
"""Below this speed (m/s) a sensor holds no course: the heading of a navigation velocity that
small is the receiver's noise (a GPS velocity has 0.05-0.3 m/s of it), so it makes no turn."""

ONE_SHIP_M = 2000.0
"""Sensors whose paths stay within this distance (m) of each other, at the same velocity, are
on one own ship (a hull array and a towed array on its cable, two receivers on one UAV)."""

ONE_SHIP_SPEED = 2.0
"""The median difference of their velocities (m/s) below which two such sensors move as one."""

_BLOCK = 1 << 14  # rows at a time where a whole log is read (temporaries kept in cache)


@dataclass(frozen=True)
class Leg:
    """One straight leg of a sensor: first and last times (s), course (deg true), speed (m/s)."""

    start: float
    stop: float
    course_deg: float
    speed: float

    def words(self) -> str:
        """Return the leg in words."""
        if self.speed < HOLDS_COURSE_SPEED:
            return f"t = {self.start:g} .. {self.stop:g} s, stationary"
        return (f"t = {self.start:g} .. {self.stop:g} s, course {self.course_deg:.0f}° at "
                f"{self.speed:.3g} m/s")


def straight_legs(time: NDArray[np.float64], state: NDArray[np.float64]) -> list[Leg]:
    """Cut a sensor's path into straight legs (constant course and speed)."""
    v = np.asarray(state, dtype=float)[:, 3:5]
    legs, first = [], 0
    while first < len(time):
        stop = _leg_end(v, first)
        course = _course_speed(v[first:first + 1])[0]
        legs.append(Leg(float(time[first]), float(time[stop - 1]), float(course[0]),
                        float(np.mean(_course_speed(v[first:stop])[1]))))
        first = stop
    return legs


def one_leg(state: NDArray[np.float64]) -> bool:
    """Tell whether a sensor's path is one straight leg (:func:`straight_legs` gives one)."""
    v = np.asarray(state, dtype=float)[:, 3:5]
    return len(v) > 0 and _leg_end(v, 0) == len(v)


def _course_speed(v: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360.0, np.hypot(v[:, 0], v[:, 1])


def _leg_end(v: NDArray[np.float64], first: int) -> int:
    """Give the first row after ``first`` that leaves its leg (``len(v)`` if none)."""
    n, lo, width = len(v), first + 1, 64
    (c0,), (s0,) = _course_speed(v[first:first + 1])
    while lo < n:
        hi = min(n, lo + width)
        c, s = _course_speed(v[lo:hi])
        turn = np.abs((c - c0 + 180.0) % 360.0 - 180.0)
        moving = np.minimum(s, s0) >= HOLDS_COURSE_SPEED
        change = np.abs(s - s0) > max(0.5, LEG_SPEED_CHANGE * s0)
        new = (moving & (turn > LEG_TURN_DEG)) | change
        if new.any():
            return lo + int(np.argmax(new))
        lo, width = hi, 2 * width
    return n


def sensor_legs(meas: MeasurementSet, sensor: str) -> list[Leg]:
    """Return the straight legs of one sensor of a measurement set."""
    rows = meas.sensor_mask(sensor)
    return straight_legs(meas.time[rows], meas.sensor_state[rows])


def range_words(meas: MeasurementSet, sensor: str, manoeuvring_model: bool = False) -> str:
    """Say why range is not observable from a sensor's angles, and which manoeuvre would help."""
    legs = sensor_legs(meas, sensor)
    spans = "; ".join(leg.words() for leg in legs)
    if all(leg.speed < HOLDS_COURSE_SPEED for leg in legs):
        how = (f"sensor {sensor} did not move during these bearings ({spans}), so the "
               "bearings fit the target at any range; only a moving sensor that changes course "
               "can give range")
    else:
        ship = own_ship_sensors(meas, sensor)
        who = sensor if len(ship) == 1 else f"of sensors {' and '.join(ship)}"
        how = (f"the own ship {who} did not manoeuvre during these bearings (one straight leg: "
               f"{spans}), so the bearings fit the target at any range, and its speed along the "
               "line of sight with it. A turn of 30° or more (or a change of speed) for a second "
               "leg about as long as the first lets range be determined")
    if manoeuvring_model:
        how += ("; the manoeuvres the motion model allows the target are no information about "
                "range: a fit that puts one in would choose a range by the shape assumed")
    return f"range is not observable: {how}"


# ---------------------------------------------------------------------------------------------
# Legs and turns from navigation with noise: the heading rate
# ---------------------------------------------------------------------------------------------

TURN_RATE_DEG_S = 0.1
"""A heading rate (deg/s) above which the own ship is turning (6°/min; ships turn at 0.3-3°/s)."""

RATE_WINDOW_S = 60.0
"""The heading rate is the slope of a line through the headings within this many seconds."""

MIN_TURN_DEG = 10.0
"""A turn changes the heading by at least this much (deg) from one leg to the next."""


@dataclass(frozen=True)
class Turn:
    """One own-ship turn: leaves the leg before, reaches the leg after (s), heading change (deg)."""

    start: float
    stop: float
    change_deg: float


@dataclass(frozen=True)
class LegsAndTurns:
    """Own-ship legs and the turns between them, with the thresholds that found them.

    Parameters
    ----------
    legs, turns : list of Leg, list of Turn
        In time order; ``turns[k]`` between ``legs[k]`` and ``legs[k + 1]``.
    turn_rate_deg_s, window_s, min_turn_deg : float
        The thresholds.
    """

    legs: list[Leg]
    turns: list[Turn]
    turn_rate_deg_s: float
    window_s: float
    min_turn_deg: float

    def leg_of(self, time: NDArray[np.float64]) -> NDArray[np.intp]:
        """Return the leg index of each time, -1 in a turn or outside every leg.

        Parameters
        ----------
        time : ndarray
            s.

        Returns
        -------
        ndarray of int
        """
        t = np.asarray(time, dtype=float)
        out = np.full(t.shape, -1, dtype=np.intp)
        for k, leg in enumerate(self.legs):
            out[(t >= leg.start) & (t <= leg.stop)] = k
        return out

    def thresholds(self) -> str:
        """Return the thresholds in words.

        Returns
        -------
        str
        """
        return (f"a turn: heading rate above {self.turn_rate_deg_s:g} deg/s (slope over "
                f"{self.window_s:g} s), changing the heading by {self.min_turn_deg:g} deg or more")

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form: the legs, the turns and the thresholds.

        Returns
        -------
        dict
        """
        return {"legs": [{"start": leg.start, "stop": leg.stop, "course_deg": leg.course_deg,
                          "speed": leg.speed} for leg in self.legs],
                "turns": [{"start": u.start, "stop": u.stop, "change_deg": u.change_deg}
                          for u in self.turns],
                "turn_rate_deg_s": self.turn_rate_deg_s, "window_s": self.window_s,
                "min_turn_deg": self.min_turn_deg, "thresholds": self.thresholds()}


def heading_rate(time: NDArray[np.float64], heading: NDArray[np.float64],
                 window_s: float = RATE_WINDOW_S) -> NDArray[np.float64]:
    """Return the heading rate at each fix: the slope of a line through the nearby headings."""
    t = np.asarray(time, dtype=float)
    n = t.size
    if n < 2:
        return np.zeros(n)
    h = np.unwrap(np.asarray(heading, dtype=float))
    lo, hi = _windows(t, window_s)
    tc = t - t.mean()
    sums = [np.concatenate([[0.0], np.cumsum(v)]) for v in (np.ones(n), tc, h, tc * tc, tc * h)]
    s0, st, sh, stt, sth = (c[hi] - c[lo] for c in sums)
    rate: NDArray[np.float64] = (sth - st * sh / s0) / np.maximum(stt - st * st / s0, 1e-300)
    return rate


def _windows(t: NDArray[np.float64], window_s: float) -> tuple[NDArray[np.intp], ...]:
    """Each fix's window: rows ``lo[k]:hi[k]`` within ``window_s / 2`` (at least 3 rows)."""
    n, idx = t.size, np.arange(t.size)
    lo = np.minimum(np.searchsorted(t, t - window_s / 2, "left"), np.maximum(idx - 1, 0))
    hi = np.maximum(np.searchsorted(t, t + window_s / 2, "right"), np.minimum(idx + 2, n))
    return lo, hi


def _turn_knots(t: NDArray[np.float64], h: NDArray[np.float64], before: float,
                after: float) -> tuple[float, float]:
    """Where a turn leaves the heading ``before`` and reaches ``after`` (s): least squares."""
    knots = t if t.size > 20 else np.unique(np.concatenate(
        [t, *(t[:-1] + f * np.diff(t) for f in np.arange(0.1, 1.0, 0.1))]))
    t1, t2 = knots[:, None, None], knots[None, :, None]
    frac = np.clip((t[None, None, :] - t1) / np.maximum(t2 - t1, 1e-9), 0.0, 1.0)
    frac = np.where(t[None, None, :] >= t2, 1.0, frac)
    cost = np.sum((h - before - (after - before) * frac) ** 2, axis=2)
    cost[t1[:, :, 0] > t2[:, :, 0]] = np.inf
    i, j = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return float(knots[i]), float(knots[j])


def detect_legs(time: NDArray[np.float64], state: NDArray[np.float64], *,
                turn_rate_deg_s: float = TURN_RATE_DEG_S, window_s: float = RATE_WINDOW_S,
                min_turn_deg: float = MIN_TURN_DEG) -> LegsAndTurns:
    """Cut an own ship's navigation into straight legs and turns, from its heading rate."""
    t = np.asarray(time, dtype=float)
    # no sort (nor copy) of a log already in time order
    order = None if np.all(t[1:] >= t[:-1]) else np.argsort(t, kind="stable")
    if order is not None:
        t = t[order]
    # one fix per window_s / 60 (1 s by default) is all a heading rate over window_s needs
    kept = _first_of_each_bin(t, 60.0 / window_s)
    last = int(np.searchsorted(t, t[-1], "left"))  # and the last fix
    kept = np.append(kept[kept < last], last)
    t, first = t[kept], kept if order is None else order[kept]
    v = np.asarray(state, dtype=float)[first, 3:5]
    speed = np.hypot(v[:, 0], v[:, 1])
    lo, hi = _windows(t, window_s)  # the speed of the window's mean velocity: noise averages out
    sums = np.concatenate([np.zeros((1, 2)), np.cumsum(v, axis=0)])
    mean_v = (sums[hi] - sums[lo]) / (hi - lo)[:, None]
    steady = np.minimum(np.hypot(mean_v[:, 0], mean_v[:, 1]), speed) >= HOLDS_COURSE_SPEED
    held = np.maximum.accumulate(np.where(steady, np.arange(t.size), -1))  # a still fix keeps
    held[held < 0] = np.argmax(steady)  # the last steady fix's heading: its own is noise
    heading = np.unwrap(np.arctan2(v[held, 0], v[held, 1]))
    turning = np.abs(heading_rate(t, heading, window_s)) > np.deg2rad(turn_rate_deg_s)
    jump = np.abs(np.diff(heading)) >= np.deg2rad(min_turn_deg)  # a turn between two fixes
    bounds = _straight_runs(turning, jump)
    legs, turns = _merge_small_turns(t, heading, speed, bounds, np.deg2rad(min_turn_deg))
    return LegsAndTurns(legs, turns, turn_rate_deg_s, window_s, min_turn_deg)


def _first_of_each_bin(t: NDArray[np.float64], scale: float) -> NDArray[np.intp]:
    """Give the first of the sorted times ``t`` in each bin ``floor((t - t[0]) * scale)``."""
    firsts, last = [np.zeros(1, dtype=np.intp)], None
    for lo in range(0, t.size, _BLOCK):  # by blocks: no temporary of every row
        bins = t[lo:lo + _BLOCK] - t[0]
        bins *= scale
        np.floor(bins, out=bins)
        if last is not None and bins[0] > last:
            firsts.append(np.array([lo]))
        firsts.append(np.flatnonzero(bins[1:] > bins[:-1]) + (lo + 1))
        last = bins[-1]
    return np.concatenate(firsts)


def _straight_runs(turning: NDArray[np.bool_], jump: NDArray[np.bool_]
                   ) -> list[tuple[int, int]]:
    """Return (first, last) indices of the runs of fixes that are not turning."""
    still = ~turning
    cut = turning[:-1] | turning[1:] | jump  # no run goes on from fix k to fix k + 1
    starts = np.flatnonzero(still & np.concatenate([[True], cut]))
    ends = np.flatnonzero(still & np.concatenate([cut, [True]]))
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _merge_small_turns(t: NDArray[np.float64], h: NDArray[np.float64],
                       speed: NDArray[np.float64], runs: list[tuple[int, int]],
                       min_turn: float) -> tuple[list[Leg], list[Turn]]:
    """Join runs across turns smaller than ``min_turn``; refine the turns' ends; make legs."""
    merged: list[list[int]] = []
    for a, b in runs:
        if merged and abs(np.median(h[a:b + 1]) - np.median(h[merged[-1][0]:merged[-1][1] + 1])
                          ) < min_turn:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    knots: list[tuple[float, float]] = []
    for k in range(len(merged) - 1):  # refine: where the heading leaves / joins each leg
        (a, b), (c, d) = merged[k], merged[k + 1]
        margin = max(3, int(np.count_nonzero(np.abs(t - t[b]) <= 60.0)))
        lo, hi = max(a, b - margin), min(d, c + margin)
        t1, t2 = _turn_knots(t[lo:hi + 1], h[lo:hi + 1], float(np.median(h[a:b + 1])),
                             float(np.median(h[c:d + 1])))
        leave = max(int(np.searchsorted(t, t1, "right")) - 1, a)
        join = min(max(int(np.searchsorted(t, t2, "left")), leave + 1), d)
        merged[k][1], merged[k + 1][0] = leave, join
        knots.append((t1, t2))
    legs = [Leg(float(t[a]), float(t[b]), float(np.degrees(np.median(h[a:b + 1])) % 360.0),
                float(np.median(speed[a:b + 1]))) for a, b in merged]
    turns = [Turn(knots[k][0], knots[k][1],
                  float(np.degrees(np.median(h[merged[k + 1][0]:merged[k + 1][1] + 1])
                                   - np.median(h[merged[k][0]:merged[k][1] + 1]))))
             for k in range(len(legs) - 1)]
    return legs, turns


def own_ship_legs(meas: MeasurementSet, sensor: str | None = None, *,
                     turn_rate_deg_s: float = TURN_RATE_DEG_S, window_s: float = RATE_WINDOW_S,
                     min_turn_deg: float = MIN_TURN_DEG) -> LegsAndTurns:
    """Return the legs and turns of one own ship of a set, all its sensors (:func:`detect_legs`).

    Parameters
    ----------
    meas : MeasurementSet
    sensor : str, optional
        Default the set's only one, or every sensor when all are on one own ship
        (:func:`own_ship_sensors`); a sensor named brings the others on its own ship.
    turn_rate_deg_s, window_s, min_turn_deg : float
        The thresholds (deg/s, s, deg).

    Returns
    -------
    LegsAndTurns

    Raises
    ------
    ValueError
        Several sensors not on one own ship, and none named.
    """
    if sensor is None:
        if len(meas.sensors) != 1 and len(own_ship_sensors(meas)) != len(meas.sensors):
            raise ValueError(f"the set has several sensors ({', '.join(meas.sensors)}) not on "
                             "one own ship: name the own ship whose legs are wanted")
        ship = list(meas.sensors)
    else:
        ship = own_ship_sensors(meas, sensor)
    rows = (slice(None) if set(ship) == set(meas.sensors)
            else np.isin(meas.sensor_code, [meas.sensor_names.index(n) for n in ship]))
    return detect_legs(meas.time[rows], meas.sensor_state[rows],
                       turn_rate_deg_s=turn_rate_deg_s, window_s=window_s,
                       min_turn_deg=min_turn_deg)


def own_ship_sensors(meas: MeasurementSet, sensor: str | None = None) -> list[str]:
    """Return the sensors on one own ship with ``sensor`` (default: the one with most rows).

    Two sensors are on one own ship when, over the time both record, each one's positions lie
    within :data:`ONE_SHIP_M` of the other's path (interpolated between its rows) and their
    velocities differ by less than :data:`ONE_SHIP_SPEED` (median): a hull-mounted and a
    towed array, or two receivers on one aircraft; or when both are so with a third.

    Parameters
    ----------
    meas : MeasurementSet
    sensor : str, optional

    Returns
    -------
    list of str
        ``sensor`` first, then the others on its own ship in the set's order.
    """
    names = list(meas.sensors)
    if sensor is None and len(names) == 1:
        sensor = names[0]
    elif sensor is None:
        counts = np.bincount(meas.sensor_code, minlength=len(meas.sensor_names))
        sensor = max(names, key=lambda n: int(counts[meas.sensor_names.index(n)]))
    if sensor not in names:
        raise ValueError(f"no sensor {sensor!r} in the set (sensors: {', '.join(names)})")
    ship, added = [sensor], [sensor]
    while added:  # through a third sensor where two records do not overlap
        added = [n for n in names if n not in ship and any(_moves_with(meas, a, n) for a in added)]
        ship += added
    return [sensor] + [n for n in names if n in ship[1:]]


def _moves_with(meas: MeasurementSet, a: str, b: str) -> bool:
    """Tell whether sensors ``a`` and ``b`` move as one, where their records overlap."""
    rows = [np.flatnonzero(meas.sensor_mask(n)) for n in (a, b)]
    rows = [r[np.argsort(meas.time[r], kind="stable")] for r in rows]
    gaps: list[NDArray[np.float64]] = []
    dv: list[NDArray[np.float64]] = []
    for ref, other in (rows, rows[::-1]):
        t_ref, t = meas.time[ref], meas.time[other]
        inside = other[(t >= t_ref[0]) & (t <= t_ref[-1])]
        if t_ref.size < 2 or not inside.size:
            continue
        at = meas.time[inside]
        for col, out in ((slice(0, 2), gaps), (slice(3, 5), dv)):
            path = np.column_stack([np.interp(at, t_ref, meas.sensor_state[ref, k])
                                    for k in range(col.start, col.stop)])
            out.append(np.hypot(*(path - meas.sensor_state[inside, col]).T))
    if not gaps:
        return False
    return bool(np.max(np.concatenate(gaps)) <= ONE_SHIP_M
                and np.median(np.concatenate(dv)) < ONE_SHIP_SPEED)


def contact_legs(result: Any, meas: MeasurementSet) -> list[dict[str, float | None]] | None:
    """Return a manoeuvre fit's segments as the contact's legs: times, course and speed."""
    motion = result.motion
    if getattr(motion, "manoeuvres", None) is None or not len(meas) or \
            not np.all(np.isfinite(result.estimate)):
        return None
    theta = np.asarray(result.estimate, dtype=float)
    lo, hi = float(meas.time.min()), float(meas.time.max())
    cuts = sorted(min(max(float(theta[motion.time_index(m)]), lo), hi)
                  for m in range(1, motion.manoeuvres + 1))
    ends = [lo, *cuts, hi]
    out: list[dict[str, float | None]] = []
    for a, b in itertools.pairwise(ends):
        if b <= a:
            continue
        states = motion.states(theta, np.array([a, b]))
        course = np.degrees(np.arctan2(states[:, 3], states[:, 4])) % 360.0
        turn = float((course[1] - course[0] + 180.0) % 360.0 - 180.0)
        out.append({"start": a, "stop": b, "course_start_deg": float(course[0]),
                    "course_deg": float(course[1]), "turn_deg": turn,
                    "speed": float(np.hypot(states[1, 3], states[1, 4]))})
    return out
