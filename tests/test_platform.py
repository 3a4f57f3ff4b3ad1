"""Steerable sensor platforms: exact constant-turn / constant-acceleration steps, limits,
vectorisation over candidates, and the flown path as a sensor track.

Conventions (tmakit.core.frames): ENU metres, headings clockwise from North (``atan2(vE, vN)``),
a positive turn rate turns clockwise.
"""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tmakit as tk
import tmakit.sensors.platform as platform_module
from tmakit.motion import ConstantVelocity, propagate_curvilinear
from tmakit.sensors import (
    HURTADO_NEHORAI_2008,
    Actions,
    PlatformKinematics,
    PlatformState,
    PlatformTrack,
    SensorTrack,
    platform_configuration,
)
from tmakit.sensors.platform import propagate_constant_turn

HN = HURTADO_NEHORAI_2008
DEG = math.pi / 180.0


def random_states(rng: np.random.Generator, n: int) -> PlatformState:
    return PlatformState(rng.uniform(-5e3, 5e3, (n, 3)), rng.uniform(-math.pi, math.pi, n),
                         rng.uniform(50.0, 200.0, n), rng.uniform(-5.0, 5.0, n), time=12.5)


def random_actions(rng: np.random.Generator, n: int) -> Actions:
    return Actions(rng.uniform(-20, 20, n) * DEG, rng.uniform(0.8, 1.2, n),
                   rng.uniform(-5.0, 5.0, n), rng.uniform(-10.0, 10.0, n))


# --------------------------------------------------------------------------- closed form


def test_module_docstring_example_runs():
    assert doctest.testmod(platform_module).failed == 0


def test_heading_is_clockwise_from_north():
    east = propagate_constant_turn([0.0, 0.0, 0.0], math.pi / 2, 100.0, 0.0, 0.0, 0.0, 2.0)
    np.testing.assert_allclose(east, [200.0, 0.0, 0.0, 100.0, 0.0, 0.0], atol=1e-12)
    s = PlatformState((0.0, 0.0), 0.0, 50.0)
    right = HN.kinematics.step(s, Actions(10 * DEG), HN.interval)
    assert right.end.position[0] > 0 and right.end.heading == pytest.approx(10 * DEG)


def test_full_circle_returns_to_start():
    start = PlatformState((1e3, -2e3, 500.0), 0.3, 120.0)
    # 36 steps of +10 degrees at constant speed: one full turn in 18 s.
    path = HN.kinematics.fly(start, Actions(np.full(36, 10 * DEG)), HN.interval)
    end = path.end
    np.testing.assert_allclose(end.position, start.position, atol=1e-9)
    np.testing.assert_allclose(end.velocity, start.velocity, atol=1e-10)
    assert end.heading == pytest.approx(float(start.heading), abs=1e-12)
    # the same circle in one call, and its radius v / w
    w = 2 * math.pi / 18.0
    one = propagate_constant_turn(start.position, 0.3, 120.0, 0.0, w, 0.0, 18.0)
    np.testing.assert_allclose(one[:3], start.position, atol=1e-9)
    half = propagate_constant_turn(start.position, 0.3, 120.0, 0.0, w, 0.0, 9.0)
    assert np.linalg.norm(half[:2] - start.position[:2]) == pytest.approx(2 * 120.0 / w)


def test_arc_at_constant_speed_matches_propagate_curvilinear():
    rng = np.random.default_rng(3)
    psi, v, w, dt = (rng.uniform(-3, 3, 50), rng.uniform(10, 200, 50),
                     rng.uniform(-0.5, 0.5, 50), rng.uniform(-30, 30, 50))
    ours = propagate_constant_turn(np.zeros(3), psi, v, 0.0, w, 0.0, dt)
    x, y, _, _, vx, vy = propagate_curvilinear(0.0, 0.0, v, psi, 0.0, w * v, dt)
    np.testing.assert_allclose(ours[:, [0, 1, 3, 4]], np.column_stack([x, y, vx, vy]),
                               atol=1e-9, rtol=1e-12)


