"""Planning beyond one step: the pruned horizon search and the mission-level planner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmakit.bounds import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.observation import MeasurementGroup
from tmakit.planning import Belief, Continuation, Planner, SensorPlan
from tmakit.planning.mission import MissionPlanner
from tmakit.sensors import Actions, PlatformKinematics, PlatformState, platform_configuration

DYN = NearlyConstantVelocity(2, 0.0)
TRUTH = np.array([4000.0, 9000.0, -6.0, -3.0])
PRIOR = np.diag([5000.0**2, 5000.0**2, 10.0**2, 10.0**2])
BEARINGS = SensorPlan("bearing", math.radians(1.0), times=tuple(np.arange(1.0, 11.0)))
SHIP = PlatformKinematics(min_speed=8.0, max_speed=8.0, max_turn_rate=math.radians(9.0))
START = PlatformState((0.0, 0.0), math.radians(45.0), 8.0)


def bearing_belief() -> Belief:
    return Belief(PosteriorInformation.from_prior(PRIOR, DYN, 0.0), TRUTH)


def radar_planner(**kw) -> tuple[Planner, PlatformState, Belief]:
    config = platform_configuration("hurtado_nehorai_2008")
    plan = SensorPlan(["bearing", "range", "range_rate"], [math.radians(1.0), 30.0, 0.5])
    planner = Planner(config.kinematics, config.actions, config.interval, plan, **kw)
    dyn = NearlyConstantVelocity(2, 0.5)
    post = PosteriorInformation.from_prior(np.diag([500.0**2] * 2 + [10.0**2] * 2), dyn)
    belief = Belief(post, np.array([-2000.0, 15000.0, 25.0, 0.0]))
    return planner, PlatformState((0.0, 0.0), 0.0, 50.0), belief


def test_beam_covering_every_leaf_is_the_exhaustive_search():
    full, platform, belief = radar_planner(horizon=3)
    wide, _, _ = radar_planner(horizon=3, beam=15**2)
    a, b = full.recommend(platform, belief), wide.recommend(platform, belief)
    assert a.index == b.index
    np.testing.assert_array_equal(a.cost, b.cost)
    narrow, _, _ = radar_planner(horizon=3, beam=4)
    c = narrow.recommend(platform, belief)
    finite = np.isfinite(c.cost)
    assert 1 <= finite.sum() <= 4          # only first actions of kept nodes have a leaf
    assert np.all(c.cost[finite] >= a.cost[finite] * (1 - 1e-12))  # pruning never finds better
    assert c.cost.min() >= a.cost.min() * (1 - 1e-12)


def test_beam_must_be_positive():
    with pytest.raises(ValueError, match="beam"):
        radar_planner(beam=0)
    with pytest.raises(ValueError, match="continuation mode"):
        Continuation(10.0, mode="circle")


def test_coast_continuation_scores_the_bound_predicted_to_the_end():
    planner, platform, belief = radar_planner(continuation=Continuation(20.0, "coast"))
    rec = planner.recommend(platform, belief)
    post = PosteriorInformation(rec.information, belief.posterior.dynamics, 0.5)
    expected = planner.criterion(post.predict_to(20.0).information)
    np.testing.assert_allclose(rec.cost, expected, rtol=1e-12)


def test_straight_continuation_with_every_sample_equals_the_flown_straight_path():
    planner = Planner(SHIP, Actions(np.radians([0.0, 45.0, -45.0])), 10.0, BEARINGS,
                      continuation=Continuation(40.0, "straight", samples=1000))
    belief = bearing_belief()
    rec = planner.recommend(START, belief)
    mission = MissionPlanner(SHIP, BEARINGS, 10.0, 10.0, 40.0)
    for k in range(3):
        h = START.heading + rec.actions.heading_change[k]
        info = mission.evaluate(START, belief, np.array([[h, h, h, h]]))[0]
        np.testing.assert_allclose(rec.cost[k], planner.criterion(info), rtol=1e-9)


def recursion_along(track, times, belief: Belief) -> np.ndarray:
    """The PosteriorInformation recursion, one bearing at a time, along a flown track."""
    post = PosteriorInformation(belief.posterior.information, DYN, belief.time, TRUTH)
    for t in times:
        post = post.predict_to(t)
        group = MeasurementGroup.planned(["bearing"], [math.radians(1.0)], t, 2)
        post = post.update(post.expected_information(track.states([t]), group)[0])
    return post.information


def small_mission(**kw) -> MissionPlanner:
    return MissionPlanner(SHIP, BEARINGS, 10.0, 40.0, 160.0, headings=8, sweeps=2,
                          refine=1, **kw)


def test_mission_plan_information_is_the_recursion_on_the_chosen_path():
    planner = small_mission()
    belief = bearing_belief()
    plan = planner.optimise(START, belief, initial=np.radians([[45.0, -45.0, 45.0, -45.0]]))
    track = SHIP.fly(START, plan.actions, 10.0)
    assert track.end_time == pytest.approx(160.0)
    info = recursion_along(track, np.arange(1.0, 161.0), belief)
    np.testing.assert_allclose(plan.information, info, rtol=1e-9)
    assert plan.bound == pytest.approx(float(np.sqrt(np.trace(np.linalg.inv(info)[:2, :2]))))
    # coordinate descent never ends worse than its starts
    starts = planner.evaluate(START, belief, np.radians([[45.0] * 4, [45.0, -45.0, 45.0,
                                                                      -45.0]]))
    assert plan.cost <= planner.criterion(starts).min() * (1 + 1e-12)


def test_mission_path_keeps_the_turn_rate_limit_and_is_deterministic():
    planner = small_mission(speeds=(6.0, 8.0))
    belief = bearing_belief()
    a = planner.optimise(START, belief)
    b = planner.optimise(START, belief)
    np.testing.assert_array_equal(a.headings, b.headings)
    np.testing.assert_array_equal(a.speeds, b.speeds)
    kin = PlatformKinematics(min_speed=0.0, max_speed=8.0, max_turn_rate=math.radians(9.0))
    track = kin.fly(START, a.actions, 10.0)
    rates = np.array([abs(float(s.turn_rate)) for s in track.steps])
    assert np.all(rates <= math.radians(9.0) * (1 + 1e-12))
    assert np.any(rates > 0)
    # the planned path turns: a straight one is far worse for bearings only
    straight = planner.evaluate(START, belief, np.full((1, 4), START.heading))
    assert a.cost < 0.5 * planner.criterion(straight)[0]


def test_mission_receding_over_legs_and_bad_settings():
    planner = small_mission()
    belief, platform = bearing_belief(), START
    plan = planner.recommend(platform, belief)
    platform, belief = planner.advance(platform, belief, plan, DYN.transition(40.0) @ TRUTH)
    assert belief.time == pytest.approx(40.0) and platform.time == pytest.approx(40.0)
    again = planner.recommend(platform, belief, previous=plan)
    assert again.headings.shape == (3,)
    assert again.cost <= plan.cost * (1 + 1e-9)     # re-planning from the tail never worse
    with pytest.raises(ValueError, match="leg_duration"):
        MissionPlanner(SHIP, BEARINGS, 10.0, 25.0, 160.0)
    with pytest.raises(ValueError, match="headings"):
        planner.evaluate(START, bearing_belief(), np.zeros((1, 3)))


# -- tactical constraints along the mission path -------------------------------------------------
ZONE = [(200.0, 200.0), (1200.0, 200.0), (1200.0, 1200.0), (200.0, 1200.0)]
AREA = [(-300.0, -300.0), (300.0, -300.0), (300.0, 300.0), (-300.0, 300.0)]


def flown_positions(plan) -> tuple[np.ndarray, np.ndarray]:
    """The planned path's sensor and (estimated = true here) target positions every 0.5 s."""
    ts = np.arange(0.0, 160.25, 0.5)
    sensor = SHIP.fly(START, plan.actions, 10.0).states(ts)[:, :2]
    target = np.array([DYN.transition(t) @ TRUTH for t in ts])[:, :2]
    return sensor, target


