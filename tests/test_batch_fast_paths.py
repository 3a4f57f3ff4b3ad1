"""The shortcuts of the no-guess fit and of the solver give what the plain computations give.

- the information at a fit taken from the solver's last evaluation equals the information
  evaluated again at the fit (no nuisance, known nuisance), and is not used where the nuisance
  is eliminated;
- one run's Gauss-Newton model (LAPACK ``dsyevd`` called directly, 2-D products) equals the
  batched model (NumPy's ``eigh``) on well-conditioned, ill-conditioned and rank-deficient
  Jacobians: eigenvalues, decrement, steps and predicted decreases;
- one run's damping update in floats equals the batched update;
- a singular problem is still reported honestly (unobservable, finite estimate);
- the residual wrapping of the solver equals ``frames.wrap_angle`` bit for bit, within one
  turn (where it shifts by hand), at the boundaries and beyond (where it hands over).
"""

from __future__ import annotations

import numpy as np
import pytest
from bearing_sets import scenario_rows

import tmakit as tk
from tmakit.batch import VarProProblem, solver
from tmakit.batch.ml import solve_without_guess
from tmakit.batch.solver import GaussNewtonModel, information_of, levenberg_marquardt
from tmakit.batch.varpro import Evaluation, _wrap_own
from tmakit.core.frames import wrap_angle
from tmakit.results.estimate import assemble_result