def test_accelerating_turn_matches_an_ode_solution():
    psi, v, w, a, dt = 0.7, 80.0, -0.2, 3.0, 25.0

    def rhs(t, _):
        return [(v + a * t) * math.sin(psi + w * t), (v + a * t) * math.cos(psi + w * t)]

    sol = solve_ivp(rhs, (0.0, dt), [10.0, 20.0], rtol=1e-12, atol=1e-10)
    out = propagate_constant_turn([10.0, 20.0, 0.0], psi, v, 0.0, w, a, dt)
    np.testing.assert_allclose(out[:2], sol.y[:, -1], atol=1e-6)
    np.testing.assert_allclose(out[3:5], (v + a * dt) * np.array(
        [math.sin(psi + w * dt), math.cos(psi + w * dt)]), rtol=1e-13)


def test_series_and_closed_form_agree_at_the_switch():
    w = np.array([0.5 - 1e-9, 0.5 + 1e-9])  # |w s| either side of the series threshold
    out = propagate_constant_turn(np.zeros(3), 0.2, 100.0, 0.0, w, 2.0, 1.0)
    np.testing.assert_allclose(out[0], out[1], rtol=1e-8, atol=1e-7)
    straight = propagate_constant_turn(np.zeros(3), 0.0, 100.0, 0.0, 0.0, 2.0, 3.0)
    np.testing.assert_allclose(straight, [0.0, 309.0, 0.0, 0.0, 106.0, 0.0], atol=1e-12)


def test_velocity_is_the_derivative_of_position():
    h = 1e-4
    s = np.linspace(0.05, 9.95, 40)
    args = ([5.0, -3.0, 100.0], 1.1, 90.0, 2.5, 0.15, -1.5)
    fd = (propagate_constant_turn(*args, s + h)[:, :3]
          - propagate_constant_turn(*args, s - h)[:, :3]) / (2 * h)
    np.testing.assert_allclose(fd, propagate_constant_turn(*args, s)[:, 3:], atol=1e-6)
    # and along a flown path, inside each of its steps (the acceleration jumps between them)
    path = HN.kinematics.fly(PlatformState((0.0, 0.0), 0.0, 60.0), HN.actions[[14, 0, 12, 9]],
                             HN.interval)
    t = np.concatenate([k * 0.5 + np.linspace(0.01, 0.49, 8) for k in range(4)])
    fd = (path.states(t + h)[:, :3] - path.states(t - h)[:, :3]) / (2 * h)
    np.testing.assert_allclose(fd, path.states(t)[:, 3:], atol=1e-6)


# --------------------------------------------------------------------------- 15 actions


def test_hurtado_nehorai_actions_speeds_and_headings():
    assert len(HN.actions) == 15 and HN.interval == 0.5
    assert platform_configuration("Hurtado_Nehorai_2008") is HN
    factors = np.repeat([0.9, 1.0, 1.1], 5)
    turns = np.tile([-10.0, -5.0, 0.0, 5.0, 10.0], 3) * DEG
    np.testing.assert_array_equal(HN.actions.speed_factor, factors)
    np.testing.assert_allclose(HN.actions.heading_change, turns, rtol=1e-15)
    start = PlatformState((0.0, 0.0), 0.25, 100.0)
    step = HN.kinematics.step(start, HN.actions, HN.interval)
    np.testing.assert_allclose(step.end.speed, 100.0 * factors, rtol=1e-15)
    np.testing.assert_allclose(step.end.heading, 0.25 + turns, rtol=1e-14)
    np.testing.assert_allclose(step.acceleration, (factors - 1.0) * 100.0 / 0.5)
    assert not step.clipped.any()


@pytest.mark.parametrize(("speed", "clipped", "limit"),
                         [(50.0, slice(0, 5), 50.0), (190.0, slice(10, 15), 200.0)])
def test_speed_range_is_clipped_and_reported(speed, clipped, limit):
    step = HN.kinematics.step(PlatformState((0.0, 0.0), 0.0, speed), HN.actions, HN.interval)
    expected = np.zeros(15, dtype=bool)
    expected[clipped] = True
    np.testing.assert_array_equal(step.speed_limited, expected)
    np.testing.assert_array_equal(step.clipped, expected)
    np.testing.assert_allclose(step.end.speed[clipped], limit)
    assert np.all((step.end.speed >= 50.0) & (step.end.speed <= 200.0))
    assert not (step.turn_limited.any() or step.acceleration_limited.any())


