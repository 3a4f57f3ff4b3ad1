"""A sensor's legs and its interpolated position: the same answers as the plain row-by-row rules.

Both read only what they need of a large set (no per-row Python loop, no copy of the rows);
these tests hold them to the plain definitions on paths of every shape.
"""

import numpy as np
import pytest

from tmakit.data import MeasurementSet
from tmakit.results.context import sensor_position
from tmakit.results.own_legs import (
    HOLDS_COURSE_SPEED,
    LEG_SPEED_CHANGE,
    LEG_TURN_DEG,
    detect_legs,
    one_leg,
    straight_legs,
)


def plain_legs(time, state):
    """The legs by the rule read row by row (a new leg where course or speed changes)."""
    v = state[:, 3:5]
    speed = np.hypot(v[:, 0], v[:, 1])
    course = np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360.0
    legs, first = [], 0
    for k in range(1, len(time) + 1):
        if k < len(time):
            turn = abs((course[k] - course[first] + 180.0) % 360.0 - 180.0)
            moving = min(speed[k], speed[first]) >= HOLDS_COURSE_SPEED
            change = abs(speed[k] - speed[first]) > max(0.5, LEG_SPEED_CHANGE * speed[first])
            if not ((moving and turn > LEG_TURN_DEG) or change):
                continue
        legs.append((time[first], time[k - 1], course[first], np.mean(speed[first:k])))
        first = k
    return legs


def path(kind, n, rng):
    """Velocities of a path: noise, a few long legs, a slow drift, or nearly stationary."""
    if kind == "noise":  # nearly every row a new leg
        return rng.normal(0.0, 5.0, (n, 2))
    if kind == "legs":
        legs = rng.normal(0.0, 5.0, (int(rng.integers(1, 6)), 2))
        return legs[np.sort(rng.integers(0, len(legs), n))]
    if kind == "drift":  # the course drifts: legs end by the turn from their first row
        course = np.radians(np.cumsum(rng.normal(0.0, 1.0, n)))
        speed = 5.0 + np.cumsum(rng.normal(0.0, 0.05, n))
        return np.column_stack([speed * np.sin(course), speed * np.cos(course)])
    return rng.normal(0.0, 0.15, (n, 2))  # GPS noise about a still sensor: no turn counts


@pytest.mark.parametrize("kind", ["noise", "legs", "drift", "still"])
def test_legs_are_the_plain_rule_read_row_by_row(kind):
    rng = np.random.default_rng(["noise", "legs", "drift", "still"].index(kind))
    for n in (1, 2, 63, 64, 65, 700):
        state = np.zeros((n, 6))
        state[:, 3:5] = path(kind, n, rng)
        time = np.sort(rng.uniform(0.0, 1000.0, n))
        got = [(g.start, g.stop, g.course_deg, g.speed) for g in straight_legs(time, state)]
        assert got == plain_legs(time, state)
        assert one_leg(state) == (len(got) == 1)


def test_a_still_receivers_navigation_noise_is_no_own_ship_turn():
    """A receiver at rest, its GPS fixes and velocities with noise, has one stationary leg."""
    rng = np.random.default_rng(7)
    time = np.arange(600.0)
    state = np.zeros((600, 6))
    state[:, :2] = rng.normal(0.0, 2.0, (600, 2))
    state[:, 3:5] = rng.normal(0.0, 0.15, (600, 2))
    found = detect_legs(time, state)
    assert len(found.legs) == 1 and found.turns == []
    assert found.legs[0].words() == "t = 0 .. 599 s, stationary"
    assert [leg.words() for leg in straight_legs(time, state)] == ["t = 0 .. 599 s, stationary"]
    state[300:, 3] += 4.0  # then it moves off east at 4 m/s, turning north at 450 s
    state[450:, 3:5] = state[450:, 4:2:-1]
    found = detect_legs(time, state)
    assert len(found.turns) == 1 and abs(abs(found.turns[0].change_deg) - 90.0) < 10.0


def test_one_leg_decided_by_the_first_rows_of_a_manoeuvring_path():
    state = np.zeros((2_000_000, 6))
    state[:, 3] = 5.0
    state[10:, 4] = 5.0  # a turn of 45 degrees at row 10
    assert not one_leg(state)
    state[10:, 4] = 0.0
    assert one_leg(state)


def two_sensors(rng, n=200):
    """Two sensors taking turns at random, each time given twice (bearing and elevation)."""
    time = np.repeat(np.sort(rng.permutation(np.arange(1000))[:n]) / 10.0, 2)
    sensor = np.repeat(np.where(rng.random(n) < 0.5, "a", "b"), 2)
    kind = np.tile(["bearing", "elevation"], n)
    state = rng.normal(0.0, 100.0, (2 * n, 6))
    return MeasurementSet.from_si(time, sensor, kind, np.zeros(2 * n), np.full(2 * n, 0.01),
                                  state)


def plain_position(meas, sensor, t):
    """Interpolation over the sensor's rows sorted by time (stable), the velocity outside."""
    sel = meas.sensor == sensor
    times, states = meas.time[sel], meas.sensor_state[sel]
    order = np.argsort(times, kind="stable")
    times, states = times[order], states[order]
    if t <= times[0] or t >= times[-1]:
        k = 0 if t <= times[0] else times.size - 1
        return states[k, :3] + states[k, 3:6] * (t - times[k])
    return np.array([np.interp(t, times, states[:, i]) for i in range(3)])


def test_sensor_position_is_the_interpolation_of_its_sorted_rows():
    rng = np.random.default_rng(4)
    meas = two_sensors(rng)
    for sensor in ("a", "b"):
        own = np.unique(meas.time[meas.sensor == sensor])
        times = [-5.0, own[0], own[3], 0.5 * (own[3] + own[4]), 50.03, own[-1], 130.0]
        for t in times:
            np.testing.assert_array_equal(sensor_position(meas, sensor, t),
                                          plain_position(meas, sensor, t))
    one = meas.select(sensor="a")
    for t in (-1.0, 33.3, 200.0):
        np.testing.assert_array_equal(sensor_position(one, "a", t),
                                      plain_position(meas, "a", t))


def test_sensor_position_of_a_sensor_not_in_the_set_is_refused():
    meas = two_sensors(np.random.default_rng(5))
    with pytest.raises(ValueError, match="no measurement of sensor 'c'"):
        sensor_position(meas, "c", 10.0)