@pytest.mark.parametrize("known", [False, True])
def test_information_from_the_last_evaluation_is_the_information_at_the_fit(known):
    gu = tk.load_scenario("gu2007")
    meas = gu.simulate(3)
    obs = tk.ObservationModel(meas, gu.motion, gu.measurement_options)
    fixed = obs.nuisance_vector(gu.nuisance) if known else None
    problem = VarProProblem(obs, None, fixed)
    sol = levenberg_marquardt(problem, meas.value_si, gu.theta[None])
    info = information_of(problem, sol.evaluation, 0)
    if not known:  # eliminated nuisance: the projected Jacobian is not the information
        assert info is None
        return
    plain = assemble_result(obs, problem.noise, sol.theta[0], sol.nuisance[0],
                            float(sol.cost[0]), 1, True, "ml", 1, tk.KnownNuisance(gu.nuisance))
    assert plain.bound is not None
    np.testing.assert_allclose(info, plain.bound.information, rtol=1e-10)
    # the solver's own J'J at its converged point (formed for the convergence test)
    assert sol.converged[0] and sol.information is not None
    kept = information_of(problem, sol.evaluation, 0, sol.information)
    np.testing.assert_allclose(kept, plain.bound.information, rtol=1e-10)
    two = levenberg_marquardt(problem, np.stack([meas.value_si] * 2), np.stack([gu.theta] * 2))
    np.testing.assert_allclose(two.information[1], plain.bound.information, rtol=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_guess_fit_reports_the_information_at_its_estimate(seed):
    scn, meas = scenario_rows(3000, seed)
    res = tk.estimate(meas, scn.motion)
    obs = tk.ObservationModel(meas, scn.motion)
    problem = VarProProblem(obs)
    best = solve_without_guess(problem, meas.value_si[None])[0]
    assert best is not None and best.information is not None
    plain = assemble_result(obs, problem.noise, res.estimate, np.zeros(0), res.chi2 / 2,
                            res.iterations, True, "ml", 1, None)
    np.testing.assert_allclose(res.covariance, plain.covariance, rtol=1e-9)
    np.testing.assert_allclose(res.std, plain.std, rtol=1e-9)


def _jacobian(kind: str, rng: np.random.Generator) -> np.ndarray:
    j = rng.normal(size=(200, 5))
    if kind == "ill-conditioned":  # columns nearly dependent, scales 1e-4 .. 1e4
        j[:, 4] = j[:, 3] + 1e-9 * rng.normal(size=200)
        j *= np.logspace(-4, 4, 5)
    elif kind == "rank-deficient":  # two columns copies of others
        j[:, 4] = j[:, 1]
        j[:, 2] = -2.0 * j[:, 0]
    return j


@pytest.mark.parametrize("kind", ["well-conditioned", "ill-conditioned", "rank-deficient"])
def test_one_run_model_equals_the_batched_model(kind):
    rng = np.random.default_rng(7)
    j = _jacobian(kind, rng)
    r = rng.normal(size=200)
    cost = np.array([0.5 * r @ r])

    def evaluation(b):
        return Evaluation(np.zeros((b, 5)), np.zeros((b, 0)), np.tile(r, (b, 1)),
                          np.repeat(cost, b), np.tile(j, (b, 1, 1)))

    one = GaussNewtonModel.at(evaluation(1), 1e-10, None)
    two = GaussNewtonModel.at(evaluation(2), 1e-10, None)  # a batch: NumPy's eigh
    np.testing.assert_allclose(one.w[0], two.w[0], rtol=1e-9, atol=1e-12 * two.w[0, -1])
    np.testing.assert_allclose(one.decrement[0], two.decrement[0], rtol=1e-7)
    assert one.small_grad[0] == two.small_grad[0]
    for lam in (1e-8, 1e-3, 1.0, 1e3):
        s1, p1 = one.step(np.array([lam]))
        s2, p2 = two.step(np.array([lam, lam]))
        assert np.all(np.isfinite(s1))
        np.testing.assert_allclose(s1[0], s2[0], rtol=1e-6, atol=1e-9 * np.abs(s2[0]).max())
        np.testing.assert_allclose(p1[0], p2[0], rtol=1e-7)


def test_one_run_damping_equals_the_batched_damping():
    rng = np.random.default_rng(3)
    rules = solver._Rules(1e-10, 1e-12, 1e-10, 1e-5, None, "nielsen", None, 0.0, (10.0, 1.0))
    for _ in range(200):
        cost, predicted = 10.0, 10.0 ** rng.uniform(-3, 1)
        trial = cost - predicted * rng.uniform(-2.0, 1.5)
        lam, grow = 10.0 ** rng.uniform(-12, 6), 2.0 ** rng.integers(1, 5)
        runs = [type("R", (), {"lam": np.array([lam]), "grow": np.array([grow])})()
                for _ in range(2)]
        better = trial < cost
        solver._damp_one(runs[0], better, cost, trial, predicted)
        solver._damp(runs[1], np.array([better]),
                     np.minimum((cost - trial) / np.maximum([predicted], 1e-300), 1.0), rules)
        np.testing.assert_allclose(runs[0].lam, runs[1].lam, rtol=1e-12)
        np.testing.assert_array_equal(runs[0].grow, runs[1].grow)


def test_a_singular_problem_is_reported_unobservable():
    # One sensor at rest and bearings only: the range of a constant-velocity target is not
    # determined, J'J is singular.
    scn, _ = scenario_rows(200, 0)
    meas = scn.simulate(np.random.default_rng(5))
    state = meas.sensor_state.copy()
    state[:] = state[0]
    state[:, 3:] = 0.0
    still = meas.take(np.arange(len(meas)))
    still.sensor_state = state
    obs = tk.ObservationModel(still, scn.motion)
    problem = VarProProblem(obs)
    sol = levenberg_marquardt(problem, still.value_si, scn.theta[None], max_iter=30)
    assert np.all(np.isfinite(sol.theta)) and np.isfinite(sol.cost[0])
    res = tk.estimate(still, scn.motion, init=scn.theta)
    assert res.status == "unobservable"
    assert np.all(np.isfinite(res.estimate))


@pytest.mark.parametrize("scale", [1e-9, 1.0, 3.0, 6.0, 9.0, 30.0])
def test_residual_wrapping_is_wrap_angle_bit_for_bit(scale):
    rng = np.random.default_rng(11)
    turn = 2.0 * np.pi
    edges = [np.pi, -np.pi, 0.0, -0.0, turn, 3 * np.pi, -3 * np.pi, 5e-324, -1e-17,
             np.nextafter(3 * np.pi, 0.0), np.nextafter(-3 * np.pi, 0.0),
             np.nextafter(np.pi, 0.0), np.nextafter(-np.pi, -4.0)]
    for _ in range(100):
        e = rng.uniform(-1.0, 1.0, size=(2, 40)) * scale
        e[0, :len(edges)] = edges
        got, want = _wrap_own(e.copy()), wrap_angle(e.copy())
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(want))
    np.testing.assert_array_equal(_wrap_own(np.zeros((1, 0))), np.zeros((1, 0)))
    for c in (-3 * np.pi, -np.pi, np.pi, 3 * np.pi):  # every float near the boundaries
        e = (c + np.arange(-500, 500) * np.spacing(c))[None]
        np.testing.assert_array_equal(_wrap_own(e.copy()), wrap_angle(e.copy()))
