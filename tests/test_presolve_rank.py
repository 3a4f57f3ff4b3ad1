"""The presolve on a subset of rows where that subset barely sees the range.

Bearings from an observer that turns by 4 degrees once in 600 s: the whole set of 20,001
rows determines the range, the presolve's subset of 2,000 rows hardly does.

* At 5 deg noise the subset's fit runs off to 10^7 m, its information rank deficient; taken
  as the start of the whole set's solve, that point left the fit on the plateau far out
  (``unobservable`` 1,000 km out, chi2 up by 0.7) where the fit on every row converges.
* At 3 deg the subset's optimum is sound but the full Gauss-Newton step from it (the subset
  step) raises the cost 3,500-fold; the solve took 27 iterations from there, not 8.
"""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch import ml
from tmakit.results.observability import full_rank
from tmakit.scenario.files import scenario_from_dict


def _weak_turn(n: int, sigma: float = 3.0) -> tk.Scenario:
    data = {
        "name": "weak-turn",
        "target": {"motion": "cv2d", "ref_time": 0.0,
                   "truth": {"x": 4000.0, "y": 9000.0, "vx": -6.0, "vy": -3.0}},
        "sensors": [{"type": "legs", "id": "observer", "start": [0.0, 0.0],
                     "heading_deg": 45.0, "speed": 8.0,
                     "legs": [{"duration": 290.0},
                              {"duration": 20.0, "turn_rate_deg_s": 0.2},
                              {"duration": float("inf")}]}],
        "measurements": [{"kind": "bearing", "sensor": "observer",
                          "times": {"start": 1.0, "stop": 600.0,
                                    "step": 599.0 / (n - 1)},
                          "sigma": sigma}],
    }
    return scenario_from_dict(data)


def test_subset_blind_to_the_range_leaves_the_start(monkeypatch) -> None:
    scn = _weak_turn(20_001, 5.0)
    meas = scn.simulate(np.random.default_rng(8))
    assert len(meas.time) > ml.PRESOLVE_ROWS
    fit = tk.estimate(meas, scn.motion)
    monkeypatch.setattr(ml, "PRESOLVE_ROWS", 10**9)  # grid and solve on every row
    plain = tk.estimate(meas, scn.motion)
    assert plain.status == "converged"
    assert fit.status == plain.status
    assert fit.chi2 == pytest.approx(plain.chi2, abs=1e-2)
    assert np.all(np.abs(fit.estimate - plain.estimate) <= 0.05 * plain.std)


def test_full_rank_is_the_observability_rank_test() -> None:
    info = np.array([[[4.0, 0.0], [0.0, 1e-6]],   # badly scaled, full rank
                     [[1.0, 1.0], [1.0, 1.0]],    # rank 1
                     [[1.0, 0.0], [0.0, 0.0]]])   # a zero column
    np.testing.assert_array_equal(full_rank(info), [True, False, False])


def test_a_subset_step_that_raises_the_cost_is_not_taken(monkeypatch) -> None:
    # Where the subset barely sees the range, the full Gauss-Newton step from its optimum
    # can raise the cost: the solve then starts at the subset's optimum, as without the step.
    scn = _weak_turn(20_001)
    meas = scn.simulate(np.random.default_rng(0))
    taken = []
    step = ml.subset_step

    def spy(problem, ys, theta, information):
        out = step(problem, ys, theta, information)
        if out is not None:
            y = problem.group(ys)
            u = problem.data_part(y, problem.reference_nuisance(y))
            after = problem.evaluate_part(out[0], u, np.zeros((1, 0)), False).cost[0]
            taken.append(after > out[1])
        return out

    monkeypatch.setattr(ml, "subset_step", spy)
    fit = tk.estimate(meas, scn.motion)
    assert taken == [True]  # (this set's step raises the cost)
    monkeypatch.setattr(ml, "subset_step", lambda *args: None)
    without = tk.estimate(meas, scn.motion)
    # the same path from the same point: equal to rounding (bit for bit on the NumPy path;
    # the compiled kernel's reassociated sums depend on the arrays' alignment)
    np.testing.assert_allclose(fit.estimate, without.estimate, rtol=1e-9)
    np.testing.assert_allclose(fit.covariance, without.covariance, rtol=1e-6)
    assert fit.iterations == without.iterations + 1  # (the step tried)
