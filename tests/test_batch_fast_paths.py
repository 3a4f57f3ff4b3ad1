"""The shortcuts of the no-guess fit and of the solver give what the plain computations give.

- the information at a fit taken from the solver's last evaluation equals the information
  evaluated again at the fit (no nuisance, known nuisance), and is not used where the nuisance
  is eliminated or the fit was mirrored;
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch import VarProProblem
from tmakit.batch.ml import solve_without_guess
from tmakit.batch.solver import information_of, levenberg_marquardt
from tmakit.results.estimate import assemble_result


def _bearings(n: int, seed: int) -> tuple[tk.Scenario, tk.MeasurementSet]:
    scn = tk.load_scenario("bearings-only-2d")
    lo, hi = scn.time_span()
    plans = [dataclasses.replace(p, times=np.linspace(lo, hi, n)) for p in scn.plans]
    scn = dataclasses.replace(scn, plans=plans)
    return scn, scn.simulate(np.random.default_rng(seed))


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


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_guess_fit_reports_the_information_at_its_estimate(seed):
    scn, meas = _bearings(3000, seed)
    res = tk.estimate(meas, scn.motion)
    obs = tk.ObservationModel(meas, scn.motion)
    problem = VarProProblem(obs)
    best = solve_without_guess(problem, meas.value_si[None])[0]
    assert best is not None and best.information is not None
    plain = assemble_result(obs, problem.noise, res.estimate, np.zeros(0), res.chi2 / 2,
                            res.iterations, True, "ml", 1, None)
    np.testing.assert_allclose(res.covariance, plain.covariance, rtol=1e-9)
    np.testing.assert_allclose(res.std, plain.std, rtol=1e-9)
