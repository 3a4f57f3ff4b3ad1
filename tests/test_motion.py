"""Motion models: constant velocity, stationary, exact curvilinear propagation, piecewise
curvilinear manoeuvres, and parsing of model names."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from kernel_paths import numerical_jacobian
from scipy.integrate import solve_ivp

from tmakit.core.frames import wrap_angle
from tmakit.motion import (
    ConstantVelocity,
    PiecewiseCurvilinear,
    Stationary,
    motion_from_name,
    propagate_curvilinear,
)
from tmakit.motion.names import DEFAULT_MANOEUVRES

HYPOTHESIS = settings(max_examples=60, deadline=None)

POSITION = st.floats(-50e3, 50e3)
VELOCITY = st.floats(-300.0, 300.0)
TIME = st.floats(0.0, 1000.0)
TIMES = st.lists(TIME, min_size=1, max_size=6).map(np.array)
POSITION_SCALE = 1e3  # m: the smallest position scale used for finite-difference steps
VELOCITY_SCALE = 300.0  # m/s


# --------------------------------------------------------------------------------------------
# (a) constant velocity and stationary
# --------------------------------------------------------------------------------------------


def cv_theta(dim: int) -> st.SearchStrategy[np.ndarray]:
    return st.tuples(*([POSITION] * dim + [VELOCITY] * dim)).map(np.array)


def central_difference_jacobian(model, theta: np.ndarray, t: np.ndarray,
                                scale: np.ndarray, rel_step: float) -> np.ndarray:
    """d states / d theta ``(n, 6, p)`` by central differences with steps rel_step * scale."""
    cols = []
    for j in range(theta.shape[-1]):
        h = rel_step * scale[j]
        step = np.zeros(theta.shape)
        step[j] = h
        cols.append((model.states(theta + step, t) - model.states(theta - step, t)) / (2 * h))
    return np.stack(cols, axis=-1)


def rounding_floor(states: np.ndarray, rel_step: float, scale: np.ndarray) -> np.ndarray:
    """Per-parameter rounding level of central differences, ``eps max|state| / step``,
    times 100 (the steps themselves and the state sums round too; a wrong Jacobian entry is
    off by far more)."""
    return 100.0 * np.finfo(float).eps * np.max(np.abs(states)) / (rel_step * scale)


def assert_jacobian_close(analytic, numeric, rtol, atol, what=""):
    """Entry-wise ``|a - n| <= rtol * max|a| + atol`` (``atol`` may be per parameter)."""
    analytic = np.asarray(analytic)
    numeric = np.asarray(numeric)
    assert analytic.shape == numeric.shape
    tol = np.broadcast_to(rtol * np.max(np.abs(analytic)) + np.asarray(atol), analytic.shape)
    err = np.abs(analytic - numeric)
    bad = ~(err <= tol)
    assert not np.any(bad), (
        f"{what}: {int(bad.sum())} entries differ; first at "
        f"{tuple(int(i) for i in np.argwhere(bad)[0])}: error {err[bad][0]:.3e} > "
        f"tolerance {tol[bad][0]:.3e}"
    )


@pytest.mark.parametrize("dim", [2, 3])
@HYPOTHESIS
@given(data=st.data(), ref_time=TIME, t=TIMES)
def test_constant_velocity_jacobian_and_reference(dim, data, ref_time, t):
    theta = data.draw(cv_theta(dim), label="theta")
    model = ConstantVelocity(dim, ref_time)
    assert model.n_params == 2 * dim
    states = model.states(theta, t)
    jac = model.jacobian(theta, t)
    assert states.shape == (t.size, 6)
    assert jac.shape == (t.size, 6, 2 * dim)

    scale = np.concatenate([np.maximum(np.abs(theta[:dim]), POSITION_SCALE),
                            np.full(dim, VELOCITY_SCALE)])
    # states are linear in theta: no truncation error, so a step of 1e-4 x scale is exact up
    # to rounding
    numeric = central_difference_jacobian(model, theta, t, scale, 1e-4)
    assert_jacobian_close(jac, numeric, 1e-8, rounding_floor(states, 1e-4, scale),
                          f"cv{dim}d")

    # closed form: p(t) = p_ref + v (t - t_ref)
    expected = np.zeros((t.size, 6))
    expected[:, :dim] = theta[:dim] + np.outer(t - ref_time, theta[dim:])
    expected[:, 3:3 + dim] = theta[dim:]
    np.testing.assert_allclose(states, expected, rtol=1e-14, atol=1e-9)
    if dim == 2:
        assert np.all(states[:, 2] == 0.0) and np.all(states[:, 5] == 0.0)
        assert np.all(jac[:, [2, 5], :] == 0.0)

    # at the reference time the state is the reference position and the velocity
    at_ref = model.states(theta, [ref_time])[0]
    np.testing.assert_array_equal(at_ref[:dim], theta[:dim])
    np.testing.assert_array_equal(at_ref[3:3 + dim], theta[dim:])

    # the same trajectory referenced at another time, from its state then
    new_ref = data.draw(TIME, label="new_ref")
    theta_new = ConstantVelocity(dim, new_ref).from_state(model.states(theta, [new_ref])[0],
                                                          new_ref)
    np.testing.assert_allclose(ConstantVelocity(dim, new_ref).states(theta_new, t), states,
                               rtol=1e-12, atol=1e-8)
    np.testing.assert_allclose(theta_new[:dim], model.states(theta, [new_ref])[0, :dim],
                               rtol=1e-14, atol=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
@HYPOTHESIS
@given(data=st.data(), t=TIMES)
def test_stationary(dim, data, t):
    theta = np.array(data.draw(st.tuples(*[POSITION] * dim)))
    model = Stationary(dim)
    states = model.states(theta, t)
    jac = model.jacobian(theta, t)
    assert states.shape == (t.size, 6) and jac.shape == (t.size, 6, dim)
    np.testing.assert_array_equal(states[:, :dim], np.broadcast_to(theta, (t.size, dim)))
    assert np.all(states[:, dim:] == 0.0)  # z = 0 in 2-D and no velocity
    scale = np.maximum(np.abs(theta), POSITION_SCALE)
    numeric = central_difference_jacobian(model, theta, t, scale, 1e-4)
    assert_jacobian_close(jac, numeric, 1e-8, rounding_floor(states, 1e-4, scale),
                          f"static{dim}d")


@pytest.mark.parametrize("model", [ConstantVelocity(2, 100.0), ConstantVelocity(3, -50.0),
                                   Stationary(2), Stationary(3)], ids=repr)
def test_batch_theta(model):
    rng = np.random.default_rng(7)
    B, t = 5, np.array([0.0, 10.0, 250.0, 999.0])
    theta = rng.uniform(-300.0, 300.0, size=(B, model.n_params)) * 10.0
    states = model.states(theta, t)
    jac = model.jacobian(theta, t)
    assert states.shape == (B, t.size, 6)
    assert jac.shape == (B, t.size, 6, model.n_params)
    for b in range(B):
        np.testing.assert_array_equal(states[b], model.states(theta[b], t))
        np.testing.assert_array_equal(jac[b], model.jacobian(theta[b], t))
    # and two leading axes
    theta2 = theta[:4].reshape(2, 2, -1)
    assert model.states(theta2, t).shape == (2, 2, t.size, 6)
    np.testing.assert_array_equal(model.states(theta2, t)[1, 0], states[2])
    # numerical_jacobian handles batches too
    numeric = numerical_jacobian(model, theta, t)
    assert numeric.shape == jac.shape
    for b in range(B):
        np.testing.assert_array_equal(numeric[b], numerical_jacobian(model, theta[b], t))
    # (its fixed relative step 1e-6 leaves rounding errors ~ eps |state| / step)
    np.testing.assert_allclose(numeric, jac, rtol=0, atol=1e-4)


def test_wrong_parameter_count_is_rejected():
    with pytest.raises(ValueError, match="takes 4 parameters"):
        ConstantVelocity(2).states(np.zeros(6), [0.0])
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        ConstantVelocity(4)


# --------------------------------------------------------------------------------------------
# (b) exact curvilinear propagation against an ODE solver
# --------------------------------------------------------------------------------------------


def integrate_curvilinear(x, y, speed, course, a_t, a_n, dt):
    """x' = v sin(phi), y' = v cos(phi), v' = a_t, phi' = a_n / v (phi clockwise from North)."""

    def rhs(_, s):
        v, phi = s[2], s[3]
        return [v * np.sin(phi), v * np.cos(phi), a_t, a_n / v]

    if dt == 0:
        return np.array([x, y, speed, course])
    sol = solve_ivp(rhs, (0.0, dt), [x, y, speed, course], method="DOP853", rtol=1e-11,
                    atol=1e-12)
    assert sol.success
    return sol.y[:, -1]


def check_against_ode(x, y, speed, course, a_t, a_n, dt):
    out = propagate_curvilinear(x, y, speed, course, a_t, a_n, dt)
    assert len(out) == 6
    xs, ys, vs, cs, vx, vy = (float(o) for o in out)
    ode = integrate_curvilinear(x, y, speed, course, a_t, a_n, dt)
    # the reference's own error: its rtol of 1e-11 on positions of up to 1.5e5 m
    tol = 1e-6 + 1e-10 * max(abs(x), abs(y), abs(ode[0]), abs(ode[1]))
    assert abs(xs - ode[0]) <= tol and abs(ys - ode[1]) <= tol, (xs - ode[0], ys - ode[1])
    assert abs(vs - ode[2]) <= 1e-9, vs - ode[2]
    assert abs(wrap_angle(cs - ode[3])) <= 1e-9, cs - ode[3]
    # the velocity is speed * (sin course, cos course)
    np.testing.assert_allclose([vx, vy], [vs * np.sin(cs), vs * np.cos(cs)], rtol=0,
                               atol=1e-12 * vs)
    return out


CURVILINEAR_CASES = {
    # name: (x, y, speed, course, a_t, a_n, dt)
    "turn_starboard": (-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, 0.5, 200.0),
    "turn_port": (-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, -0.5, 200.0),
    "turn_backward": (1000.0, -2000.0, 80.0, 0.3, 0.0, 1.2, -250.0),
    "many_revolutions": (0.0, 0.0, 20.0, -2.0, 0.0, 2.0, 300.0),
    "accelerating_turn": (500.0, 700.0, 40.0, 1.0, 0.3, 0.2, 300.0),
    "decelerating_port_turn": (500.0, 700.0, 50.0, -2.5, -0.1, -0.4, 150.0),
    "accelerating_backward": (-4e4, 3e4, 50.0, 2.0, 0.1, 0.3, -200.0),
    "decelerating_backward": (-4e4, 3e4, 50.0, 2.0, -0.1, -0.3, -400.0),
    "pure_acceleration": (100.0, 200.0, 10.0, 0.7, 0.5, 0.0, 100.0),
    "tiny_both": (-9000.0, 12000.0, 50.0, np.pi / 2, 1e-9, 1e-9, 1000.0),
    "tiny_both_backward": (-9000.0, 12000.0, 50.0, np.pi / 2, -1e-9, 1e-9, -1000.0),
    "tiny_normal": (0.0, 0.0, 7.0, 3.0, 0.0, -1e-9, 800.0),
    "tiny_tangential": (0.0, 0.0, 7.0, -3.0, 1e-9, 0.0, 800.0),
    "zero": (-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, 0.0, 900.0),
    "zero_backward": (-9000.0, 12000.0, 50.0, 0.4, 0.0, 0.0, -900.0),
    "zero_dt": (5.0, 6.0, 50.0, 0.4, 0.3, 0.2, 0.0),
    # either side of the switch between series and closed form (|g| + |r| = 0.05)
    "series_side": (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 0.9 * 0.05 * 50.0 / 0.056),
    "closed_form_side": (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 1.1 * 0.05 * 50.0 / 0.056),
    "series_side_turn": (0.0, 0.0, 50.0, 1.0, 0.0, 0.05, 0.99 * 0.05 * 50.0 / 0.05),
    "closed_form_side_turn": (0.0, 0.0, 50.0, 1.0, 0.0, 0.05, 1.01 * 0.05 * 50.0 / 0.05),
}


@pytest.mark.parametrize("args", CURVILINEAR_CASES.values(), ids=CURVILINEAR_CASES.keys())
def test_propagate_curvilinear_matches_ode(args):
    check_against_ode(*args)


@settings(max_examples=20, deadline=None)
@given(x=POSITION, y=POSITION, speed=st.floats(5.0, 300.0), course=st.floats(-np.pi, np.pi),
       a_t=st.one_of(st.just(0.0), st.floats(-1.0, 1.0)), a_n=st.floats(-3.0, 3.0),
       dt=st.floats(-500.0, 500.0))
def test_propagate_curvilinear_matches_ode_random(x, y, speed, course, a_t, a_n, dt):
    if speed + a_t * dt < 1.0:  # keep away from the stop, where the ODE is stiff
        dt = -dt
    if speed + a_t * dt < 1.0:
        return
    check_against_ode(x, y, speed, course, a_t, a_n, dt)


def test_propagate_curvilinear_broadcasts_and_straight_line():
    dt = np.array([-100.0, 0.0, 50.0, 400.0])
    x, y, v, c, vx, vy = propagate_curvilinear(10.0, 20.0, 30.0, np.pi / 2, 0.0, 0.0, dt)
    assert x.shape == dt.shape
    np.testing.assert_allclose(x, 10.0 + 30.0 * dt, rtol=1e-15, atol=1e-9)
    np.testing.assert_allclose(y, 20.0, atol=1e-9)
    np.testing.assert_allclose(vx, 30.0, rtol=1e-15)
    np.testing.assert_allclose(vy, 0.0, atol=1e-12)
    np.testing.assert_array_equal(v, 30.0)
    np.testing.assert_array_equal(c, np.pi / 2)


@pytest.mark.parametrize(("speed", "a_t", "dt"), [
    (10.0, -1.0, 20.0),    # stops at 10 s, goes on decelerating
    (10.0, -1.0, 10.0),    # exactly zero at the end
    (10.0, 1.0, -20.0),    # backwards in time the speed was negative
    (10.0, 0.5, -20.0),    # ... and exactly zero
    (0.0, 0.0, 5.0),       # no speed at all
    (-5.0, 0.0, 5.0),
])
def test_propagate_curvilinear_nan_when_speed_not_positive(speed, a_t, dt):
    out = propagate_curvilinear(0.0, 0.0, speed, 0.3, a_t, 0.1, dt)
    assert all(np.isnan(o) for o in out)
    # elementwise: valid samples in the same call are not affected
    out = propagate_curvilinear(0.0, 0.0, speed, 0.3, a_t, 0.1, np.array([dt, 0.0]))
    assert all(np.isnan(o[0]) for o in out)
    assert all(np.isfinite(o[1]) for o in out) == (speed > 0)


# --------------------------------------------------------------------------------------------
# (c) piecewise curvilinear motion: the scenario of Hörst & Oispuu (2010)
# --------------------------------------------------------------------------------------------

T1, T2 = 400.0, 600.0
SCENARIO = {"x": -9000.0, "y": 12000.0, "speed": 50.0, "course": np.pi / 2,
            "at_0": 0.0, "an_0": 0.0, "at_1": 0.0, "an_1": 0.5, "at_2": 0.0, "an_2": 0.0,
            "t_1": T1, "t_2": T2}
TURN = 0.5 / 50.0 * (T2 - T1)  # course change during the manoeuvre, rad (= 2)


def scenario_theta(model=None, **changes):
    model = model or PiecewiseCurvilinear(2, 0.0)
    return model.theta({**SCENARIO, **changes})


def course_of(states):
    return np.arctan2(states[..., 3], states[..., 4])


def theta_from_state(state, accelerations_and_times):
    """Curvilinear parameters (x, y, speed, course, ...) from a Cartesian state."""
    return np.array([state[0], state[1], np.hypot(state[3], state[4]), course_of(state),
                     *accelerations_and_times])


def test_scenario_geometry():
    model = PiecewiseCurvilinear(2, 0.0)
    assert model.param_names == tuple(SCENARIO)
    theta = scenario_theta()
    t = np.arange(0.0, 901.0, 1.0)
    s = model.states(theta, t)
    assert s.shape == (t.size, 6)
    assert np.all(np.isfinite(s))
    assert np.all(s[:, [2, 5]] == 0.0)  # planar
    np.testing.assert_allclose(np.hypot(s[:, 3], s[:, 4]), 50.0, rtol=0, atol=1e-9)

    before, during, after = t <= T1, (t > T1) & (t <= T2), t >= T2
    np.testing.assert_allclose(wrap_angle(course_of(s[before]) - np.pi / 2), 0.0, atol=1e-12)
    # straight East before the manoeuvre
    np.testing.assert_allclose(s[before, 0], -9000.0 + 50.0 * t[before], rtol=1e-14, atol=1e-9)
    np.testing.assert_allclose(s[before, 1], 12000.0, atol=1e-9)
    # a clockwise circle of radius v^2 / a_n = 5 km around (11000, 7000) during it
    radius, centre = 50.0**2 / 0.5, np.array([11000.0, 7000.0])
    swept = 0.5 / 50.0 * (t[during] - T1)
    np.testing.assert_allclose(s[during, 0], centre[0] + radius * np.sin(swept), atol=1e-7)
    np.testing.assert_allclose(s[during, 1], centre[1] + radius * np.cos(swept), atol=1e-7)
    np.testing.assert_allclose(wrap_angle(course_of(s[during]) - (np.pi / 2 + swept)), 0.0,
                               atol=1e-11)
    # the course turned by 0.5 / 50 * 200 = 2 rad, then a straight line
    assert TURN == pytest.approx(2.0)
    np.testing.assert_allclose(wrap_angle(course_of(s[after]) - (np.pi / 2 + TURN)), 0.0,
                               atol=1e-11)
    end_of_turn = centre + radius * np.array([np.sin(TURN), np.cos(TURN)])
    heading = np.array([np.sin(np.pi / 2 + TURN), np.cos(np.pi / 2 + TURN)])
    np.testing.assert_allclose(s[after, :2],
                               end_of_turn + 50.0 * np.outer(t[after] - T2, heading),
                               atol=1e-7)


def test_scenario_continuous_at_change_over_times():
    model = PiecewiseCurvilinear(2, 0.0)
    theta = scenario_theta()
    for tm in (T1, T2):
        for delta in (1e-3, 1e-6):
            s = model.states(theta, [tm - delta, tm, tm + delta])
            step = np.linalg.norm(np.diff(s[:, :2], axis=0), axis=-1)
            # moving at 50 m/s: each step is 50 * delta (up to the curvature)
            np.testing.assert_allclose(step, 50.0 * delta, rtol=1e-6, atol=1e-9)
            # the velocity changes by at most |a| * delta
            dv = np.linalg.norm(np.diff(s[:, 3:5], axis=0), axis=-1)
            assert np.all(dv <= 0.5 * delta * (1 + 1e-6) + 1e-10), dv


@pytest.mark.parametrize("new_ref", [250.0, T1, 500.0, T2, 900.0])
def test_scenario_referenced_at_another_time(new_ref):
    """Parameters taken from the state at ``new_ref`` reproduce the same trajectory."""
    model = PiecewiseCurvilinear(2, 0.0)
    theta = scenario_theta()
    t = np.arange(0.0, 901.0, 5.0)
    s = model.states(theta, t)
    state_at_ref = model.states(theta, [new_ref])[0]
    moved = PiecewiseCurvilinear(2, new_ref)
    theta_new = theta_from_state(state_at_ref, theta[4:])
    s_new = moved.states(theta_new, t)
    np.testing.assert_allclose(s_new[:, :2], s[:, :2], rtol=0, atol=1e-6)
    np.testing.assert_allclose(s_new[:, 3:5], s[:, 3:5], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(s_new[:, [2, 5]], 0.0)


def test_sample_at_change_over_time_belongs_to_earlier_segment():
    model = PiecewiseCurvilinear(2, 0.0)
    t = np.array([T1 - 10.0, T1, T1 + 1e-3, T1 + 10.0])
    base = model.states(scenario_theta(), t)
    # other accelerations in the later segment: samples up to and at t_1 unchanged
    other = model.states(scenario_theta(at_1=0.2, an_1=-0.7), t)
    np.testing.assert_array_equal(other[:2], base[:2])
    assert np.all(np.abs(other[2:, 3:5] - base[2:, 3:5]) > 1e-5)
    # a later segment with undefined accelerations: the sample at t_1 is still computed with
    # the earlier segment's, every later sample is NaN
    poisoned = model.states(scenario_theta(at_1=np.nan, an_1=np.nan), t)
    np.testing.assert_array_equal(poisoned[:2], base[:2])
    assert np.all(np.isnan(poisoned[2:, [0, 1, 3, 4]]))

    # referenced after the change-over, the chain runs backwards: now the earlier segment's
    # accelerations decide the sample at t_1
    s_end = model.states(scenario_theta(), [900.0])[0]
    late = PiecewiseCurvilinear(2, 900.0)
    theta_late = theta_from_state(s_end, scenario_theta()[4:])
    np.testing.assert_allclose(late.states(theta_late, t), base, rtol=0, atol=1e-6)
    theta_late_poisoned = theta_late.copy()
    theta_late_poisoned[4:6] = np.nan  # at_0, an_0
    s = late.states(theta_late_poisoned, t)
    assert np.all(np.isnan(s[:2, [0, 1, 3, 4]]))
    np.testing.assert_allclose(s[2:], base[2:], rtol=0, atol=1e-6)


@pytest.mark.parametrize(("t_1", "t_2"), [(T2, T1), (T1, T1)])
def test_change_over_times_out_of_order_give_nan(t_1, t_2):
    model = PiecewiseCurvilinear(2, 0.0)
    s = model.states(scenario_theta(t_1=t_1, t_2=t_2), np.array([0.0, 500.0, 900.0]))
    assert s.shape == (3, 6)
    assert np.all(np.isnan(s))


def test_curvilinear_jacobian():
    model = PiecewiseCurvilinear(2, 0.0)
    theta = scenario_theta(at_0=0.02, an_0=-0.01, at_1=-0.03, at_2=0.05, an_2=0.1)
    t = np.array([0.0, 100.0, 350.0, 450.0, 550.0, 650.0, 900.0])  # not at t_1, t_2
    jac = model.jacobian(theta, t)
    assert jac.shape == (t.size, 6, model.n_params)
    assert np.all(np.isfinite(jac))
    # the analytic Jacobian against a central difference, step 1e-4 * max(1, |theta_j|)
    # (tests/test_manoeuvre.py checks it to 1e-8 with fourth-order differences)
    scale = np.maximum(1.0, np.abs(theta))
    numeric = central_difference_jacobian(model, theta, t, scale, 1e-4)
    for j, name in enumerate(model.param_names):
        assert_jacobian_close(jac[..., j], numeric[..., j], 1e-5, 1e-6, name)
    # some entries known in closed form: position moves with the start position ...
    np.testing.assert_allclose(jac[:, 0, 0], 1.0, rtol=1e-9)
    np.testing.assert_allclose(jac[:, 1, 1], 1.0, rtol=1e-9)
    # ... and nothing before t_1 depends on later accelerations or change-over times
    early = t < T1
    np.testing.assert_array_equal(jac[early][..., 6:], 0.0)

    # batches of parameter vectors
    batch = np.stack([theta, scenario_theta()])
    jac_b = model.jacobian(batch, t)
    assert jac_b.shape == (2, t.size, 6, model.n_params)
    np.testing.assert_allclose(jac_b[0], jac, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(model.states(batch, t)[1], model.states(scenario_theta(), t),
                               rtol=0, atol=0)


def test_curvilinear_without_manoeuvres_is_one_propagation():
    model = PiecewiseCurvilinear(0, 100.0)
    assert model.param_names == ("x", "y", "speed", "course", "at_0", "an_0")
    theta = np.array([300.0, -400.0, 25.0, -1.0, 0.05, -0.2])
    t = np.array([0.0, 50.0, 100.0, 300.0])
    s = model.states(theta, t)
    x, y, _, _, vx, vy = propagate_curvilinear(*theta, t - 100.0)
    np.testing.assert_allclose(s[:, 0], x, rtol=1e-15)
    np.testing.assert_allclose(s[:, 1], y, rtol=1e-15)
    np.testing.assert_allclose(s[:, 3], vx, rtol=1e-15)
    np.testing.assert_allclose(s[:, 4], vy, rtol=1e-15)


# --------------------------------------------------------------------------------------------
# (d) model names
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "cls", "dim", "n_params"), [
    ("cv2d", ConstantVelocity, 2, 4),
    ("cv3d", ConstantVelocity, 3, 6),
    ("static", Stationary, 2, 2),
    ("static2d", Stationary, 2, 2),
    ("static3d", Stationary, 3, 3),
    ("curvilinear", PiecewiseCurvilinear, 2, 12),  # = curvilinear:2 (tmakit.motion.names)
    ("curvilinear:0", PiecewiseCurvilinear, 2, 6),
    ("curvilinear:2", PiecewiseCurvilinear, 2, 12),
    (" CV3D ", ConstantVelocity, 3, 6),
])
def test_motion_from_name(name, cls, dim, n_params):
    model = motion_from_name(name, ref_time=12.5)
    assert type(model) is cls
    assert model.dim == dim
    assert model.n_params == n_params
    if hasattr(model, "ref_time"):
        assert model.ref_time == 12.5


def test_motion_from_name_names_round_trip():
    for name in ("cv2d", "cv3d", "static2d", "static3d", "curvilinear:0", "curvilinear:3"):
        assert motion_from_name(name).name == name


@pytest.mark.parametrize("bad", ["cv4d", "constant", ""])
def test_motion_from_name_rejects_unknown(bad):
    with pytest.raises(ValueError) as err:
        motion_from_name(bad)
    message = str(err.value)
    assert repr(bad) in message
    for accepted in ("cv2d", "cv3d", "static2d", "static3d", "curvilinear"):
        assert accepted in message


def test_motion_from_name_rejects_bad_manoeuvre_count():
    with pytest.raises(ValueError, match="curvilinear:M"):
        motion_from_name("curvilinear:two")


# -- one meaning per name, whoever reads it (issue 10: the parser is tmakit.motion.names) --------

AGREEMENT_NAMES = ["cv2d", "cv", " CV2D ", "cv3d", "static", "static2d", "static3d",
                   "curvilinear", "Curvilinear", "curvilinear:0", "curvilinear:1",
                   "curvilinear:3"]


def test_curvilinear_means_two_manoeuvres():
    model = motion_from_name("curvilinear", ref_time=5.0)
    assert model.manoeuvres == DEFAULT_MANOEUVRES == 2 and model.name == "curvilinear:2"
    assert model.param_names == motion_from_name("curvilinear:2").param_names
    for bad in ("curvilinear:", "curvilinear:-1", "curvilinear:2.5", "curvilinearx", "cv2"):
        with pytest.raises(ValueError):
            motion_from_name(bad)


class _Routed(Exception):
    """Raised by the stand-ins below: which estimator a motion name reached, with what."""


@pytest.fixture(scope="module")
def hoerst_file(tmp_path_factory):
    from typer.testing import CliRunner

    from tmakit.cli import app

    path = tmp_path_factory.mktemp("names") / "obs.csv"
    assert CliRunner().invoke(app, ["simulate", "hoerst2010", "--seed", "1", "-o",
                                    str(path)]).exit_code == 0
    return path


def _stand_ins(monkeypatch):
    """Replace the work of both estimators by stand-ins that report what they were asked to
    fit: the manoeuvre search, and the no-guess fit of a fixed model."""
    import tmakit.batch.manoeuvre as manoeuvre
    import tmakit.batch.ml as ml

    def manoeuvres(meas, max_manoeuvres=2, **kw):
        raise _Routed(("manoeuvres", max_manoeuvres))

    def fixed(problem, ys, *args, **kw):
        raise _Routed(("model", problem.obs.motion.name))

    monkeypatch.setattr(manoeuvre, "estimate_manoeuvres", manoeuvres)
    monkeypatch.setattr(ml, "solve_without_guess", fixed)


def _meaning(name):
    """What a name must mean to every caller: the model, and for a piecewise curvilinear one
    the largest number of manoeuvres the estimator searches."""
    model = motion_from_name(name)
    if isinstance(model, PiecewiseCurvilinear):
        return ("manoeuvres", model.manoeuvres)
    return ("model", model.name)


@pytest.mark.parametrize("name", AGREEMENT_NAMES)
def test_every_caller_reads_a_motion_name_alike(name, hoerst_file, monkeypatch, tmp_path):
    """motion_from_name, the estimator's hook (what ``tk.estimate`` calls with a name), the
    CLI's ``tma estimate --motion`` and scenario files give a name the same meaning."""
    from typer.testing import CliRunner

    import tmakit as tk
    from tmakit.batch.curvilinear import estimate_for
    from tmakit.cli import app

    want = _meaning(name)
    meas = tk.read_measurements(hoerst_file)
    _stand_ins(monkeypatch)
    with pytest.raises(_Routed) as hook:
        estimate_for(meas, name)
    assert hook.value.args[0] == want
    with pytest.raises(_Routed) as short:
        tk.estimate(meas, name)
    assert short.value.args[0] == want
    cli = CliRunner().invoke(app, ["--debug", "estimate", str(hoerst_file), "--motion", name])
    assert isinstance(cli.exception, _Routed), cli.output
    assert cli.exception.args[0] == want
    # a scenario file naming its target's motion so: the built-in file, its motion renamed
    from importlib import resources

    toml = (resources.files("tmakit.scenario") / "builtin" / "hoerst2010.toml").read_text()
    if want == ("manoeuvres", 2):
        path = tmp_path / "renamed.toml"
        path.write_text(toml.replace('motion = "curvilinear:2"', f'motion = "{name}"'))
        scn = tk.load_scenario(path)
        assert scn.motion.name == "curvilinear:2" and scn.motion.n_params == 12


