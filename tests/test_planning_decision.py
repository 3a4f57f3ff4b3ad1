"""The compiled decision (kinematics, one call for the whole decision) equals the general path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import (
    Belief,
    LogDet,
    MinimumRange,
    Planner,
    SensorPlan,
    WeightedTrace,
)
from tmakit.planning import planner as decision
from tmakit.sensors import Actions, PlatformKinematics, PlatformState, platform_configuration

TARGET = np.array([-2000.0, 15000.0, 25.0, 0.0])
SPREAD = np.array([500.0, 500.0, 10.0, 10.0])
FIELDS = ("turn_rate", "acceleration", "climb_rate", "speed_limited", "turn_limited",
          "acceleration_limited", "climb_limited")


def _same_step(fast, slow):
    assert fast.shape == slow.shape
    for a, b in ((fast.start, slow.start), (fast.end, slow.end)):
        for name in ("position", "heading", "speed", "climb_rate"):
            x, y = getattr(a, name), getattr(b, name)
            assert x.shape == y.shape, name
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()),
                                       err_msg=name)
        assert a.time == b.time
    for name in FIELDS:
        x, y = getattr(fast, name), getattr(slow, name)
        if x.dtype == bool:
            np.testing.assert_array_equal(x, y, err_msg=name)
        else:
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-15, err_msg=name)
    assert fast.interval == slow.interval
    np.testing.assert_allclose(fast.end.sensor_state, slow.end.sensor_state, rtol=1e-12,
                               atol=1e-9)


def test_compiled_kinematics_equal_the_step_of_the_paper_platform():
    config = platform_configuration("hurtado_nehorai_2008")
    for speed in (50.0, 120.0, 200.0):   # the floor, free, the ceiling: speed range acts
        start = PlatformState(position=(100.0, -30.0), heading=3.1, speed=speed, time=4.0)
        fast = decision.fly(config.kinematics, start, config.actions, config.interval)
        slow = config.kinematics.step(start, config.actions, config.interval)
        _same_step(fast, slow)
        assert fast.speed_limited.any() == (speed in (50.0, 200.0))


def test_compiled_kinematics_3d_with_every_limit_hit():
    kin = PlatformKinematics(min_speed=20.0, max_speed=60.0, max_turn_rate=math.radians(3.0),
                             max_acceleration=2.0, max_climb_rate=5.0, min_altitude=100.0,
                             max_altitude=300.0)
    actions = Actions.grid(np.radians([-40.0, -2.0, 0.0, 1.0, 90.0]),
                           speed_factors=[0.1, 1.0, 1.05, 3.0],
                           climb_rates=[-50.0, -1.0, 0.0, 4.0, 50.0])
    rng = np.random.default_rng(5)
    starts = PlatformState(position=rng.uniform(-1e3, 1e3, (6, 3)) * [1, 1, 0.2] + [0, 0, 200],
                           heading=rng.uniform(-math.pi, math.pi, 6),
                           speed=[20.0, 25.0, 40.0, 60.0, 59.0, 0.0],
                           climb_rate=rng.uniform(-3, 3, 6), time=12.5)
    start = PlatformState.trusted(starts.position[:, None, :], starts.heading[:, None],
                                  starts.speed[:, None], starts.climb_rate[:, None], 12.5)
    for interval in (0.5, 10.0, 60.0):   # straight-ish steps and long turns (closed form)
        fast = decision.fly(kin, starts, actions, interval)
        slow = kin.step(start, actions, interval)
        _same_step(fast, slow)
        every = ("speed_limited", "turn_limited", "acceleration_limited", "climb_limited")
        for name in every if interval <= 10 else ():   # 60 s: the limits are not reached
            assert getattr(slow, name).any() and not getattr(slow, name).all(), (name,
                                                                                 interval)
    # the climb rate of the platform kept when the actions give none, altitude band clipped
    keep = Actions(np.radians([0.0, 10.0]), speed_factor=[1.0, 1.2])
    high = PlatformState(position=(0.0, 0.0, 299.0), heading=0.0, speed=30.0, climb_rate=4.0)
    _same_step(decision.fly(kin, high, keep, 1.0), kin.step(high, keep, 1.0))
    assert decision.fly(kin, high, keep, 1.0).climb_limited.all()


def test_raise_on_limit_is_left_to_the_platform_step():
    kin = PlatformKinematics(max_speed=10.0, on_limit="raise")
    start = PlatformState(position=(0.0, 0.0), heading=0.0, speed=10.0)
    assert decision.fly(kin, start, Actions([0.0], speed_factor=[1.5]), 1.0) is None


def _belief(rng, n, q=0.1):
    dyn = NearlyConstantVelocity(dim=2, q=q)
    post = PosteriorInformation.from_prior(np.diag(SPREAD**2), dyn, time=3.0)
    return Belief(post, TARGET + rng.standard_normal((n, 4)) * SPREAD)


def _both(planner, fn):
    """Run ``fn`` on the compiled decision, then on the planner's general path."""
    fast = fn()
    planner._decision["setup"] = None    # the decision steps aside: step_information and the rest
    try:
        slow = fn()
    finally:
        planner._decision.clear()
    return fast, slow