def test_turn_and_acceleration_limits():
    kin = PlatformKinematics(min_speed=50.0, max_speed=200.0, max_turn_rate=20 * DEG,
                             max_acceleration=10.0)
    step = kin.step(PlatformState((0.0, 0.0), 0.0, 100.0),
                    Actions([15 * DEG, -15 * DEG, 10 * DEG], [1.0, 1.1, 1.02]), 0.5)
    np.testing.assert_array_equal(step.turn_limited, [True, True, False])
    np.testing.assert_allclose(step.end.heading, [10 * DEG, -10 * DEG, 10 * DEG])
    np.testing.assert_array_equal(step.acceleration_limited, [False, True, False])
    np.testing.assert_allclose(step.end.speed, [100.0, 105.0, 102.0])
    strict = PlatformKinematics(max_turn_rate=20 * DEG, on_limit="raise")
    with pytest.raises(ValueError, match="turn-rate limit"):
        strict.step(PlatformState((0.0, 0.0), 0.0, 100.0), Actions([0.0, 15 * DEG]), 0.5)


def test_altitude_band_and_climb_rate_limit():
    kin = PlatformKinematics(max_climb_rate=10.0, min_altitude=100.0, max_altitude=1000.0)
    start = PlatformState([[0.0, 0.0, 998.0], [0.0, 0.0, 500.0], [0.0, 0.0, 102.0]],
                          0.0, 100.0)
    step = kin.step(start, Actions(0.0, climb_rate=[8.0, 30.0, -8.0]), 1.0)
    np.testing.assert_allclose(step.end.position[:, 2], [1000.0, 510.0, 100.0])
    np.testing.assert_array_equal(step.climb_limited, [True, True, True])
    level = kin.step(start, Actions(0.0), 1.0)   # climb rate kept (0): nothing clipped
    assert not level.clipped.any()
    np.testing.assert_allclose(level.end.position[:, 2], start.position[:, 2])


def test_invalid_limits_and_inputs_are_refused():
    with pytest.raises(ValueError, match="speed range"):
        PlatformKinematics(min_speed=200.0, max_speed=50.0)
    with pytest.raises(ValueError, match="altitude band"):
        PlatformKinematics(min_altitude=10.0, max_altitude=0.0)
    with pytest.raises(ValueError, match=">= 0 m/s"):
        PlatformState((0.0, 0.0), 0.0, -1.0)
    with pytest.raises(ValueError, match="positive"):
        HN.kinematics.step(PlatformState((0.0, 0.0), 0.0, 60.0), HN.actions, 0.0)
    with pytest.raises(ValueError, match="unknown platform configuration"):
        platform_configuration("nope")
    with pytest.raises(ValueError, match="1-D sequence"):
        HN.kinematics.fly(PlatformState((0.0, 0.0), 0.0, 60.0), HN.actions[3], HN.interval)
    with pytest.raises(TypeError):
        len(HN.actions[3])


def test_two_dimensional_positions_mean_altitude_zero():
    two = propagate_constant_turn([1.0, 2.0], 0.4, 80.0, 0.0, 0.1, 1.0, 3.0)
    three = propagate_constant_turn([1.0, 2.0, 0.0], 0.4, 80.0, 0.0, 0.1, 1.0, 3.0)
    np.testing.assert_array_equal(two, three)
    step = HN.kinematics.step(PlatformState((1.0, 2.0), 0.4, 80.0), HN.actions, HN.interval)
    assert np.all(step.end.position[:, 2] == 0.0) and np.all(step.end.velocity[:, 2] == 0.0)


def test_state_from_velocity_round_trip():
    s = PlatformState.from_velocity([[1.0, 2.0, 3.0]], [[30.0, -40.0, 2.0]], time=4.0)
    assert s.shape == (1,)
    assert float(s.speed[0]) == pytest.approx(50.0)
    assert float(s.heading[0]) == pytest.approx(math.atan2(30.0, -40.0))
    np.testing.assert_allclose(s.sensor_state, [[1.0, 2.0, 3.0, 30.0, -40.0, 2.0]])


# --------------------------------------------------------------------------- vectorised


