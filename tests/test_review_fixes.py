"""Fixes found by a new user's review: each case a bad or odd input and its honest outcome."""

from __future__ import annotations

import numpy as np
import pytest

from tmakit.measurements import range_difference_covariance
from tmakit.measurements.range_difference import MAX_GROUP_ROWS, RangeDifference, overlap_groups
from tmakit.observation.noise import NoiseModel


def _dense(blocks, m):
    r = np.zeros((m, m))
    for rows, cov in blocks:
        r[np.ix_(rows, rows)] = cov
    return r


def test_range_difference_noise_blocks_are_the_dense_covariance_without_forming_it():
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 100, 300)).round(1) + 1.0
    lag = rng.choice([0.5, 1.0, 2.5], size=t.shape[0])  # some spans overlap, some chain
    t_ref = t - lag
    sigma = rng.uniform(0.5, 2.0, t.shape[0])
    blocks = RangeDifference().noise_blocks(t, t_ref, sigma)
    np.testing.assert_array_equal(_dense(blocks, t.shape[0]),
                                  range_difference_covariance(t, t_ref, sigma))
    assert all(np.all(np.diff(rows) > 0) for rows, _ in blocks)
    assert sorted(np.concatenate([rows for rows, _ in blocks]).tolist()) == list(range(300))


def test_consecutive_range_differences_are_independent_groups():
    t = np.arange(1.0, 50001.0)
    group = overlap_groups(t, t - 1.0)  # (t-1, t]: touching, not overlapping
    assert np.array_equal(group, np.arange(50000))
    blocks = RangeDifference().noise_blocks(t, t - 1.0, np.full(t.shape[0], 0.7))
    assert max(rows.size for rows, _ in blocks) == 1  # no 50,000 x 50,000 matrix
    assert overlap_groups([2.0, 3.0, 2.5], [1.0, 2.0, 1.5]).tolist() == [0, 0, 0]
    assert overlap_groups([2.0, 4.0, 3.0], [1.0, 3.0, 2.0]).tolist() == [0, 2, 1]


def test_a_noise_model_of_many_small_groups_whitens_as_the_dense_covariance():
    t = np.repeat(np.arange(1.0, 41.0), 2)
    t_ref = t - np.tile([1.0, 0.5], 40)  # pairs that share the last half interval
    sigma = np.tile([0.7, 0.5], 40)
    blocks = RangeDifference().noise_blocks(t, t_ref, sigma)
    noise = NoiseModel.independent(sigma)
    noise._setup(sigma, blocks)
    w = noise.whiten(np.eye(t.shape[0]), axis=0)
    np.testing.assert_allclose(np.linalg.inv(w.T @ w),
                               range_difference_covariance(t, t_ref, sigma), atol=1e-12)


def test_one_chain_of_too_many_overlapping_range_differences_is_refused():
    n = MAX_GROUP_ROWS + 1
    t = np.arange(1.0, n + 1.0)
    with pytest.raises(ValueError, match=r"share pulse intervals.*consecutive samples"):
        RangeDifference().noise_blocks(t, np.zeros(n), np.ones(n))
