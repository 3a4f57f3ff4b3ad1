"""The planar bearing linearisation (``tmakit.observation.planar``) is the general one.

For one kind of bearings under an affine motion model and one parameter vector, the
observation model writes the predictions and the Jacobian directly from the two relative
components a bearing uses.  It must give what the general path (relative states ``(n, 6)``,
their derivatives, the motion's chain rule) gives, to 1e-12, and a Jacobian equal to central
finite differences of the predictions; it must not apply where it cannot (several kinds, a
batch of parameter vectors) and the Jacobian it hands over may be scaled by the caller
without changing a later one.  The solver's evaluation with it (residual wrapped in place)
equals the general one.
"""

from __future__ import annotations

import numpy as np
import pytest
from bearing_sets import bearings

import tmakit as tk
from tmakit.batch import VarProProblem
from tmakit.batch.varpro import _wrap_own
from tmakit.core.frames import wrap_angle
from tmakit.observation.planar import planar_linearisation

CASES = [
    (tk.ConstantVelocity(2), np.array([8000.0, 12000.0, -4.0, 2.5]), 2),
    (tk.ConstantVelocity(2, ref_time=600.0), np.array([-5000.0, 9000.0, 3.0, -1.0]), 2),
    (tk.ConstantVelocity(3), np.array([8000.0, 12000.0, 100.0, -4.0, 2.5, 0.5]), 3),
    (tk.Stationary(2), np.array([7000.0, -9000.0]), 2),
]


@pytest.mark.parametrize("n", [50, 5000])  # both ways of AffineRows.single
@pytest.mark.parametrize(("motion", "theta", "dim"), CASES)
def test_planar_equals_the_general_path(motion, theta, dim, n):
    meas = bearings(motion, theta, n, seed=n, dim=dim)
    obs = tk.ObservationModel(meas, motion)
    trial = theta * 1.01 + 3.0
    for point in (trial, trial[None]):
        lin = obs.linearisation(point)
        assert lin.planar_jacobian is not None  # the planar path was taken
        # the general path: a batch of two parameter vectors is not planar
        both = obs.linearisation(np.stack([trial, trial]))
        assert both.planar_jacobian is None
        jac = lin.jacobian(np.zeros(0))
        assert jac.shape == (*point.shape[:-1], n, theta.size)
        assert lin.h0.shape == (*point.shape[:-1], n)
        np.testing.assert_allclose(lin.h0.reshape(n), both.h0[0], rtol=0, atol=1e-12)
        general = both.jacobian(np.zeros(0))[0]
        scale = np.abs(general).max()
        np.testing.assert_allclose(jac.reshape(n, -1), general, rtol=0, atol=1e-12 * scale)
        np.testing.assert_array_equal(lin.a_var.shape, (*point.shape[:-1], n, 0))


@pytest.mark.parametrize(("motion", "theta", "dim"), CASES)
def test_planar_jacobian_is_the_finite_difference_of_thebearings(motion, theta, dim):
    meas = bearings(motion, theta, 300, seed=1, dim=dim)
    obs = tk.ObservationModel(meas, motion)
    jac = obs.linearisation(theta).jacobian(np.zeros(0))
    step = np.where(np.arange(theta.size) < dim, 1.0, 1e-3)  # m and m/s
    if isinstance(motion, tk.Stationary):
        step = np.ones(theta.size)
    for i in range(theta.size):
        e = np.zeros(theta.size)
        e[i] = step[i]
        up = obs.linearisation(theta + e, derivatives=False).h0
        down = obs.linearisation(theta - e, derivatives=False).h0
        fd = (up - down) / (2.0 * step[i])
        np.testing.assert_allclose(jac[:, i], fd, rtol=1e-5, atol=1e-12)
    if dim == 3 and not isinstance(motion, tk.Stationary):  # a bearing ignores z and vz
        assert not jac[:, 2].any() and not jac[:, 5].any()


def test_planar_jacobian_handed_over_once_then_copied():
    motion, theta, _ = CASES[0]
    obs = tk.ObservationModel(bearings(motion, theta, 100, seed=2), motion)
    lin = obs.linearisation(theta)
    first = lin.jacobian(np.zeros(0))
    kept = first.copy()
    first *= 2.0  # the caller owns it (the solver whitens it in place)
    np.testing.assert_array_equal(lin.jacobian(np.zeros(0)), kept)
    assert not lin.jacobian(np.zeros(0), with_h0=False).any()


def test_planar_path_declines_other_problems():
    motion, theta, _ = CASES[0]
    meas = bearings(motion, theta, 100, seed=3)
    obs = tk.ObservationModel(meas, motion)
    assert planar_linearisation(obs, np.stack([theta, theta])) is None  # a batch
    gu = tk.load_scenario("gu2007")  # bearing and frequency, with a carrier nuisance
    obs_gu = tk.ObservationModel(gu.simulate(0), gu.motion, gu.measurement_options)
    assert planar_linearisation(obs_gu, gu.theta) is None


@pytest.mark.parametrize("scale", [1e-9, 1.0, 3.0, 6.0, 9.0, 30.0])
def test_residual_wrapping_in_place_is_wrap_angle_bit_for_bit(scale):
    # the solver wraps its own residual array in place (the range tested on e before it is
    # shifted): the same bits as wrap_angle, also where it hands over (beyond one turn)
    rng = np.random.default_rng(5)
    for _ in range(50):
        e = rng.uniform(-1.0, 1.0, size=(1, 60)) * scale
        e[0, :6] = [np.pi, -np.pi, -0.0, 3 * np.pi, np.nextafter(3 * np.pi, 0.0), -3 * np.pi]
        want = wrap_angle(e.copy())
        got = _wrap_own(e, in_place=True)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(want))
    for c in (-3 * np.pi, -np.pi, np.pi, 3 * np.pi):  # every float near the boundaries
        e = (c + np.arange(-500, 500) * np.spacing(c))[None]
        want = wrap_angle(e.copy())
        np.testing.assert_array_equal(_wrap_own(e, in_place=True), want)


def test_solver_evaluation_with_the_planar_path_equals_the_general_one():
    motion, theta, _ = CASES[0]
    meas = bearings(motion, theta, 3000, seed=4)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    one = problem.evaluate_part(theta[None] * 1.02, u, np.zeros((1, 0)))  # planar
    two = problem.evaluate_part(np.stack([theta * 1.02] * 2), np.vstack([u, u]),
                                np.zeros((2, 0)))  # general (a batch)
    np.testing.assert_allclose(one.residual[0], two.residual[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(one.cost[0], two.cost[0], rtol=1e-12)
    np.testing.assert_allclose(one.jacobian[0], two.jacobian[0], rtol=0,
                               atol=1e-12 * np.abs(two.jacobian).max())
