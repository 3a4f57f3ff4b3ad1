"""MissionPlanner with target hypotheses: the expected bound over a few target states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmakit.bounds import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, SensorPlan
from tmakit.planning.mission import MissionPlanner
from tmakit.sensors import PlatformKinematics, PlatformState

DYN = NearlyConstantVelocity(2, 0.0)
TRUTH = np.array([4000.0, 9000.0, -6.0, -3.0])
PRIOR = np.diag([5000.0**2, 5000.0**2, 10.0**2, 10.0**2])
BEARINGS = SensorPlan("bearing", math.radians(1.0), times=(5.0, 10.0))
SHIP = PlatformKinematics(min_speed=8.0, max_speed=8.0, max_turn_rate=math.radians(9.0))
START = PlatformState((0.0, 0.0), math.radians(45.0), 8.0)
PATHS = np.radians([[45.0, 45.0, 45.0], [0.0, -60.0, 30.0], [90.0, 0.0, -90.0]])


def planner(**kw) -> MissionPlanner:
    return MissionPlanner(SHIP, BEARINGS, 10.0, 40.0, 120.0, headings=8, sweeps=1, refine=1,
                          **kw)


def belief(states, weights=None) -> Belief:
    return Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0), states, weights)


def test_each_hypothesis_is_the_single_target_recursion():
    ranges = np.array([0.5, 1.0, 2.0])
    states = ranges[:, None] * TRUTH[None, :]        # three ranges along the same bearing
    per = planner(hypotheses=True).evaluate(START, belief(states), PATHS)
    assert per.shape == (3, 3, 4, 4)
    for k in range(3):
        one = planner().evaluate(START, belief(states[k]), PATHS)
        np.testing.assert_allclose(per[:, k], one, rtol=1e-12)


def test_cost_is_the_weighted_mean_bound_and_one_hypothesis_is_the_plain_plan():
    states = np.array([0.6, 1.4])[:, None] * TRUTH[None, :]
    w = np.array([0.25, 0.75])
    hyp = planner(hypotheses=True).optimise(START, belief(states, w))
    per = planner(hypotheses=True).evaluate(START, belief(states, w), hyp.headings[None])[0]
    cost = np.trace(np.linalg.inv(per)[:, :2, :2], axis1=1, axis2=2)
    assert hyp.cost == pytest.approx(float(w @ cost), rel=1e-12)
    assert hyp.bound == pytest.approx(math.sqrt(hyp.cost), rel=1e-12)
    # the expected bound of the chosen path is no worse than that of each start path
    starts = planner(hypotheses=True).evaluate(START, belief(states, w), PATHS[:1])[0]
    start_cost = np.trace(np.linalg.inv(starts)[:, :2, :2], axis1=1, axis2=2)
    assert hyp.cost <= float(w @ start_cost) * (1 + 1e-12)
    # one hypothesis: the same plan as without hypotheses
    a = planner(hypotheses=True).optimise(START, belief(TRUTH))
    b = planner().optimise(START, belief(TRUTH))
    np.testing.assert_array_equal(a.headings, b.headings)
    assert a.cost == pytest.approx(b.cost, rel=1e-12)


def test_information_per_hypothesis_starts_each_recursion():
    states = np.array([0.6, 1.4])[:, None] * TRUTH[None, :]
    mp = planner(hypotheses=True)
    b = belief(states)
    j0 = b.posterior.information
    same = mp.optimise(START, b, information=np.stack([j0, j0]))
    plain = mp.optimise(START, b)
    np.testing.assert_array_equal(same.headings, plain.headings)
    # more information under one hypothesis: a lower expected bound for the same path
    richer = mp.optimise(START, b, initial=plain.headings,
                         information=np.stack([j0, j0 + np.diag([1e-2, 1e-2, 0.0, 0.0])]))
    assert richer.cost < plain.cost
    with pytest.raises(ValueError, match="one J per hypothesis"):
        mp.optimise(START, b, information=np.stack([j0, j0, j0]))
