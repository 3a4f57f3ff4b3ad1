"""The shortlist of :class:`tmakit.batch.init.Starts` chooses what the plain greedy scan does."""

import numpy as np
import pytest

from tmakit.batch.init import SHORTLIST, Starts, first_of_many, starts_of


def _greedy(candidates, cost, m):
    """The plain scan: the cheapest left (lowest index on ties), then its neighbours dropped."""
    scaled = candidates.T / np.maximum(np.abs(candidates.T).max(axis=1), 1.0)[:, None]
    left = np.where(np.isfinite(cost), cost, np.inf)
    chosen = []
    while len(chosen) < m:
        i = int(np.argmin(left))
        if not np.isfinite(left[i]):
            break
        chosen.append(i)
        left[np.max(np.abs(scaled - scaled[:, i:i + 1]), axis=0) <= 0.05] = np.inf
    return chosen


@pytest.mark.parametrize("seed", range(40))
def test_shortlist_chooses_as_the_full_scan(seed):
    rng = np.random.default_rng(seed)
    count = int(rng.choice([5, SHORTLIST, SHORTLIST + 1, 300, 2000]))
    candidates = rng.normal(0.0, 1.0, (count, 4)) * [5e3, 5e3, 20.0, 20.0]
    if seed % 4 == 0:  # clusters: many candidates near each other
        candidates = np.round(candidates / 400.0) * 400.0 + rng.normal(0, 1, candidates.shape)
    cost = rng.exponential(10.0, count)
    if seed % 3 == 0:  # ties, also at the shortlist's cut
        cost = np.round(cost)
    if seed % 5 == 0:
        cost[rng.random(count) < 0.3] = np.nan
    for steps in ([6, 24], [1, 6, 24], [30], [count + 3]):
        starts = Starts(candidates, cost)
        expected = _greedy(candidates, cost, steps[-1])
        for m in steps:
            got = starts.first(m)
            np.testing.assert_array_equal(got, candidates[expected[:m]])


@pytest.mark.parametrize("seed", range(12))
def test_many_data_sets_choose_as_one_by_one(seed):
    rng = np.random.default_rng(100 + seed)
    count, sets = int(rng.choice([SHORTLIST + 1, 500])), 7
    candidates = rng.normal(0.0, 1.0, (count, 4)) * [5e3, 5e3, 20.0, 20.0]
    if seed % 2:
        candidates = np.round(candidates / 400.0) * 400.0 + rng.normal(0, 1, candidates.shape)
    costs = rng.exponential(10.0, (sets, count))
    if seed % 3 == 0:
        costs = np.round(costs)  # ties, also at the cut
    costs[rng.random(costs.shape) < 0.1] = np.inf
    costs[0, :] = np.inf  # a data set without any finite candidate
    starts = starts_of(candidates, costs)
    for m in (1, 6, 24):
        got = first_of_many(starts, m)
        for b in range(sets):
            np.testing.assert_array_equal(got[b], candidates[_greedy(candidates, costs[b], m)])
