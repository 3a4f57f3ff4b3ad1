"""The no-guess fit of many rows ends with a Gauss–Newton step checked by its residuals alone.

``levenberg_marquardt(..., polish=d)`` (one run) stops, once the decrement is at most ``d``,
after one lightly damped step whose decrease agrees with the model's prediction, without a
Jacobian at the end.  What the user gets must be the optimum the solver reaches without it,
and a step that does not do what the model predicted must not stop the run.
"""

from __future__ import annotations

import collections
import dataclasses

import numpy as np
import pytest
from bearing_sets import scenario_rows

import tmakit as tk
from tmakit.batch import ml, solver
from tmakit.batch.solver import GaussNewtonModel, information_steady
from tmakit.batch.varpro import VarProProblem
from tmakit.observation import ObservationModel
from tmakit.observation.planar import planar_linearisation, planar_values


@pytest.fixture(scope="module")
def large() -> tuple[tk.Scenario, tk.MeasurementSet]:
    return scenario_rows(100_000, 5)


def _counting(monkeypatch: pytest.MonkeyPatch) -> collections.Counter:
    counts: collections.Counter = collections.Counter()
    evaluate = VarProProblem._evaluate_any

    def counted(self, theta, u, nu_star, with_jacobian, spare=None):
        if u.shape[-1] > ml.PRESOLVE_ROWS:
            counts["jacobian" if with_jacobian else "residuals"] += 1
        return evaluate(self, theta, u, nu_star, with_jacobian, spare)

    monkeypatch.setattr(VarProProblem, "_evaluate_any", counted)
    return counts


def test_polished_fit_is_the_fit_without_polish(large, monkeypatch) -> None:
    scn, meas = large
    counts = _counting(monkeypatch)
    polished = tk.estimate(meas, scn.motion)
    assert counts["residuals"] == 1  # it ended with a step checked by its residuals
    used = counts["jacobian"]
    monkeypatch.setattr(ml, "POLISH_DECREMENT", 0.0)
    counts.clear()
    full = tk.estimate(meas, scn.motion)
    assert counts["residuals"] == 0 and counts["jacobian"] == used + 1
    assert polished.status == full.status == "converged"
    # The same point: the polishing step is the step the solver takes next without polish.
    np.testing.assert_array_equal(polished.estimate, full.estimate)
    assert polished.chi2 == pytest.approx(full.chi2, rel=1e-12)  # (compiled sums: rounding)
    # The covariance is the one at the point the last step left (at most one standard
    # deviation away): the same to the relative size of a standard deviation.
    np.testing.assert_allclose(polished.covariance, full.covariance, rtol=5e-3)
    # And the point reported is a minimum: its own decrement is below the tolerance.
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    ev = problem.evaluate(polished.estimate[None], meas.value_si[None], np.zeros((1, 0)))
    assert float(GaussNewtonModel.at(ev, 1e-10, None).decrement[0]) < 1e-5


def test_a_step_the_model_does_not_predict_does_not_stop_the_run(large, monkeypatch) -> None:
    # No step agrees with its model exactly: every polishing trial is dropped, and the fit
    # goes on as without polish (one more Jacobian), to the same point.
    scn, meas = large
    tried = []
    polished = solver._polished

    def spy(problem, runs, rules):
        out = polished(problem, runs, rules)
        tried.append(out)
        return out

    monkeypatch.setattr(solver, "_polished", spy)
    monkeypatch.setattr(solver, "POLISH_AGREEMENT", 0.0)
    dropped = tk.estimate(meas, scn.motion)
    monkeypatch.setattr(ml, "POLISH_DECREMENT", 0.0)
    full = tk.estimate(meas, scn.motion)
    assert tried and not any(tried)
    assert dropped.status == full.status == "converged"
    np.testing.assert_array_equal(dropped.estimate, full.estimate)
    assert dropped.chi2 == full.chi2


