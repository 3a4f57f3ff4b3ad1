"""The fast paths of the manoeuvre estimator make the same choices as plain computations.

The batched piecewise-curvilinear model (states and derivatives in one pass, the chain rule
segment by segment) against the general model on every row layout; the profile of the
change-over time against a plain search (each grid time fitted alone, to convergence, no
pruning); the acceleration hold chosen by the backward elimination against a plain one.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import tmakit as tk
import tmakit.batch.manoeuvre as search_mod
from tmakit.batch.manoeuvre import (
    ManoeuvreSearch,
    ManoeuvreSettings,
    hold_starts,
    lm_fit,
    may_hold,
    split_segment,
)
from tmakit.motion import PiecewiseCurvilinear
from tmakit.motion.curvilinear import ForwardPiecewise


@pytest.mark.parametrize("layout", ["by kind", "interleaved", "unsorted"])
def test_batched_chain_equals_the_general_model_on_every_row_layout(layout):
    rng = np.random.default_rng(1)
    scn = tk.load_scenario("hoerst2010")
    theta = np.tile(np.concatenate([scn.theta[:8], [0.0, 0.0], scn.theta[8:], [700.0]]),
                    (3, 1))
    theta[:, 4:12] += 0.01 * rng.normal(size=(3, 8))
    times = np.arange(0.0, 901.0, 5.0)
    times[40] = theta[0, 12]  # a sample on a change-over time: the earlier segment's
    t = {"by kind": np.concatenate([times, times]),
         "interleaved": np.repeat(times, 2),
         "unsorted": rng.permutation(np.concatenate([times, times]))}[layout]
    fast, general = ForwardPiecewise(3, 0.0), PiecewiseCurvilinear(3, 0.0)
    d = rng.normal(size=(3, t.size, 6))
    np.testing.assert_allclose(fast.states(theta, t), general.states(theta, t), rtol=0,
                               atol=1e-6)
    expected = np.einsum("bni,bnip->bnp", d, general.jacobian(theta, t))
    got = fast.chain(d, theta, t)  # from the derivatives kept by states()
    scale = np.abs(expected).max(axis=1, keepdims=True)
    np.testing.assert_allclose(got / scale, expected / scale, rtol=0, atol=1e-9)
    fresh = ForwardPiecewise(3, 0.0).chain(d, theta, t)  # no states() call before
    np.testing.assert_array_equal(fresh, got)


@pytest.fixture(scope="module")
def small():
    """hoerst2010 (one turn from 400 s to 600 s) thinned to every 6th second: a quick case."""
    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=np.random.default_rng(5))
    keep = np.flatnonzero(meas.time % 6.0 == 0.0)
    return ManoeuvreSearch(meas.take(keep), None, None,
                           ManoeuvreSettings(max_manoeuvres=1, grid_step=60.0))


def test_profile_chooses_the_grid_time_of_a_plain_search(small):
    zero = small.fit_zero()
    tuples, _, cost = small.profile(1)
    pr = small.problem(1)
    free = np.ones(pr.p, dtype=bool)
    free[-1] = False
    plain = []
    for g in small.grid[tuples[:, 0]]:  # each grid time alone, to convergence, no pruning
        start = split_segment(zero.theta[None], 0, 0, np.array([g]))
        plain.append(lm_fit(pr, start, free, 300, rtol=1e-12, atol=1e-9).cost[0])
    plain = np.array(plain)
    assert int(np.argmin(cost)) == int(np.argmin(plain))
    assert cost.min() == pytest.approx(plain.min(), abs=0.05)
    assert np.all(cost >= plain - 0.05)  # pruned fits stop above their minimum, never below


def test_backward_elimination_holds_what_a_plain_search_holds(small):
    fit = small.fit(1, small.fit_zero())
    pr = small.problem(1)
    free = fit.free_mask()
    best = search_mod._best_hold(small, fit, free, np.log(pr.noise.rank))
    plain = {}
    for i in range(4, 8):
        if free[i] and may_hold(free, i, 1):
            mask = free.copy()
            mask[i] = False
            sol = lm_fit(pr, hold_starts(small, fit.theta, i, 1), mask, 300, rtol=1e-12,
                         atol=1e-9)
            plain[i] = 2.0 * float(np.min(sol.cost))
    assert best is not None
    assert best[1] == min(plain, key=plain.get)
    # the ranking fits stop early (30 steps, chi2 to ~0.1): above the plain minimum, close to it
    assert plain[best[1]] - 1e-6 <= best[0] <= plain[best[1]] + 0.5
    others = [v for i, v in plain.items() if i != best[1]]
    assert not others or min(others) > best[0]


def _unpruned(monkeypatch):
    """Make the search's pruned fits (``prune=0``: stop what cannot beat a cost) run in full."""
    def plain(problem, theta0, free, max_iter, **kw):
        if kw.get("prune") == 0.0:
            kw["prune"], kw["best"] = None, np.inf
        return lm_fit(problem, theta0, free, max_iter, **kw)

    monkeypatch.setattr(search_mod, "lm_fit", plain)


def test_pruned_corner_probes_settle_as_the_full_probes_do(small, monkeypatch):
    fit = small.fit_from(1, small.fit(1, small.fit_zero()).theta[None])
    fit.theta[-1] += 7.0  # off its minimum: the probes find a better change-over time
    pruned = copy.deepcopy(fit)
    small.settle(pruned)
    _unpruned(monkeypatch)
    full = copy.deepcopy(fit)
    small.settle(full)
    assert pruned.converged == full.converged and pruned.note == full.note
    assert pruned.chi2 == pytest.approx(full.chi2, abs=1e-6)
    np.testing.assert_allclose(pruned.theta[-1], full.theta[-1], atol=1e-6)


def test_pruned_finer_profile_polishes_as_the_full_one_does(small, monkeypatch):
    fit = small.fit_from(1, small.fit(1, small.fit_zero()).theta[None])
    fit.theta[-1] += 30.0  # a dip next to the deepest one
    fit = small.fit_from(1, fit.theta[None], np.r_[np.ones(8, bool), False])
    fit.free = None
    pruned = small.polish(copy.deepcopy(fit))
    _unpruned(monkeypatch)
    full = small.polish(copy.deepcopy(fit))
    assert pruned.chi2 == pytest.approx(full.chi2, abs=1e-6)
    np.testing.assert_allclose(pruned.theta[-1], full.theta[-1], atol=1e-6)
    assert pruned.chi2 <= fit.chi2
