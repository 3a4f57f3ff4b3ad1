"""Correlated range differences of many rows: every start on a subset, one over all rows."""

from __future__ import annotations

import numpy as np
import pytest
from test_correlated_chunks import shared_reference_set

import tmakit as tk
from tmakit.batch import ml as subset_first


def test_a_large_correlated_fit_carries_one_start_and_finds_the_same_estimate(monkeypatch):
    meas = shared_reference_set()  # 201 rows, range differences in correlated threes
    whole = tk.estimate(meas, "cv3d")  # every start over every row
    monkeypatch.setattr(subset_first, "SUBSET_FIRST_ROWS", 100)  # these rows count as many
    monkeypatch.setattr(subset_first, "SUBSET_ROWS", 60)
    carried = []
    solve = subset_first.levenberg_marquardt

    def spy(problem, y, theta0, **kw):
        carried.append((len(problem.obs.meas), np.shape(theta0)[0]))
        return solve(problem, y, theta0, **kw)

    monkeypatch.setattr(subset_first, "levenberg_marquardt", spy)
    sub = tk.estimate(meas, "cv3d")
    # (the spy sees the subset's solves too) one start over every row, once
    assert [c for c in carried if c[0] == len(meas)] == [(len(meas), 1)]
    assert {c[0] for c in carried} == {60, len(meas)}  # every other solve on the subset
    assert whole.status == sub.status == "converged"
    assert whole.starts > 12  # the whole set was not settled on its first start
    # the same optimum to the solver's tolerance (a decrement of 1e-5 in half chi2 is
    # about 0.0045 standard deviations)
    assert np.all(np.abs(sub.estimate - whole.estimate) <= 5e-3 * whole.std)
    np.testing.assert_allclose(sub.std, whole.std, rtol=1e-4)
    assert sub.chi2 == pytest.approx(whole.chi2, abs=4e-5)


def test_a_subset_is_never_solved_on_a_subset_again(monkeypatch):
    from tmakit.batch.varpro import VarProProblem
    from tmakit.motion import motion_from_name
    from tmakit.observation import ObservationModel

    problem = VarProProblem(ObservationModel(shared_reference_set(), motion_from_name("cv3d")))
    monkeypatch.setattr(subset_first, "SUBSET_FIRST_ROWS", 10)
    monkeypatch.setattr(subset_first, "SUBSET_ROWS", 150)
    assert not subset_first.subset_first(problem)  # 201 rows: not twice the subset's
    monkeypatch.setattr(subset_first, "SUBSET_ROWS", 60)
    assert subset_first.subset_first(problem)