def test_planar_values_are_the_planar_linearisation_values_bit_for_bit() -> None:
    scn, meas = scenario_rows(500, 1)
    obs = ObservationModel(meas, scn.motion)
    theta = scn.theta + np.array([100.0, -50.0, 0.5, -0.2])
    lin = planar_linearisation(obs, theta)
    values = planar_values(obs, theta)
    assert lin is not None and values is not None
    assert np.array_equal(values.h0, lin.h0)
    each = obs.linearisation(np.stack([theta, theta]), derivatives=False, each=True)
    assert np.array_equal(values.h0, each.h0[0])  # the general path, this point alone


def test_a_set_without_references_holds_no_memory_per_row_for_them() -> None:
    _, meas = scenario_rows(1000, 0)
    assert meas.time_ref.strides[0] == 0 and meas.ref_sensor_state.strides[0] == 0
    part = meas.take(np.arange(0, 1000, 7))
    assert part.ref_sensor_state.shape == (143, 6) and part.time_ref.shape == (143,)
    assert part.ref_sensor_state.strides[0] == 0
    assert np.isnan(part.ref_sensor_state).all() and np.isnan(part.time_ref).all()


def _weak_turn(sigma_deg: float, n: int) -> tk.Scenario:
    """``bearings-only-2d`` whose observer turns once by 4 deg: range barely observable."""
    import importlib.resources
    import tomllib

    from tmakit.scenario.files import scenario_from_dict

    text = (importlib.resources.files("tmakit.scenario") / "builtin"
            / "bearings-only-2d.toml").read_text()
    d = tomllib.loads(text)
    d["sensors"][0]["legs"] = [{"duration": 290.0}, {"duration": 20.0, "turn_rate_deg_s": 0.2},
                               {"duration": float("inf")}]
    d["measurements"][0]["sigma"] = sigma_deg
    scn = scenario_from_dict(d, "<weak turn>")
    lo, hi = scn.time_span()
    return dataclasses.replace(scn, plans=[dataclasses.replace(p, times=np.linspace(lo, hi, n))
                                           for p in scn.plans])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_weak_geometry_covariance_is_the_end_points(seed, monkeypatch) -> None:
    # J'J changes by tens of per cent per standard deviation here: a polishing step would
    # report the covariance of the point it left (7-36 % off on these seeds before the test
    # of how fast J'J changes); the covariance must be the one the fit without polish gives.
    scn = _weak_turn(5.0, 30_000)
    meas = scn.simulate(np.random.default_rng(seed))
    default = tk.estimate(meas, scn.motion)
    monkeypatch.setattr(ml, "POLISH_DECREMENT", 0.0)
    plain = tk.estimate(meas, scn.motion)
    assert default.status == plain.status == "converged"
    sd = np.sqrt(np.outer(np.diag(plain.covariance), np.diag(plain.covariance)))
    assert np.max(np.abs(default.covariance - plain.covariance) / sd) < 1e-2
    assert np.all(np.abs(default.estimate - plain.estimate) <= 1e-2 * plain.std)


def test_information_steady_asks_for_a_slowly_changing_jtj() -> None:
    jtj = np.array([[4.0, 1.0], [1.0, 3.0]])
    model = GaussNewtonModel(np.ones((1, 2)), np.eye(2)[None], np.zeros((1, 2)),
                             np.ones((1, 2)), np.array([0.01]), np.array([False]), jtj[None])

    here = np.array([1.0, 2.0])
    assert not information_steady(model, here, None, 0.01, None)  # no previous point
    back = here - np.array([0.5, 0.0])  # 1 std away in J'J's metric
    assert information_steady(model, here, (back, jtj * (1.0 - 1e-4)), 0.01, None)
    # J'J doubled over one standard deviation
    assert not information_steady(model, here, (back, jtj * 0.5), 0.01, None)
    # no move: no rate to extrapolate
    assert not information_steady(model, here, (here, jtj * 0.5), 0.01, None)
