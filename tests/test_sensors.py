"""Sensor tracks and the WGS-84 <-> ENU conversion: what a user relies on.

Conventions (tmakit.core.frames): ENU metres, headings clockwise from North, a positive turn rate
turns clockwise.  ``states(t)`` is ``(n, 6)``: ENU position then velocity.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tmakit.core.frames import wrap_angle
from tmakit.core.geodesy import enu_to_geodetic, geodetic_to_enu
from tmakit.sensors import FixedSensor, Leg, LegsTrack, RecordedTrack, WaypointTrack

FD_STEP = 1e-3  # s, central finite-difference step for velocities


def course(states: np.ndarray) -> np.ndarray:
    """Course (rad, clockwise from North) of the velocities in ``states``."""
    return np.arctan2(states[:, 3], states[:, 4])


def speed(states: np.ndarray) -> np.ndarray:
    return np.hypot(states[:, 3], states[:, 4])


def central_difference(track, t: np.ndarray, h: float = FD_STEP) -> np.ndarray:
    return (track.states(t + h)[:, :3] - track.states(t - h)[:, :3]) / (2.0 * h)


# --------------------------------------------------------------------------- FixedSensor


def test_fixed_sensor_2d_gets_zero_altitude_and_zero_velocity():
    s = FixedSensor((100.0, -250.0))
    out = s.states([0.0, 10.0, 1e4])
    assert out.shape == (3, 6)
    np.testing.assert_array_equal(out[:, :3], [[100.0, -250.0, 0.0]] * 3)
    np.testing.assert_array_equal(out[:, 3:], 0.0)


def test_fixed_sensor_3d_and_scalar_time():
    s = FixedSensor([1.0, 2.0, 3.0])
    out = s.states(5.0)
    assert out.shape == (1, 6)
    np.testing.assert_array_equal(out[0], [1.0, 2.0, 3.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(s.states([0.0, 1.0])[:, :3], [[1.0, 2.0, 3.0]] * 2)


@pytest.mark.parametrize("position", [
    (np.nan, 0.0), (0.0, np.inf, 0.0), (1.0,), (1.0, 2.0, 3.0, 4.0), (),
])
def test_fixed_sensor_bad_position_raises(position):
    with pytest.raises(ValueError, match="sensor position"):
        FixedSensor(position)


# --------------------------------------------------------------------------- LegsTrack


def test_legs_speed_constant_on_every_leg_and_new_speed_applied():
    track = LegsTrack((0.0, 0.0), 0.3, 120.0, [
        Leg(30.0, 0.02),
        Leg(20.0, 0.0, speed=80.0),
        Leg(25.0, -0.03),
        Leg(math.inf, 0.01, speed=200.0),
    ], start_time=5.0)
    np.testing.assert_allclose(track.leg_start_times, [5.0, 35.0, 55.0, 80.0])
    pieces = [(5.0, 35.0, 120.0), (35.0, 55.0, 80.0), (55.0, 80.0, 80.0), (80.0, 300.0, 200.0)]
    for lo, hi, v in pieces:
        t = np.linspace(lo, hi, 50, endpoint=False)
        np.testing.assert_allclose(speed(track.states(t)), v, rtol=1e-12)


@pytest.mark.parametrize(("heading", "direction"), [
    (0.0, (0.0, 1.0)),
    (math.pi / 2, (1.0, 0.0)),
    (math.pi, (0.0, -1.0)),
    (-math.pi / 2, (-1.0, 0.0)),
])
def test_legs_heading_convention(heading, direction):
    track = LegsTrack((10.0, 20.0), heading, 50.0, [Leg(math.inf)])
    out = track.states([0.0, 10.0])
    np.testing.assert_allclose(out[1, :2], np.array([10.0, 20.0]) + 500.0 * np.array(direction),
                               atol=1e-9)
    np.testing.assert_allclose(out[:, 3:5], [np.array(direction) * 50.0] * 2, atol=1e-12)


def test_legs_positive_turn_rate_turns_clockwise():
    track = LegsTrack((0.0, 0.0), 0.0, 100.0, [Leg(math.inf, 0.05)])
    t = np.linspace(0.0, 20.0, 21)
    out = track.states(t)
    c = course(out)
    assert np.all(np.diff(c) > 0)  # heading North, turning towards East
    np.testing.assert_allclose(c, 0.05 * t, atol=1e-12)
    assert np.all(out[1:, 0] > 0)  # to starboard of a northbound start: East


def test_legs_negative_turn_rate_turns_counter_clockwise():
    track = LegsTrack((0.0, 0.0), 0.0, 100.0, [Leg(math.inf, -0.05)])
    t = np.linspace(0.0, 20.0, 21)
    out = track.states(t)
    c = course(out)
    assert np.all(np.diff(c) < 0)
    np.testing.assert_allclose(c, -0.05 * t, atol=1e-12)
    assert np.all(out[1:, 0] < 0)  # to port: West


def test_legs_positions_continuous_across_leg_boundaries():
    track = LegsTrack((500.0, -300.0), 1.0, 150.0, [
        Leg(40.0, 0.03),
        Leg(15.0, -0.04, speed=60.0),
        Leg(30.0, 0.0, speed=250.0),
        Leg(math.inf, 0.02),
    ], start_time=-10.0)
    eps = 1e-6
    for tb in track.leg_start_times[1:]:
        before, after = track.states([tb - eps, tb + eps])[:, :3]
        # At most 250 m/s * 2e-6 s apart, plus rounding.
        assert np.linalg.norm(after - before) < 250.0 * 2 * eps + 1e-6


legs_strategy = st.lists(
    st.tuples(
        st.floats(5.0, 200.0),
        st.floats(-0.05, 0.05),
        st.one_of(st.none(), st.floats(10.0, 300.0)),
    ),
    min_size=1, max_size=5,
)


@settings(deadline=None, max_examples=60)
@given(
    legs=legs_strategy,
    v0=st.floats(10.0, 300.0),
    heading=st.floats(-math.pi, math.pi),
    start_time=st.floats(-100.0, 100.0),
    fractions=st.lists(st.floats(0.01, 0.99), min_size=1, max_size=4),
)
def test_legs_velocity_is_derivative_of_position(legs, v0, heading, start_time, fractions):
    track = LegsTrack((1000.0, -2000.0, 50.0), heading, v0,
                      [Leg(d, w, v) for d, w, v in legs], start_time=start_time)
    starts = track.leg_start_times
    speeds = []
    v = v0
    for _, _, leg_speed in legs:
        v = leg_speed if leg_speed is not None else v
        speeds.append(v)
    for i, (d, _, _) in enumerate(legs):
        t = starts[i] + d * np.asarray(fractions)
        out = track.states(t)
        fd = central_difference(track, t)
        np.testing.assert_allclose(out[:, 3:], fd, atol=1e-4 * max(speeds) / 10.0, rtol=0)
        np.testing.assert_allclose(speed(out), speeds[i], rtol=1e-12)
    # beyond the last leg and before the first: still consistent
    t_out = np.array([starts[0] - 50.0, starts[-1] + legs[-1][0] + 50.0])
    np.testing.assert_allclose(track.states(t_out)[:, 3:], central_difference(track, t_out),
                               atol=1e-4 * max(speeds) / 10.0, rtol=0)


@pytest.mark.parametrize("rate", [0.03, -0.03, 0.1])
def test_legs_full_circle_returns_to_start(rate):
    v = 120.0
    start = np.array([300.0, 400.0])
    track = LegsTrack(start, 0.0, v, [Leg(math.inf, rate)])
    period = 2 * math.pi / abs(rate)
    radius = v / abs(rate)
    t = np.linspace(0.0, period, 73)
    out = track.states(t)
    np.testing.assert_allclose(out[-1, :2], start, atol=1e-6)
    np.testing.assert_allclose(out[-1, 3:5], [0.0, v], atol=1e-9)
    # heading North: the centre is to starboard (East) for a clockwise turn, West otherwise
    centre = start + np.array([math.copysign(radius, rate), 0.0])
    np.testing.assert_allclose(np.linalg.norm(out[:, :2] - centre, axis=1), radius, rtol=1e-10)
    half = track.states(period / 2)[0, :2]
    np.testing.assert_allclose(half, start + 2 * (centre - start), atol=1e-6)


def test_legs_continue_on_last_leg_after_it_ends():
    straight = LegsTrack((0.0, 0.0), 0.0, 50.0, [Leg(10.0, 0.0)])
    out = straight.states([10.0, 30.0])
    np.testing.assert_allclose(out[:, :2], [[0.0, 500.0], [0.0, 1500.0]], atol=1e-9)
    np.testing.assert_allclose(out[:, 3:5], [[0.0, 50.0]] * 2, atol=1e-12)

    finite = LegsTrack((0.0, 0.0), 0.0, 50.0, [Leg(20.0, 0.0), Leg(10.0, 0.02)])
    endless = LegsTrack((0.0, 0.0), 0.0, 50.0, [Leg(20.0, 0.0), Leg(math.inf, 0.02)])
    t = np.array([30.0, 60.0, 200.0])
    np.testing.assert_allclose(finite.states(t), endless.states(t), atol=1e-9)


def test_legs_before_start_time_extend_first_leg_backwards():
    straight = LegsTrack((100.0, 0.0), math.pi / 2, 40.0, [Leg(50.0)], start_time=100.0)
    out = straight.states(90.0)[0]
    np.testing.assert_allclose(out[:5], [100.0 - 400.0, 0.0, 0.0, 40.0, 0.0], atol=1e-9)

    rate = 0.02
    early = LegsTrack((0.0, 0.0), 0.3, 80.0, [Leg(math.inf, rate)], start_time=0.0)
    s20 = early.states(20.0)[0]
    late = LegsTrack(s20[:3], course(s20[None])[0], 80.0, [Leg(30.0, rate), Leg(math.inf)],
                     start_time=20.0)
    t = np.array([-40.0, 0.0, 5.0, 19.9])
    np.testing.assert_allclose(late.states(t), early.states(t), atol=1e-8)


def test_legs_altitude_constant():
    track = LegsTrack((0.0, 0.0, 3000.0), 1.0, 200.0,
                      [Leg(30.0, 0.05), Leg(20.0, speed=100.0), Leg(math.inf, -0.02)],
                      start_time=0.0)
    out = track.states(np.linspace(-50.0, 200.0, 101))
    np.testing.assert_array_equal(out[:, 2], 3000.0)
    np.testing.assert_array_equal(out[:, 5], 0.0)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"legs": []}, "at least one leg"),
    ({"legs": [Leg(0.0)]}, "duration"),
    ({"legs": [Leg(-5.0)]}, "duration"),
    ({"legs": [Leg(math.nan)]}, "duration"),
    ({"legs": [Leg(math.inf), Leg(10.0)]}, "last leg"),
    ({"speed": 0.0}, "speed"),
    ({"speed": -10.0}, "speed"),
    ({"speed": math.nan}, "speed"),
    ({"speed": math.inf}, "speed"),
    ({"legs": [Leg(10.0, speed=0.0)]}, "speed"),
    ({"legs": [Leg(10.0, speed=-3.0)]}, "speed"),
    ({"legs": [Leg(10.0, speed=math.nan)]}, "speed"),
    ({"legs": [Leg(10.0, turn_rate=math.nan)]}, "turn rate"),
    ({"heading": math.nan}, "heading"),
    ({"legs": [Leg(10.0, turn_rate=math.inf)]}, "turn rate"),
    ({"start_time": math.nan}, "start time"),
    ({"start": (0.0, math.nan)}, "track start"),
])
def test_legs_invalid_raise(kwargs, match):
    args = {"start": (0.0, 0.0), "heading": 0.0, "speed": 50.0, "legs": [Leg(10.0)]}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        LegsTrack(**args)


def test_paper_000_sensor_path_distances():
    """The sensor path of Gu et al. (2007) against its straight-line target."""
    heading = float(wrap_angle(math.pi / 2 - math.radians(-1.21008)))  # from East, ccw
    assert math.degrees(heading) == pytest.approx(90.0 + 1.21008, abs=1e-12)
    track = LegsTrack((801.385, 5002.294), heading, 50.0, [
        Leg(44.2152, math.radians(0.508926)),
        Leg(94.4088 - 44.2152, math.radians(1.040814)),
        Leg(math.inf, math.radians(2.366679)),
    ])
    t = np.arange(0.0, 121.0)
    sensor = track.states(t)[:, :3]
    target = np.column_stack([3200.0 - 21.65 * t, 3200.0 - 12.5 * t])
    d = np.linalg.norm(target - sensor[:, :2], axis=1)
    assert abs(d.mean() - 2718) < 1
    assert abs(d.max() - 3634) < 1
    assert abs(d.min() - 1935) < 1
    assert round(d.mean()) == 2718 and round(d.max()) == 3634 and round(d.min()) == 1935


# --------------------------------------------------------------------------- WaypointTrack


WAYPOINTS = np.array([[0.0, 0.0], [300.0, 400.0], [300.0, 1400.0], [-500.0, 800.0]])


def test_waypoints_with_speed():
    v = 25.0
    track = WaypointTrack(WAYPOINTS, speed=v, start_time=10.0)
    expected_times = 10.0 + np.array([0.0, 500.0, 1500.0, 2500.0]) / v
    np.testing.assert_allclose(track.times, expected_times)
    at = track.states(expected_times)
    np.testing.assert_allclose(at[:, :2], WAYPOINTS, atol=1e-9)
    np.testing.assert_array_equal(at[:, 2], 0.0)
    # constant speed in between, directed at the next waypoint
    for i in range(3):
        t = np.linspace(expected_times[i], expected_times[i + 1], 20, endpoint=False)[1:]
        out = track.states(t)
        np.testing.assert_allclose(speed(out), v, rtol=1e-12)
        direction = (WAYPOINTS[i + 1] - WAYPOINTS[i]) / np.linalg.norm(
            WAYPOINTS[i + 1] - WAYPOINTS[i])
        np.testing.assert_allclose(out[:, 3:5], np.tile(v * direction, (len(t), 1)), atol=1e-12)
        np.testing.assert_allclose(out[:, 3:], central_difference(track, t), atol=1e-6)
    # holds position before the first and after the last waypoint
    before = track.states([-100.0, 0.0, 9.999])
    np.testing.assert_allclose(before[:, :2], [WAYPOINTS[0]] * 3)
    np.testing.assert_array_equal(before[:, 3:], 0.0)
    after = track.states([expected_times[-1], expected_times[-1] + 1.0, 1e6])
    np.testing.assert_allclose(after[:, :2], [WAYPOINTS[-1]] * 3, atol=1e-9)
    np.testing.assert_array_equal(after[:, 3:], 0.0)


def test_waypoints_with_times_3d():
    pts = np.array([[0.0, 0.0, 100.0], [100.0, 0.0, 200.0], [100.0, 50.0, 200.0]])
    track = WaypointTrack(pts, times=[0.0, 10.0, 60.0])
    out = track.states([0.0, 5.0, 10.0, 35.0, 60.0])
    np.testing.assert_allclose(out[:, :3], [[0.0, 0.0, 100.0], [50.0, 0.0, 150.0],
                                            [100.0, 0.0, 200.0], [100.0, 25.0, 200.0],
                                            [100.0, 50.0, 200.0]], atol=1e-12)
    np.testing.assert_allclose(out[:, 3:], [[10.0, 0.0, 10.0], [10.0, 0.0, 10.0],
                                            [0.0, 1.0, 0.0], [0.0, 1.0, 0.0],
                                            [0.0, 0.0, 0.0]], atol=1e-12)


@pytest.mark.parametrize("kwargs", [
    {"waypoints": WAYPOINTS, "times": [0.0, 10.0, 5.0, 20.0]},
    {"waypoints": WAYPOINTS, "times": [0.0, 10.0, 10.0, 20.0]},
    {"waypoints": WAYPOINTS, "times": [0.0, 10.0, 20.0]},
    {"waypoints": WAYPOINTS[:1], "speed": 10.0},
    {"waypoints": WAYPOINTS[:1], "times": [0.0]},
    {"waypoints": WAYPOINTS, "speed": 10.0, "times": [0.0, 1.0, 2.0, 3.0]},
    {"waypoints": WAYPOINTS},
    {"waypoints": WAYPOINTS, "speed": 0.0},
    {"waypoints": WAYPOINTS, "speed": -5.0},
    {"waypoints": WAYPOINTS, "speed": math.nan},
    {"waypoints": [1.0, 2.0, 3.0], "speed": 10.0},
])
def test_waypoints_bad_input_raises(kwargs):
    with pytest.raises(ValueError):
        WaypointTrack(**kwargs)


# --------------------------------------------------------------------------- RecordedTrack


def _circle():
    """A circular track: 2 km radius flown at 60 m/s clockwise, altitude 500 m."""
    v, radius = 60.0, 2000.0
    return LegsTrack((0.0, 0.0, 500.0), 0.7, v, [Leg(math.inf, v / radius)])


def test_recorded_with_velocities_reproduces_circle():
    truth = _circle()
    t_rec = np.arange(0.0, 301.0, 10.0)
    rec = truth.states(t_rec)
    track = RecordedTrack(t_rec, rec[:, :3], rec[:, 3:])
    t = np.linspace(0.0, 300.0, 601)
    out, expected = track.states(t), truth.states(t)
    assert np.max(np.linalg.norm(out[:, :3] - expected[:, :3], axis=1)) < 1.0
    assert np.max(np.linalg.norm(out[:, 3:] - expected[:, 3:], axis=1)) < 0.1
    # the record itself is matched exactly
    np.testing.assert_allclose(track.states(t_rec), rec, atol=1e-9)


def test_recorded_with_2d_velocities():
    truth = _circle()
    t_rec = np.arange(0.0, 101.0, 10.0)
    rec = truth.states(t_rec)
    track = RecordedTrack(t_rec, rec[:, :2], rec[:, 3:5])
    out = track.states(45.0)[0]
    np.testing.assert_array_equal(out[[2, 5]], 0.0)
    np.testing.assert_allclose(out[:2], truth.states(45.0)[0, :2], atol=1.0)


@pytest.mark.parametrize("n", [2, 3, 12])
def test_recorded_without_velocities_straight_track_exact(n):
    p0, v = np.array([1500.0, -800.0, 120.0]), np.array([-35.0, 47.5, 0.5])
    t_rec = np.sort(np.concatenate([[0.0, 200.0], np.linspace(3.0, 190.0, n - 2) ** 1.01]))
    track = RecordedTrack(t_rec, p0 + np.outer(t_rec, v))
    t = np.linspace(0.0, 200.0, 97)
    out = track.states(t)
    np.testing.assert_allclose(out[:, :3], p0 + np.outer(t, v), atol=1e-9, rtol=0)
    np.testing.assert_allclose(out[:, 3:], np.tile(v, (len(t), 1)), atol=1e-9, rtol=0)


def test_recorded_outside_span_raises_with_span():
    t_rec = np.array([100.0, 110.0, 120.0, 130.0])
    track = RecordedTrack(t_rec, np.column_stack([t_rec, 2 * t_rec]))
    for bad in (99.0, 130.5, [110.0, 1000.0]):
        with pytest.raises(ValueError, match=r"\[100, 130\]"):
            track.states(bad)
    # the end points themselves are inside
    np.testing.assert_allclose(track.states([100.0, 130.0])[:, :2],
                               [[100.0, 200.0], [130.0, 260.0]], atol=1e-9)


@pytest.mark.parametrize("kwargs", [
    {"times": [0.0, 1.0, 1.0], "positions": np.zeros((3, 2))},
    {"times": [0.0], "positions": np.zeros((1, 2))},
    {"times": [0.0, 1.0], "positions": np.zeros((3, 2))},
    {"times": [0.0, 1.0], "positions": [[0.0, np.nan], [1.0, 1.0]]},
    {"times": [0.0, 1.0], "positions": np.zeros((2, 3)), "velocities": np.zeros((2, 4))},
])
def test_recorded_bad_input_raises(kwargs):
    with pytest.raises(ValueError):
        RecordedTrack(**kwargs)


def test_recorded_from_geodetic_matches_geodetic_to_enu():
    origin = (48.1, 11.5, 520.0)
    t = np.arange(0.0, 61.0, 5.0)
    lat = 48.1 + 1e-4 * t
    lon = 11.5 - 2e-4 * t
    alt = 600.0 + 2.0 * t
    track = RecordedTrack.from_geodetic(t, lat, lon, alt, origin)
    e, n, u = geodetic_to_enu(lat, lon, alt, origin)
    np.testing.assert_allclose(track.states(t)[:, :3], np.column_stack([e, n, u]), atol=1e-6)
    # North and West of the origin, above it
    p = track.states(30.0)[0, :3]
    assert p[0] < 0 < p[1] and p[2] > 0
    with pytest.raises(ValueError):
        RecordedTrack.from_geodetic(t, lat, lon, alt, (95.0, 0.0, 0.0))


# --------------------------------------------------------------------------- geodesy


def test_geodesy_origin_maps_to_zero():
    origin = (-33.9, 151.2, 40.0)
    e, n, u = geodetic_to_enu(*origin, origin)
    np.testing.assert_allclose([e, n, u], 0.0, atol=1e-6)
    lat, lon, alt = enu_to_geodetic(0.0, 0.0, 0.0, origin)
    np.testing.assert_allclose([lat, lon, alt], origin, atol=1e-9)


def test_geodesy_north_offset_at_equator_matches_meridian_arc():
    # WGS-84 meridian radius of curvature at the equator: a (1 - e^2).
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    metres_per_degree = a * (1 - e2) * math.pi / 180.0
    assert metres_per_degree == pytest.approx(110574.0, abs=1.0)
    e, n, u = geodetic_to_enu(0.01, 0.0, 0.0, (0.0, 0.0, 0.0))
    assert abs(float(n) - 0.01 * metres_per_degree) < 1.0
    assert abs(float(n) - 1105.7) < 1.0
    assert abs(float(e)) < 1e-6
    assert -0.2 < float(u) < 0.0  # the Earth curves away below the tangent plane


@settings(deadline=None, max_examples=100)
@given(
    lat0=st.floats(-80.0, 80.0),
    lon0=st.floats(-180.0, 180.0),
    alt0=st.floats(-100.0, 5000.0),
    offset=st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
    distance=st.floats(0.0, 50e3),
)
def test_geodesy_round_trip(lat0, lon0, alt0, offset, distance):
    origin = (lat0, lon0, alt0)
    direction = np.array(offset)
    norm = np.linalg.norm(direction)
    direction = direction / norm if norm > 0 else np.zeros(3)
    east, north, up = distance * direction
    up = up / 20.0  # a sensor is within a few km of the origin's altitude
    lat, lon, alt = enu_to_geodetic(east, north, up, origin)
    e, n, u = geodetic_to_enu(lat, lon, alt, origin)
    np.testing.assert_allclose([e, n, u], [east, north, up], atol=1e-6)
    lat2, lon2, alt2 = enu_to_geodetic(e, n, u, origin)
    assert abs(float(lat2) - float(lat)) < 1e-9
    assert abs((float(lon2) - float(lon) + 180.0) % 360.0 - 180.0) < 1e-9
    assert abs(float(alt2) - float(alt)) < 1e-6


def test_geodesy_vectorised():
    origin = (10.0, 20.0, 0.0)
    lat = np.array([10.0, 10.01, 9.99])
    lon = np.array([20.0, 20.0, 20.02])
    e, n, u = geodetic_to_enu(lat, lon, np.zeros(3), origin)
    assert e.shape == n.shape == u.shape == (3,)
    lat2, lon2, _ = enu_to_geodetic(e, n, u, origin)
    np.testing.assert_allclose(lat2, lat, atol=1e-9)
    np.testing.assert_allclose(lon2, lon, atol=1e-9)


@pytest.mark.parametrize("origin", [
    (95.0, 0.0, 0.0), (-90.5, 0.0, 0.0), (0.0, 400.0, 0.0), (0.0, 0.0, math.nan),
    (math.nan, 0.0, 0.0), (1.0, 2.0), "origin", None,
])
def test_geodesy_bad_origin_raises(origin):
    with pytest.raises(ValueError):
        geodetic_to_enu(0.0, 0.0, 0.0, origin)
    with pytest.raises(ValueError):
        enu_to_geodetic(0.0, 0.0, 0.0, origin)


def test_recorded_and_waypoint_tracks_refuse_non_finite_or_misshapen_input():
    t = np.array([0.0, 10.0, 20.0])
    p = np.zeros((3, 2))
    with pytest.raises(ValueError, match="velocities"):
        RecordedTrack(t, p, np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        RecordedTrack(t, p, np.array([[0.0, 0.0], [np.nan, 0.0], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="finite"):
        WaypointTrack([[0.0, 0.0], [np.nan, 1.0]], speed=1.0)
    with pytest.raises(ValueError, match="finite"):
        WaypointTrack([[0.0, 0.0], [1.0, 1.0]], speed=1.0, start_time=np.nan)
