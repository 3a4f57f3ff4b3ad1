"""The compiled batch evaluation (observation/varpro_compiled.py) equals the NumPy path.

The NumPy path is the general evaluation of every problem; the kernel, asked for by a large
Monte Carlo study, evaluates the point kinds under affine motion.  Both must agree to
rounding on every scenario the kernel applies to, and decline alike where it does not.
"""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch.varpro import VarProProblem, compiled_batches
from tmakit.montecarlo import monte_carlo, study
from tmakit.observation import ObservationModel
from tmakit.observation.varpro_compiled import evaluate_batch, plan_for


def _points(problem, theta0, batch, spread, seed=0):
    rng = np.random.default_rng(seed)
    scale = np.maximum(np.abs(theta0), 10.0) * spread
    return theta0 + rng.standard_normal((batch, theta0.size)) * scale


def _both(problem, meas, theta, with_jacobian=True):
    """The NumPy path's evaluation and J'J, J'r; the kernel's evaluation."""
    y = np.broadcast_to(problem.group(meas.value_si), (theta.shape[0], len(meas)))
    nu_star = problem.reference_nuisance(y)
    u = problem.data_part(y, nu_star)
    with compiled_batches(False):
        plain = problem.evaluate_part(theta, u, nu_star, with_jacobian)
    with compiled_batches(True):
        fast = problem.evaluate_part(theta, u, nu_star, with_jacobian)
    return plain, fast


def _assert_equal_to_rounding(plain, fast, with_jacobian=True):
    def close(a, b, what):
        if a.size == 0:  # (no nuisance)
            assert b.size == 0, what
            return
        scale = max(np.max(np.abs(a)), 1e-300)
        assert np.max(np.abs(a - b)) <= 1e-9 * scale, what

    assert plain.jacobian is not None or not with_jacobian  # the NumPy path holds J
    close(plain.residual, fast.residual, "residual")
    close(plain.nuisance, fast.nuisance, "nuisance")
    close(plain.cost, fast.cost, "cost")
    if with_jacobian:
        assert fast.jacobian is None and fast.normal is not None  # the kernel's J'J, J'r
        jt = plain.jacobian.swapaxes(1, 2)
        close(jt @ plain.jacobian, fast.normal[0], "J'J")
        close((jt @ plain.residual[:, :, None])[..., 0], fast.normal[1], "J'r")


def _truth(scn, motion):
    return np.array([scn.truth[n] for n in motion.param_names])


@pytest.mark.parametrize("name", ["gu2007", "hurtado2008", "bearings-only-2d",
                                  "doppler-lecture"])
@pytest.mark.parametrize("with_jacobian", [True, False])
def test_kernel_equals_the_numpy_path_on_the_scenarios(name, with_jacobian):
    scn = tk.load_scenario(name)
    meas = scn.simulate(np.random.default_rng(4))
    obs = ObservationModel(meas, scn.motion, scn.measurement_options)
    problem = VarProProblem(obs)
    theta = _points(problem, _truth(scn, scn.motion), 9, 0.3)
    plain, fast = _both(problem, meas, theta, with_jacobian)
    _assert_equal_to_rounding(plain, fast, with_jacobian)


def test_kernel_with_known_nuisance():
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(np.random.default_rng(5))
    obs = ObservationModel(meas, scn.motion, scn.measurement_options)
    problem = VarProProblem(obs, fixed_nuisance=obs.nuisance_vector(scn.nuisance) * 1.001)
    plain, fast = _both(problem, meas, _points(problem, _truth(scn, scn.motion), 6, 0.2))
    _assert_equal_to_rounding(plain, fast)


def _three_d_set(rng):
    """Bearing, elevation, range and power rows from a climbing, turning sensor (3-D)."""
    kinds = ["bearing", "elevation", "range", "power", "range_rate"]
    t = np.repeat(np.arange(40.0) * 3.0, len(kinds))
    kind = np.tile(kinds, 40)
    sensor = np.stack([400.0 * np.sin(t / 30.0), 300.0 * np.cos(t / 40.0), 100.0 + 2.0 * t,
                       40.0 / 3.0 * np.cos(t / 30.0), -7.5 * np.sin(t / 40.0),
                       np.full(t.size, 2.0)], axis=1)
    sigma = np.select([kind == "range", kind == "power", kind == "range_rate"],
                      [5.0, 1.0, 0.5], 0.01)
    motion = tk.ConstantVelocity(3, ref_time=60.0)
    theta = np.array([3000.0, 4000.0, 20.0, -5.0, 8.0, 0.0])
    blank = tk.MeasurementSet.from_si(t, ["uav"] * t.size, kind, np.zeros(t.size), sigma,
                                      sensor)
    obs = ObservationModel(blank, motion)
    values = obs.predict(theta, obs.nuisance_vector({"power_constant_db": -40.0}))
    values += sigma * rng.standard_normal(t.size)
    meas = tk.MeasurementSet.from_si(t, ["uav"] * t.size, kind, values, sigma, sensor)
    return meas, motion, theta


