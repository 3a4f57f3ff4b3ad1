"""The compiled bearing kernel (``tmakit.observation.fused_compiled``) is the NumPy path.

On large bearings-only problems under 2-D constant velocity or a stationary model, one
evaluation of the solver gives the whitened residual, ``J'J`` and ``J'r`` from one compiled
pass.  They must equal the NumPy path's (fused linearisation, wrap, whitening, products) to
1e-12, the residual wrapped the same way wherever the data lie, a point on a sensor must
cost infinity in both, the kernel must decline what it does not handle, and a whole
no-guess estimate must give the same answer with and without it.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from bearing_sets import bearings
from kernel_paths import both_paths

import tmakit as tk
from tmakit.batch import VarProProblem
from tmakit.batch.gauss_newton import normal_equations
from tmakit.observation import fused_compiled as compiled

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(not compiled.available(), reason="compiled kernels off")

N = compiled.KERNEL_ROWS + 1000


def _bearings(motion, theta, n, seed, dim=2):
    return bearings(motion, theta, n, seed, dim, unequal_sigma=True)  # unequal weights


def _both(fn):
    """Run ``fn`` with the kernels, then on the NumPy path; give both results."""
    return both_paths(compiled, fn)


CASES = [
    (tk.ConstantVelocity(2), np.array([8000.0, 12000.0, -4.0, 2.5])),
    (tk.ConstantVelocity(2, ref_time=600.0), np.array([-5000.0, 9000.0, 3.0, -1.0])),
    (tk.Stationary(2), np.array([7000.0, -9000.0])),
]


def _evaluations(motion, theta, u_shift=0.0, seed=1):
    meas = _bearings(motion, theta, N, seed=seed)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None] + u_shift
    point = theta[None] * 1.02 + 50.0
    return _both(lambda: problem.evaluate_part(point, u.copy(), np.zeros((1, 0))))


@pytest.mark.parametrize(("motion", "theta"), CASES)
def test_kernel_equals_the_numpy_path(motion, theta):
    fast, slow = _evaluations(motion, theta)
    assert fast.jacobian is None and fast.normal is not None  # the kernel was used
    assert slow.jacobian is not None
    np.testing.assert_allclose(fast.residual, slow.residual, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)
    jtj, grad = normal_equations(fast, None)
    jtj0, grad0 = normal_equations(slow, None)
    np.testing.assert_allclose(jtj, jtj0, rtol=0, atol=1e-12 * np.abs(jtj0).max())
    np.testing.assert_allclose(grad, grad0, rtol=0, atol=1e-12 * np.abs(jtj0).max() ** 0.5
                               * np.sqrt(2.0 * slow.cost[0]))
    free = np.arange(theta.size) != 1  # a parameter held: the normal equations' columns
    np.testing.assert_allclose(normal_equations(fast, free)[0], normal_equations(slow, free)[0],
                               rtol=0, atol=1e-12 * np.abs(jtj0).max())


@pytest.mark.parametrize("shift", [2.0 * np.pi, -2.0 * np.pi, 3.0, 9.0 * np.pi])
def test_kernel_wraps_residuals_as_the_numpy_path(shift):
    """Data a turn away, or half a turn: residuals wrapped the same; several turns away the
    kernel leaves the evaluation to the NumPy path."""
    motion, theta = CASES[0]
    fast, slow = _evaluations(motion, theta, u_shift=shift)
    assert (fast.jacobian is None) == (abs(shift) < 3.0 * np.pi)
    assert np.all(np.abs(fast.residual) <= np.pi / np.radians(0.5))
    np.testing.assert_allclose(fast.residual, slow.residual, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)


def test_point_on_a_sensor_costs_infinity_in_both():
    motion, theta = CASES[2]
    meas = _bearings(motion, theta, N, seed=3)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    on_sensor = problem.obs.grouped.sensor_state[0, :2][None]
    fast, slow = _both(lambda: problem.evaluate_part(on_sensor, u.copy(), np.zeros((1, 0))))
    assert fast.jacobian is None
    assert np.isnan(normal_equations(fast, None)[0]).any()
    np.testing.assert_array_equal(np.isnan(normal_equations(fast, None)[0]),
                                  np.isnan(normal_equations(slow, None)[0]))


def test_kernel_declines_what_it_does_not_handle():
    motion, theta = CASES[0]
    meas = _bearings(motion, theta, N, seed=5)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    batch = np.stack([theta, theta * 1.01])
    assert problem.evaluate_part(batch, np.vstack([u, u]), np.zeros((2, 0))).jacobian is not None
    assert problem.evaluate_part(theta[None], u, np.zeros((1, 0)), with_jacobian=False).normal \
        is None
    small = problem.take(np.arange(compiled.KERNEL_ROWS - 1))
    us = small.group(meas.value_si[:compiled.KERNEL_ROWS - 1])[None]
    assert small.evaluate_part(theta[None], us, np.zeros((1, 0))).jacobian is not None
    motion3 = tk.ConstantVelocity(3)
    theta3 = np.array([8000.0, 12000.0, 100.0, -4.0, 2.5, 0.5])
    meas3 = _bearings(motion3, theta3, N, seed=6, dim=3)
    problem3 = VarProProblem(tk.ObservationModel(meas3, motion3))
    u3 = problem3.group(meas3.value_si)[None]
    assert problem3.evaluate_part(theta3[None], u3, np.zeros((1, 0))).jacobian is not None


def test_no_guess_estimate_is_the_same_with_and_without_the_kernel():
    scn = tk.load_scenario("bearings-only-2d")
    meas = _bearings(scn.motion, scn.theta, 30_000, seed=7)
    fast, slow = _both(lambda: tk.estimate(meas, scn.motion))
    np.testing.assert_allclose(fast.estimate, slow.estimate, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(fast.covariance, slow.covariance, rtol=1e-8)
    assert fast.status == slow.status == "converged"
    assert fast.iterations == slow.iterations


@pytest.mark.parametrize(("motion", "theta"), CASES)
def test_compiled_relative_positions_are_the_affine_maps_bit_for_bit(motion, theta):
    from tmakit.observation import fused_numba

    meas = _bearings(motion, theta, N, seed=8)
    rel_map = tk.ObservationModel(meas, motion)._rel_map
    want = rel_map.single(theta, components=2)  # (the NumPy path)
    lazy = rel_map._offset is None
    base = rel_map._base if lazy else rel_map.offset
    coef = next((c for _, _, c in rel_map.terms if c is not None), base[0])
    got, head = np.empty((2, rel_map.m)), np.empty((2, rel_map.m))
    fused_numba.relative_east_north(base, rel_map._sensor if lazy else base.T, lazy, theta,
                                    coef, theta.size == 4, got, head)
    np.testing.assert_array_equal(got, want)
    if lazy:  # the offset's head it keeps for the next passes: NumPy's bits
        np.testing.assert_array_equal(head, rel_map._offset_head(2))


def test_an_estimate_keeps_the_offset_head_of_its_first_compiled_pass():
    motion, theta = CASES[0]
    meas = _bearings(motion, theta, N, seed=4)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    rel_map = problem.obs._rel_map
    assert rel_map.position_source()[2]  # nothing made yet: from the sensor states
    first = problem.evaluate_part(theta[None] * 1.01, u, np.zeros((1, 0)))
    base, _, lazy = rel_map.position_source()
    assert first.jacobian is None and not lazy  # the head was kept
    np.testing.assert_array_equal(base, rel_map._base[:2] - rel_map._sensor[:, :2].T)
    again = problem.evaluate_part(theta[None] * 1.01, u, np.zeros((1, 0)))
    np.testing.assert_array_equal(again.residual, first.residual)


def test_evaluations_of_both_forms_are_merged_as_normal_equations():
    """A batch's Jacobians and one run's compiled J'J, J'r (a multi-start whose other runs
    stopped) are merged as normal equations, the run's own kept."""
    motion, theta = CASES[0]
    meas = _bearings(motion, theta, N, seed=9)
    problem = VarProProblem(tk.ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    batch = np.stack([theta, theta * 1.01 + 20.0])
    both = problem.evaluate_part(batch, np.vstack([u, u]), np.zeros((2, 0)))  # Jacobians
    one = problem.evaluate_part(batch[1:] + 5.0, u, np.zeros((1, 0)))  # compiled
    assert both.jacobian is not None and one.jacobian is None
    want = problem.evaluate_part(np.stack([batch[0], batch[1] + 5.0]), np.vstack([u, u]),
                                 np.zeros((2, 0)))
    merged = both.take(np.arange(2))
    merged.put(np.array([1]), one)
    jtj, grad = normal_equations(merged, None)
    jtj0, grad0 = normal_equations(want, None)
    np.testing.assert_allclose(jtj, jtj0, rtol=0, atol=1e-12 * np.abs(jtj0).max())
    np.testing.assert_allclose(grad, grad0, rtol=1e-9, atol=1e-9 * np.abs(grad0).max())
    np.testing.assert_allclose(merged.cost, want.cost, rtol=1e-12)
    back = one.take(np.arange(1))
    back.put(np.array([0]), both, np.array([0]))  # the other way round
    np.testing.assert_allclose(normal_equations(back, None)[0][0], jtj0[0], rtol=0,
                               atol=1e-12 * np.abs(jtj0).max())


def test_a_single_fit_does_not_wait_for_numba_and_many_fits_load_it():
    """The kernel is taken where it pays: a fresh process fitting one large set stays on
    NumPy (no 0.3 s import for a 1.5 ms gain); once it has evaluated PAYBACK_ROWS rows on
    the NumPy path, it loads ``numba`` and uses the kernel."""
    script = """
import sys
import numpy as np
import tmakit as tk
from tmakit.observation import fused_compiled as fc
scn = tk.load_scenario("bearings-only-2d")
lo, hi = scn.time_span()
import dataclasses
plans = [dataclasses.replace(p, times=np.linspace(lo, hi, 50_000)) for p in scn.plans]
meas = dataclasses.replace(scn, plans=plans).simulate(np.random.default_rng(0))
first = tk.estimate(meas, scn.motion)
print("numba" in sys.modules, fc._numpy_rows[0] > 0)
fc._numpy_rows[0] = fc.PAYBACK_ROWS  # as after many fits
again = tk.estimate(meas, scn.motion)
print("numba" in sys.modules, np.allclose(first.estimate, again.estimate, rtol=1e-9))
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True, env={**os.environ, "TMAKIT_NO_NUMBA": ""})
    assert out.stdout.split() == ["False", "True", "True", "True"], out.stdout + out.stderr