@pytest.mark.parametrize(("kinds", "sigmas", "gamma", "q", "n"), [
    (["bearing", "range"], [math.radians(1.0), 30.0], "mean", 0.1, 1),
    (["bearing", "range"], [math.radians(1.0), 30.0], "mean", 0.1, 500),
    (["bearing", "range"], [math.radians(1.0), 30.0], "cloud", 0.1, 2000),
    (["bearing"], [math.radians(0.5)], "cloud", 0.0, 300),
    (["bearing", "range", "range_rate"], [0.02, 20.0, 0.5], "mean", 1.0, 50),
    (["bearing", "range", "range_rate"], [0.02, 20.0, 0.5], "cloud", 1.0, 800),
])
def test_compiled_decision_equals_the_general_path(kinds, sigmas, gamma, q, n):
    config = platform_configuration("hurtado_nehorai_2008")
    rng = np.random.default_rng(len(kinds) * 100 + n)
    for trial in range(4):
        belief = _belief(rng, n, q)
        start = PlatformState(position=rng.uniform(-3e3, 3e3, 2), heading=rng.uniform(-3, 3),
                              speed=rng.choice([50.0, 100.0, 200.0]), time=3.0)
        planner = Planner(config.kinematics, config.actions, config.interval,
                          SensorPlan(kinds, sigmas), gamma=gamma)
        assert decision.decide(planner, {}, start, belief) is not None   # compiled decision ran
        fast, slow = _both(planner, lambda p=planner, s=start, b=belief: p.recommend(s, b))
        assert fast.index == slow.index, trial
        np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)
        np.testing.assert_allclose(fast.bound, slow.bound, rtol=1e-12)
        scale = np.abs(slow.information).max(axis=(-1, -2), keepdims=True)
        assert np.all(np.abs(fast.information - slow.information) <= 1e-12 * scale)
        _same_step(fast.steps, slow.steps)


@pytest.mark.parametrize("criterion", [LogDet(), WeightedTrace(np.diag([1.0, 2.0, 25.0, 25.0]))])
def test_compiled_decision_with_other_criteria_and_constraints(criterion):
    config = platform_configuration("hurtado_nehorai_2008")
    rng = np.random.default_rng(9)
    belief = _belief(rng, 200)
    start = PlatformState(position=(-2000.0, 9000.0), heading=0.3, speed=150.0, time=3.0)
    planner = Planner(config.kinematics, config.actions, config.interval,
                      SensorPlan(["bearing", "range"], [0.02, 30.0]), criterion=criterion,
                      constraints=[MinimumRange(5902.0, hard=True)], gamma="cloud")
    fast, slow = _both(planner, lambda: planner.recommend(start, belief))
    assert fast.index == slow.index
    np.testing.assert_array_equal(fast.feasible, slow.feasible)
    assert not slow.feasible.all() and slow.feasible.any()   # the constraint acts
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)
    for name, amount in slow.violations.items():
        np.testing.assert_allclose(fast.violations[name], amount, rtol=1e-9, atol=1e-9)


