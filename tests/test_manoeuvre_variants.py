"""Held variants fitted in one solver loop are the variants fitted one by one, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch.manoeuvre import ManoeuvreSearch, ManoeuvreSettings, variants
from tmakit.batch.manoeuvre.search import lm_fit
from tmakit.batch.manoeuvre.selection import hold_starts, may_hold
from tmakit.batch.manoeuvre.variants import HeldVariants, batched_fit
from tmakit.batch.solver import VarProProblem


@pytest.fixture(scope="module")
def fitted():
    """hoerst2010 thinned to every 6th second, its order-1 fit (every acceleration free)."""
    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=np.random.default_rng(8))
    keep = np.flatnonzero(meas.time % 6.0 == 0.0)
    search = ManoeuvreSearch(meas.take(keep), None, None,
                             ManoeuvreSettings(max_manoeuvres=1, grid_step=60.0))
    return search, search.fit(1, search.fit_zero())


def test_pack_and_unpack_put_every_parameter_back():
    rng = np.random.default_rng(0)
    free_sets = np.ones((3, 8), dtype=bool)
    free_sets[[0, 1, 2], [4, 7, 0]] = False
    held = HeldVariants(type("P", (), {"p": 8})(), free_sets)
    theta = rng.normal(size=(5, 8))
    variant = np.array([2, 0, 1, 1, 0])
    packed = held.pack(theta, variant)
    assert packed[0, -2] == theta[0, 0] and packed[1, -2] == theta[1, 4]
    np.testing.assert_array_equal(packed[2, :7], np.delete(theta[2], 7))
    back, v = held.unpack(packed)
    np.testing.assert_array_equal(back, theta)
    np.testing.assert_array_equal(v, variant)
    with pytest.raises(ValueError, match="as many"):
        HeldVariants(type("P", (), {"p": 8})(), np.array([[True] * 8, [True] * 7 + [False]]))


@pytest.mark.parametrize("prune", [None, 12.0])
def test_batched_holds_equal_the_holds_fitted_one_by_one(fitted, prune):
    search, fit = fitted
    pr = search.problem(1)
    free = fit.free_mask()
    cands = [i for i in range(4, 8) if may_hold(free, i, 1)]
    starts = [hold_starts(search, fit.theta, i, 1) for i in cands]
    free_sets = np.tile(free, (len(cands), 1))
    free_sets[np.arange(len(cands)), cands] = False
    variant = np.repeat(np.arange(len(cands)), [s.shape[0] for s in starts])
    kw = dict(max_iter=30, rtol=0.0, atol=0.02, max_reject=8, stall=1e-2, prune=prune,
              best=fit.chi2 / 2.0 + 3.0)
    sol = batched_fit(lm_fit, pr, np.concatenate(starts), free_sets, variant, **kw)
    assert len(cands) >= 3 and sol.theta.shape == (variant.size, pr.p)
    for v in range(len(cands)):
        alone = lm_fit(pr, starts[v], free_sets[v], **kw)
        rows = variant == v
        np.testing.assert_array_equal(sol.theta[rows], alone.theta)
        np.testing.assert_array_equal(sol.cost[rows], alone.cost)
        np.testing.assert_array_equal(sol.iterations[rows], alone.iterations)
        np.testing.assert_array_equal(sol.converged[rows], alone.converged)
        assert np.all(sol.theta[rows][:, cands[v]] == 0.0)  # held at zero


def test_blocked_evaluation_equals_one_piece(fitted):
    search, fit = fitted
    pr = search.problem(1)
    assert isinstance(pr, variants.BlockedProblem)
    rng = np.random.default_rng(4)
    theta = fit.theta + 1e-3 * rng.normal(size=(variants.BLOCK * 2 + 5, pr.p))
    y = np.broadcast_to(pr.group(pr.obs.values), (theta.shape[0], len(search.meas)))
    nu = pr.reference_nuisance(y)
    u = pr.data_part(y, nu)
    blocked = pr.evaluate_part(theta, u, nu, True)
    whole = VarProProblem.evaluate_part(pr, theta, u, nu, True)
    for name in ("theta", "nuisance", "residual", "cost", "jacobian"):
        np.testing.assert_array_equal(getattr(blocked, name), getattr(whole, name))