def test_one_state_many_actions_equals_a_loop():
    start = PlatformState((100.0, 200.0, 50.0), 1.0, 120.0, 1.5, time=3.0)
    times = 3.0 + np.array([0.0, 0.1, 0.3, 0.5])
    step = HN.kinematics.step(start, HN.actions, HN.interval)
    states = step.sensor_states(times)
    assert states.shape == (15, 4, 6)
    for c in range(15):
        one = HN.kinematics.step(start, HN.actions[c], HN.interval)
        assert one.shape == ()
        # equal to rounding (numpy may take SIMD paths for arrays and not for scalars)
        np.testing.assert_allclose(one.sensor_states(times), states[c], rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(one.end.sensor_state, step.end.sensor_state[c], rtol=1e-14,
                                   atol=1e-12)
        assert bool(one.clipped) == bool(step.clipped[c])
    np.testing.assert_allclose(states[:, -1], step.end.sensor_state, atol=1e-9)
    np.testing.assert_array_equal(states[:, 0], np.broadcast_to(start.sensor_state, (15, 6)))


def test_many_states_with_their_actions_and_all_pairs_equal_a_loop():
    rng = np.random.default_rng(7)
    kin = PlatformKinematics(min_speed=50.0, max_speed=200.0, max_turn_rate=30 * DEG,
                             max_acceleration=20.0, max_climb_rate=8.0, min_altitude=-4e3)
    states, actions = random_states(rng, 8), random_actions(rng, 8)
    times = 12.5 + np.linspace(0.0, 2.0, 5)
    paired = kin.step(states, actions, 2.0)
    pairs = kin.step(states[:, None], actions, 2.0)        # every state x every action
    assert paired.shape == (8,) and pairs.shape == (8, 8)
    assert pairs.sensor_states(times).shape == (8, 8, 5, 6)
    for i in range(8):
        one = kin.step(states[i], actions[i], 2.0)
        np.testing.assert_allclose(one.sensor_states(times), paired.sensor_states(times)[i],
                                   rtol=1e-14, atol=1e-9)
        np.testing.assert_allclose(pairs.sensor_states(times)[i, i],
                                   one.sensor_states(times), rtol=1e-14, atol=1e-9)
        for name in ("speed_limited", "turn_limited", "acceleration_limited",
                     "climb_limited"):
            assert bool(getattr(one, name)) == bool(getattr(paired, name)[i])
    with pytest.raises(ValueError, match="inside the step"):
        paired.sensor_states([12.0])


# --------------------------------------------------------------------------- as a track


def test_flown_path_is_a_sensor_track_with_the_exact_positions():
    start = PlatformState((0.0, 0.0, 300.0), 0.0, 50.0)
    choice = [13, 14, 12, 7, 2, 0, 9]
    path = HN.kinematics.fly(start, HN.actions[choice], HN.interval)
    assert isinstance(path, SensorTrack)
    assert (path.start_time, path.end_time) == (0.0, 3.5)
    state = start
    for k, c in enumerate(choice):
        step = HN.kinematics.step(state, HN.actions[c], HN.interval)
        inside = k * 0.5 + np.array([0.0, 0.1, 0.25, 0.4999])
        np.testing.assert_allclose(path.states(inside), step.sensor_states(inside),
                                   rtol=1e-13, atol=1e-9)
        state = step.end
    np.testing.assert_allclose(path.states(3.5)[0], state.sensor_state, atol=1e-9)
    with pytest.raises(ValueError, match="inside the flown path"):
        path.states([3.6])
    # chosen candidates of vectorised steps make the same track
    steps, state = [], start
    for c in choice:
        steps.append(HN.kinematics.step(state, HN.actions, HN.interval)[c])
        state = steps[-1].end
    np.testing.assert_allclose(PlatformTrack(steps).states(np.linspace(0, 3.5, 29)),
                               path.states(np.linspace(0, 3.5, 29)), rtol=1e-13, atol=1e-9)
    with pytest.raises(ValueError, match="does not start"):
        PlatformTrack([steps[0], steps[2]])
    with pytest.raises(ValueError, match="candidates"):
        PlatformTrack([HN.kinematics.step(start, HN.actions, HN.interval)])


def test_scenario_simulates_measurements_from_a_flown_path():
    path = HN.kinematics.fly(PlatformState((0.0, 0.0), 0.0, 50.0), HN.actions[[14] * 20],
                             HN.interval)
    times = np.linspace(0.0, 10.0, 21)
    scn = tk.Scenario("platform", ConstantVelocity(2, 0.0),
                      {"x": 5e3, "y": 8e3, "vx": 25.0, "vy": 0.0}, {"radar": path},
                      [tk.MeasurementPlan("bearing", "radar", times, sigma=1e-3)])
    meas = scn.simulate(rng=1, noise=False)
    np.testing.assert_allclose(meas.sensor_state, path.states(meas.time), atol=1e-12)