def test_compiled_decision_steps_aside_where_it_does_not_apply():
    rng = np.random.default_rng(3)
    belief = _belief(rng, 10)
    start = PlatformState(position=(0.0, 0.0), heading=0.0, speed=50.0, time=3.0)
    config = platform_configuration("hurtado_nehorai_2008")
    base = dict(kinematics=config.kinematics, actions=config.actions, interval=config.interval)
    two_pulses = Planner(**base, plan=SensorPlan(["bearing"], [0.01], times=(0.25, 0.5)))
    assert decision.decide(two_pulses, {}, start, belief) is None
    climbing = Planner(config.kinematics, Actions.grid([0.0, 0.1], climb_rates=[0.0, 5.0]),
                       1.0, SensorPlan(["bearing", "range"], [0.01, 10.0]))
    assert decision.decide(climbing, {}, start, belief) is None   # a sensor leaves z = 0
    fast, slow = _both(climbing, lambda: climbing.recommend(start, belief))
    assert fast.index == slow.index
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)


def test_horizon_search_after_the_compiled_decision_chooses_as_the_general_path():
    config = platform_configuration("hurtado_nehorai_2008")
    rng = np.random.default_rng(21)
    belief = _belief(rng, 400)
    start = PlatformState(position=(500.0, 2000.0), heading=-0.4, speed=120.0, time=3.0)
    planner = Planner(config.kinematics, config.actions, config.interval,
                      SensorPlan(["bearing", "range"], [0.02, 30.0]), gamma="cloud", horizon=2)
    fast, slow = _both(planner, lambda: planner.recommend(start, belief))
    assert fast.index == slow.index
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)


def test_the_recommendation_of_the_compiled_decision_reads_as_the_general_one():
    import pickle

    config = platform_configuration("hurtado_nehorai_2008")
    belief = _belief(np.random.default_rng(4), 1)
    start = PlatformState(position=(0.0, 0.0), heading=0.0, speed=50.0, time=3.0)
    planner = Planner(config.kinematics, config.actions, config.interval,
                      SensorPlan(["bearing", "range"], [0.02, 30.0]))
    fast, slow = _both(planner, lambda: planner.recommend(start, belief))
    assert isinstance(fast.steps, decision.LazyStep)
    again = pickle.loads(pickle.dumps(fast.steps))
    _same_step(again, slow.steps)                     # before any field was read
    _same_step(fast.step, slow.step)                  # one candidate: Step.__getitem__
    assert "Step" in repr(fast.steps) and fast.steps.shape == (15,)
    np.testing.assert_array_equal(fast.feasible, slow.feasible)
    assert fast.violations == slow.violations == {} and not fast.all_infeasible
    np.testing.assert_allclose(fast.action.heading_change, slow.action.heading_change)


def test_compiled_decision_takes_views_and_fortran_ordered_clouds():
    config = platform_configuration("hurtado_nehorai_2008")
    rng = np.random.default_rng(8)
    cloud = np.asfortranarray(TARGET + rng.standard_normal((300, 4)) * SPREAD)
    post = PosteriorInformation(np.asfortranarray(np.diag([4e-6, 4e-6, 1e-2, 1e-2])),
                                NearlyConstantVelocity(dim=2, q=0.1), time=3.0)
    belief = Belief(post, cloud)
    start = PlatformState(position=(10.0, 20.0), heading=1.0, speed=80.0, time=3.0)
    planner = Planner(config.kinematics, config.actions, config.interval,
                      SensorPlan(["bearing", "range"], [0.02, 30.0]), gamma="cloud")
    assert decision.decide(planner, {}, start, belief) is not None
    fast, slow = _both(planner, lambda: planner.recommend(start, belief))
    assert fast.index == slow.index
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)