def test_kernel_in_3d_with_every_point_kind_mixed():
    meas, motion, theta0 = _three_d_set(np.random.default_rng(6))
    problem = VarProProblem(ObservationModel(meas, motion))
    assert plan_for(problem.obs, problem.noise.inv_sigma, problem.const_design) is not None
    plain, fast = _both(problem, meas, _points(problem, theta0, 7, 0.2))
    _assert_equal_to_rounding(plain, fast)


def test_kernel_for_a_stationary_emitter():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(7))
    motion = tk.Stationary(2)
    problem = VarProProblem(ObservationModel(meas, motion))
    plain, fast = _both(problem, meas, _points(problem, np.array([5e3, 5e3]), 5, 0.5))
    _assert_equal_to_rounding(plain, fast)


@pytest.mark.parametrize("name, options", [
    ("gu2007", {"frequency": {"drift": True}}),  # two columns in one kind
    ("gu2007", {"power": {"exponent": None}}),
    ("chen-sun-1", {}),  # range differences: correlated noise, reference samples
])
def test_kernel_does_not_apply_where_its_formulas_do_not(name, options):
    scn = tk.load_scenario(name)
    meas = scn.simulate(np.random.default_rng(8))
    problem = VarProProblem(ObservationModel(meas, scn.motion, options))
    inv = None if problem.noise.correlated else problem.noise.inv_sigma
    assert plan_for(problem.obs, inv, problem.const_design) is None
    theta = _points(problem, _truth(scn, scn.motion), 3, 0.1)
    plain, fast = _both(problem, meas, theta)  # both on the NumPy path: the same bits
    assert fast.jacobian is not None
    assert np.array_equal(plain.residual, fast.residual)


def test_an_angle_more_than_a_turn_out_is_left_to_the_numpy_path():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(9))
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    theta = _points(problem, _truth(scn, scn.motion), 3, 0.1)
    y = np.array(np.broadcast_to(problem.group(meas.value_si), (3, len(meas))))
    y[1, 17] += 20.0  # three turns and more out
    plan = plan_for(problem.obs, problem.noise.inv_sigma, problem.const_design)
    with compiled_batches(True):
        assert evaluate_batch(plan, theta, y, np.zeros((3, 0)), False, True) is None
        fast = problem.evaluate_part(theta, y, np.zeros((3, 0)))
    with compiled_batches(False):
        plain = problem.evaluate_part(theta, y, np.zeros((3, 0)))
    assert np.array_equal(plain.residual, fast.residual)
    assert -np.pi < plain.residual[1, 17] * 0.01 <= np.pi  # wrapped (sigma 0.01 rad)


def test_outside_a_study_every_batch_takes_the_numpy_path():
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(np.random.default_rng(10))
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    plain, _ = _both(problem, meas, _points(problem, _truth(scn, scn.motion), 200, 0.1))
    auto = problem.evaluate_part(plain.theta, *_data(problem, meas, 200))
    assert auto.jacobian is not None  # the NumPy path, bit for bit
    assert np.array_equal(auto.residual, plain.residual)


def _data(problem, meas, batch):
    y = np.broadcast_to(problem.group(meas.value_si), (batch, len(meas)))
    nu_star = problem.reference_nuisance(y)
    return problem.data_part(y, nu_star), nu_star


def test_a_large_study_asks_for_the_kernel_everywhere(monkeypatch):
    """The choice is the study's: one process and a pool of workers give the same table, for
    any chunk size, and it agrees with the NumPy path's to rounding."""
    scn = tk.load_scenario("gu2007")
    plain = monte_carlo(scn, runs=30, rng=3, progress=False, chunk=10)
    monkeypatch.setattr(study, "COMPILED_WORK", 1)
    here = monte_carlo(scn, runs=30, rng=3, progress=False, chunk=10)
    pool = monte_carlo(scn, runs=30, rng=3, progress=False, chunk=7, workers=2)
    assert here.table.equals(pool.table)
    assert (here.table["status"] == plain.table["status"]).all()
    assert (here.table["starts"] == plain.table["starts"]).all()
    for col in ("chi2", "est_x", "est_y", "est_vx", "est_vy"):
        np.testing.assert_allclose(here.table[col], plain.table[col], rtol=1e-8, atol=1e-9)


def test_the_kernel_gives_the_same_bits_wherever_its_arrays_lie():
    """Same inputs, same bits, call after call, however the allocator places the scratch
    arrays (with reassociated sums they came out 1 ulp apart in a few calls of 300)."""
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(np.random.default_rng(11))
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    theta = _points(problem, _truth(scn, scn.motion), 30, 0.05)
    u, nu_star = _data(problem, meas, 30)
    plan = plan_for(problem.obs, problem.noise.inv_sigma, problem.const_design)
    with compiled_batches(True):
        problem.evaluate_part(theta[:1], u[:1], nu_star[:1])  # (loads the kernel)
    first = evaluate_batch(plan, theta, u, nu_star, True, True)
    rng, held = np.random.default_rng(0), []
    for _ in range(300):
        held.append(np.empty(int(rng.integers(1, 5000))))  # moves what is allocated next
        if len(held) > 20:
            held.pop(int(rng.integers(0, len(held))))
        again = evaluate_batch(plan, theta, u, nu_star, True, True)
        assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
