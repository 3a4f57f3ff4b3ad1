"""The no-guess fit of many rows takes its first full-size step with the subset's ``J'J``.

From the presolve's optimum on a subset of rows, ``ml.subset_step`` takes the
Gauss–Newton step on every row from the whole set's gradient ``J'r`` alone
(``ml.gradient_at``, no Jacobian formed) and the subset's ``J'J`` scaled to every
row.  The gradient must be the one of the full evaluation; the scaled ``J'J`` must be close to
the whole set's; and the fit must reach the optimum it reaches without the step, with one
full-size Jacobian fewer.
"""

from __future__ import annotations

import collections

import numpy as np
import pytest
from bearing_sets import scenario_rows

import tmakit as tk
from tmakit.batch import ml
from tmakit.batch.init import GridSettings
from tmakit.batch.solver import normal_equations
from tmakit.batch.varpro import VarProProblem


@pytest.fixture(scope="module")
def large() -> tuple[tk.Scenario, tk.MeasurementSet]:
    return scenario_rows(60_000, 3)


def _data_part(problem: VarProProblem, meas: tk.MeasurementSet) -> np.ndarray:
    y = problem.group(meas.value_si[None])
    return problem.data_part(y, problem.reference_nuisance(y))


def test_gradient_alone_is_the_full_evaluations(large) -> None:
    scn, meas = large
    problem = VarProProblem(tk.ObservationModel(meas, scn.motion))
    u = _data_part(problem, meas)
    theta = (scn.theta * 1.002 + 5.0)[None]
    cost, grad = ml.gradient_at(problem, theta, u)
    full = problem.evaluate_part(theta, u, np.zeros((1, 0)))
    want = normal_equations(full, None)[1][0]  # (J'r of the Jacobian or of the compiled sums)
    np.testing.assert_allclose(grad, want, rtol=1e-10, atol=1e-12 * np.abs(want).max())
    assert cost == pytest.approx(float(full.cost[0]), rel=1e-12)


def test_gradient_alone_declines_what_it_does_not_handle(large) -> None:
    scn, meas = large
    problem = VarProProblem(tk.ObservationModel(meas, scn.motion))
    u = _data_part(problem, meas)
    two = np.stack([scn.theta, scn.theta * 1.01])
    assert ml.gradient_at(problem, two, np.vstack([u, u])) is None  # a batch of points
    gu = tk.load_scenario("gu2007")  # frequency and power: nuisance eliminated
    m = gu.simulate(np.random.default_rng(0))
    other = VarProProblem(tk.ObservationModel(m, gu.motion))
    assert ml.gradient_at(other, gu.theta[None], _data_part(other, m)) is None


def test_subset_information_scaled_is_the_whole_sets(large) -> None:
    scn, meas = large
    problem = VarProProblem(tk.ObservationModel(meas, scn.motion))
    ys = meas.value_si[None]
    subset = ml.presolve_subset(problem)
    start = ml.grid_starts(problem, ys, GridSettings(), subset)[0].first(1)
    theta, near, information = ml.presolve(problem, ys, start, 100, subset)
    assert near
    full = normal_equations(problem.evaluate_part(theta, _data_part(problem, meas),
                                                  np.zeros((1, 0))), None)[0][0]
    scale = np.sqrt(np.outer(np.diag(full), np.diag(full)))
    assert np.max(np.abs(information[0] - full) / scale) < 1e-2
    stepped, cost = ml.subset_step(problem, ys, theta, information)
    assert cost == ml.gradient_at(problem, theta, _data_part(problem, meas))[0]
    # the step lands where the exact Gauss-Newton step would: within the polishing range
    jtj, jtr = normal_equations(problem.evaluate_part(stepped, _data_part(problem, meas),
                                                      np.zeros((1, 0))), None)
    g = jtr[0]
    assert 0.5 * g @ np.linalg.solve(jtj[0], g) < ml.POLISH_DECREMENT


def test_fit_with_the_subset_step_is_the_fit_without(large, monkeypatch) -> None:
    scn, meas = large
    counts: collections.Counter = collections.Counter()
    evaluate, gradient = VarProProblem._evaluate_any, ml.gradient_at

    def counted(self, theta, u, nu_star, with_jacobian, spare=None):
        if u.shape[-1] > ml.PRESOLVE_ROWS:
            counts["jacobian" if with_jacobian else "residuals"] += 1
        return evaluate(self, theta, u, nu_star, with_jacobian, spare)

    def counted_gradient(problem, theta, u):
        counts["gradient"] += 1
        return gradient(problem, theta, u)

    monkeypatch.setattr(VarProProblem, "_evaluate_any", counted)
    monkeypatch.setattr(ml, "gradient_at", counted_gradient)
    stepped = tk.estimate(meas, scn.motion)
    assert counts == {"gradient": 1, "jacobian": 1, "residuals": 1}  # (either path)
    monkeypatch.setattr(ml, "subset_step", lambda *args: None)
    counts.clear()
    plain = tk.estimate(meas, scn.motion)
    assert counts["jacobian"] == 2
    assert stepped.status == plain.status == "converged"
    # the same optimum, to the convergence test's 4.5e-3 standard deviations
    assert np.all(np.abs(stepped.estimate - plain.estimate) <= 5e-3 * plain.std)
    np.testing.assert_allclose(stepped.covariance, plain.covariance, rtol=1e-2)
    assert stepped.chi2 == pytest.approx(plain.chi2, abs=1e-2)
    assert stepped.iterations == plain.iterations  # the step counted as one