def test_mission_plan_keeps_hard_constraints_the_free_plan_breaks():
    import shapely

    from tmakit.planning.constraints import KeepOutZones, MinimumRange, OperatingArea

    belief = bearing_belief()
    free = small_mission().optimise(START, belief)
    sensor, target = flown_positions(free)
    zone, area = shapely.Polygon(ZONE), shapely.Polygon(AREA)
    # the unconstrained plan breaks each of the three constraints below
    assert np.hypot(*(sensor - target).T).min() < 9000.0
    assert shapely.contains_xy(zone, sensor[:, 0], sensor[:, 1]).any()
    assert not shapely.contains_xy(area, sensor[:, 0], sensor[:, 1]).all()
    for constraint in (MinimumRange(9300.0), KeepOutZones([ZONE]), OperatingArea(AREA)):
        plan = small_mission(constraints=[constraint]).optimise(START, belief)
        assert plan.feasible and plan.violations == {constraint.name: 0.0}
        sensor, target = flown_positions(plan)
        points = shapely.points(sensor)
        if isinstance(constraint, MinimumRange):   # checked 4 times a step: 1 m of slack
            assert np.hypot(*(sensor - target).T).min() >= 9300.0 - 1.0
        elif isinstance(constraint, KeepOutZones):
            inside = shapely.contains_xy(zone, sensor[:, 0], sensor[:, 1])
            assert shapely.distance(zone.boundary, points)[inside].max(initial=0.0) < 1.0
        else:
            assert shapely.distance(area, points).max() < 1.0
        assert plan.bound > free.bound * (1 - 1e-9)   # a constraint never helps the bound


def test_mission_penalty_and_an_infeasible_mission_are_reported():
    from tmakit.planning.constraints import MinimumRange, OperatingArea

    belief = bearing_belief()
    soft = MinimumRange(9300.0, hard=False, weight=10.0)
    plan = small_mission(constraints=[soft]).optimise(START, belief)
    sensor, target = flown_positions(plan)
    amount = plan.violations["minimum range"]
    assert plan.feasible and amount >= 0.0
    assert amount == pytest.approx(max(0.0, 9300.0 - np.hypot(*(sensor - target).T).min()),
                                   abs=1.0)
    expected = small_mission().criterion(plan.information[None])[0] * (1 + 10.0 * amount
                                                                      / 9300.0)
    assert plan.cost == pytest.approx(expected, rel=1e-12)
    # an operating area 2 km to the south-west of the start cannot be reached in 160 s
    far = [(-3000.0, -3000.0), (-2000.0, -3000.0), (-2000.0, -2000.0), (-3000.0, -2000.0)]
    stuck = small_mission(constraints=[OperatingArea(far)]).optimise(START, belief)
    assert not stuck.feasible and stuck.violations["operating area"] > 0.0
    # the least violating path turns for the area at once and holds on to it: it ends
    # within 60 m of as near as the ship could get (8 m/s for 160 s, less a 20 s turn)
    sensor, _ = flown_positions(stuck)
    start_gap = math.hypot(2000.0, 2000.0)
    assert stuck.violations["operating area"] < start_gap + 100.0   # the worst: at the turn
    assert np.hypot(*(sensor[-1] + 2000.0)) < start_gap - 8.0 * 140.0 + 60.0