def test_an_unknown_name_is_refused_alike(hoerst_file):
    from typer.testing import CliRunner

    import tmakit as tk
    from tmakit.batch.curvilinear import estimate_for
    from tmakit.cli import app

    meas = tk.read_measurements(hoerst_file)
    for bad in ("curvilinear:x", "cv4d"):
        with pytest.raises(ValueError) as lib:
            motion_from_name(bad)
        with pytest.raises(ValueError) as hook:
            estimate_for(meas, bad)
        assert str(hook.value) == str(lib.value)
        cli = CliRunner().invoke(app, ["estimate", str(hoerst_file), "--motion", bad])
        assert cli.exit_code == 2 and repr(bad) in cli.output


@pytest.mark.parametrize("motion", [ConstantVelocity(2, ref_time=3.0), ConstantVelocity(3),
                                    Stationary(2)], ids=lambda m: m.name)
def test_component_terms_give_the_states(motion):
    t = np.linspace(-5.0, 50.0, 7)
    terms, offset = motion.component_terms(t)
    theta = np.arange(1.0, motion.n_params + 1.0)
    states = np.array(offset, dtype=float)
    for i, c, coef in terms:
        states[c] += theta[i] * (1.0 if coef is None else coef)
    assert np.allclose(states.T, motion.states(theta, t), rtol=1e-14, atol=1e-12)
