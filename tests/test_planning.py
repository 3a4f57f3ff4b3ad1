"""The planning core: vectorised criterion, the recursion, criteria, constraints, horizon."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import (
    Belief,
    CustomCriterion,
    KeepOutZones,
    LogDet,
    MaximumRange,
    MinimumRange,
    OperatingArea,
    Planner,
    SensorPlan,
    WeightedTrace,
)
from tmakit.planning.belief import cubature_points
from tmakit.planning.candidates import step_information
from tmakit.sensors import Actions, PlatformKinematics, PlatformState, platform_configuration

CONFIG = platform_configuration("hurtado_nehorai_2008")
RADAR = SensorPlan(["bearing", "range", "range_rate"], [math.radians(1.0), 30.0, 0.5])
TARGET = np.array([-2000.0, 15000.0, 25.0, 0.0])
DYN = NearlyConstantVelocity(dim=2, q=0.1)
PRIOR = np.diag([500.0**2, 500.0**2, 10.0**2, 10.0**2])


def belief(n_particles=200, seed=1, at=0.0):
    rng = np.random.default_rng(seed)
    cloud = TARGET + rng.standard_normal((n_particles, 4)) * np.sqrt(np.diag(PRIOR))
    w = rng.random(n_particles)
    return Belief(PosteriorInformation.from_prior(PRIOR, DYN, time=at), cloud, w / w.sum())


def planner(**kw):
    base = dict(kinematics=CONFIG.kinematics, actions=CONFIG.actions,
                interval=CONFIG.interval, plan=RADAR)
    base.update(kw)
    return Planner(**base)


START = PlatformState(position=(0.0, 0.0), heading=0.0, speed=50.0)


@pytest.mark.parametrize("gamma", ["mean", "cloud"])
def test_vectorised_criterion_equals_a_loop_over_candidates(gamma):
    b = belief()
    rec = planner(gamma=gamma).recommend(START, b)
    crit = WeightedTrace()
    f = DYN.transition(CONFIG.interval)
    cloud = b.states @ f.T
    for c in range(len(CONFIG.actions)):
        sensor = rec.steps[c].sensor_states([CONFIG.interval])[0]       # (6,)
        post = b.posterior.predict(CONFIG.interval)
        if gamma == "mean":
            gam = RADAR.group.information((b.weights @ cloud)[None], sensor)[0]
        else:
            gam = sum(w * RADAR.group.information(x[None], sensor)[0]
                      for w, x in zip(b.weights, cloud, strict=True))
        j = post.update(gam).information
        np.testing.assert_allclose(rec.information[c], j, rtol=1e-10)
        assert rec.cost[c] == pytest.approx(crit(j), rel=1e-10)
    assert rec.index == int(np.argmin(rec.cost))


def test_predicted_information_equals_the_recursion_on_the_flown_path():
    plan = SensorPlan("bearing", math.radians(1.0), times=[2.0, 5.0, 10.0])
    acts = Actions.grid(np.radians([-90.0, -45.0, 0.0, 45.0, 90.0]))
    kin = PlatformKinematics(max_turn_rate=math.radians(9.0))
    b = belief(n_particles=1)  # the mean only
    p = Planner(kin, acts, 10.0, plan)
    start = PlatformState(position=(0.0, 0.0), heading=math.radians(45.0), speed=8.0)
    rec = p.recommend(start, b)
    for c in range(len(acts)):
        track = kin.fly(start, acts[[c]], 10.0)
        post = b.posterior
        x = b.states[0]
        for t in (2.0, 5.0, 10.0):
            post = post.predict_to(t)
            xt = DYN.transition(t) @ x
            post = post.update(plan.group.information(xt[None], track.states([t])[0])[0])
        np.testing.assert_allclose(rec.information[c], post.information, rtol=1e-9)


def test_the_paper_radar_closes_on_the_target():
    # Range accuracy does not depend on range, cross-range accuracy does: get closer.
    rec = planner().recommend(START, belief())
    toward = math.atan2(TARGET[0], TARGET[1])   # the target is to the West of North
    assert np.sign(rec.action.heading_change) == np.sign(toward)
    assert rec.action.speed_factor > 1.0


def test_criteria():
    info = np.linalg.inv(np.diag([4.0, 9.0, 1.0, 2.0]))[None].repeat(3, 0)
    assert WeightedTrace()(info) == pytest.approx([13.0] * 3)
    assert WeightedTrace(np.eye(4))(info) == pytest.approx([16.0] * 3)
    assert LogDet()(info) == pytest.approx([math.log(36.0)] * 3)
    assert LogDet("state")(info) == pytest.approx([math.log(72.0)] * 3)
    custom = CustomCriterion(lambda j: j[..., 0, 0], name="x information")
    assert custom(info) == pytest.approx([0.25] * 3)
    with pytest.raises(ValueError, match="returned shape"):
        CustomCriterion(lambda j: 1.0)(info)
    with pytest.raises(ValueError, match="positive semi-definite"):
        WeightedTrace(-np.eye(4))(info)


def test_constraint_amounts():
    pos = np.array([[[0.0, 0.0, 0.0]], [[3000.0, 4000.0, 0.0]], [[20000.0, 0.0, 0.0]]])
    tgt = np.zeros((1, 3))
    assert MinimumRange(5000.0).check(pos, tgt).amount == pytest.approx([5000.0, 0.0, 0.0])
    assert MaximumRange(10000.0).check(pos, tgt).amount == pytest.approx([0.0, 0.0, 10000.0])
    zone = [(-100.0, -100.0), (100.0, -100.0), (100.0, 50.0), (-100.0, 50.0)]
    assert KeepOutZones([zone]).check(pos).amount == pytest.approx([50.0, 0.0, 0.0])
    area = [(-1.0, -1.0), (10000.0, -1.0), (10000.0, 10000.0), (-1.0, 10000.0)]
    assert OperatingArea(area).check(pos).amount == pytest.approx([0.0, 0.0, 10000.0])
    with pytest.raises(ValueError, match="minimum range must be a positive"):
        MinimumRange(-1.0)
    with pytest.raises(ValueError, match="not a valid polygon"):
        KeepOutZones([[(0, 0), (1, 1), (1, 0), (0, 1)]])
    with pytest.raises(ValueError, match="at least three"):
        OperatingArea([(0, 0), (1, 1)])


def test_hard_minimum_range_is_kept_and_penalty_is_softer():
    near = Belief(PosteriorInformation.from_prior(PRIOR, DYN), [300.0, 3000.0, 0.0, 0.0])
    hard = planner(constraints=[MinimumRange(5000.0)]).recommend(START, near)
    assert hard.all_infeasible        # already inside 5 km: every candidate violates
    best = int(np.argmin(hard.violations["minimum range"]))
    assert hard.violations["minimum range"][hard.index] == \
        pytest.approx(hard.violations["minimum range"][best])
    far = belief()
    rec = planner(constraints=[MinimumRange(5000.0), KeepOutZones(
        [[(-500.0, 0.0), (-500.0, 200.0), (-0.5, 200.0), (-0.5, 0.0)]])]).recommend(START, far)
    assert rec.feasible[rec.index] and not rec.all_infeasible
    assert rec.violations["keep-out zone"][rec.index] == 0.0
    assert (rec.violations["keep-out zone"] > 0).any()   # the zone removed some candidates


def test_one_candidate_and_horizon_search():
    one = planner(actions=CONFIG.actions[[7]])
    assert one.recommend(START, belief()).index == 0
    b = belief(n_particles=1)
    p2 = planner(horizon=2)
    rec = p2.recommend(START, b)
    # brute force over the 15 x 15 sequences
    costs = np.empty((15, 15))
    for i in range(15):
        s1 = CONFIG.kinematics.step(START, CONFIG.actions[i], CONFIG.interval)
        j1 = step_information(b, b.posterior.information, RADAR,
                              s1.sensor_states([0.5])[None], 0.5, "mean")[0]
        for k in range(15):
            s2 = CONFIG.kinematics.step(s1.end, CONFIG.actions[k], CONFIG.interval)
            f = DYN.transition(0.5)
            j2 = step_information(b, j1, RADAR, s2.sensor_states([1.0])[None], 0.5, "mean",
                                  cloud=(b.states @ f.T, b.weights))[0]
            costs[i, k] = WeightedTrace()(j2)
    np.testing.assert_allclose(rec.cost, costs.min(axis=1), rtol=1e-9)
    assert rec.index == int(np.argmin(costs.min(axis=1)))


def test_cubature_points_keep_mean_and_covariance():
    pts, w = cubature_points(TARGET, PRIOR)
    np.testing.assert_allclose(w @ pts, TARGET)
    d = pts - TARGET
    np.testing.assert_allclose((w[:, None] * d).T @ d, PRIOR, rtol=1e-12)


def test_bad_planner_settings_are_refused():
    with pytest.raises(ValueError, match="horizon"):
        planner(horizon=0)
    with pytest.raises(ValueError, match="gamma"):
        planner(gamma="particles")
    with pytest.raises(ValueError, match="sigmas must be positive"):
        SensorPlan("bearing", -1.0)
    with pytest.raises(ValueError, match="one platform state"):
        planner().recommend(PlatformState(np.zeros((2, 2)), 0.0, 50.0), belief())


@pytest.mark.parametrize("dim", [2, 3])
def test_planar_cloud_information_equals_the_general_path(dim):
    from tmakit.planning.candidates import GEOMETRIC_KINDS, cloud_information

    kinds = ["bearing", "range", "range_rate"] + (["elevation"] if dim == 3 else [])
    sig = [0.02, 30.0, 0.5, 0.03][:len(kinds)]
    plan = SensorPlan(kinds, sig, dim=dim)
    assert set(plan.kinds) <= GEOMETRIC_KINDS
    rng = np.random.default_rng(3)
    n = 2 * dim
    states = rng.normal(size=(300, n)) * 500.0 + np.r_[[-2000.0, 15000.0, 900.0][:dim],
                                                       [25.0, 0.0, 1.0][:dim]]
    w = rng.random(300)
    w /= w.sum()
    sensors = rng.normal(size=(5, 6)) * [30, 30, 30, 10, 10, 1] + [0, 0, 100, 0, 50, 0]
    general = np.einsum("ckij,k->cij", plan.information(states, sensors), w)
    np.testing.assert_allclose(cloud_information(plan, states, w, sensors), general,
                               rtol=1e-9, atol=1e-12 * np.abs(general).max())
    # a full noise covariance: the whitening mixes the rows
    a = rng.normal(size=(len(kinds), len(kinds))) * 0.1 + np.eye(len(kinds))
    cov = np.diag(sig) @ (a @ a.T) @ np.diag(sig)
    full = SensorPlan(kinds, sig, dim=dim)
    object.__setattr__(full, "covariance", cov)
    h = plan.group.jacobian(states, sensors[:, None, None, :])        # (C, N, m, n)
    rinv = np.linalg.inv(cov)
    expect = np.einsum("cnmi,mk,cnkj,n->cij", h, rinv, h, w)
    np.testing.assert_allclose(cloud_information(full, states, w, sensors), expect,
                               rtol=1e-9, atol=1e-12 * np.abs(expect).max())


@pytest.mark.parametrize("kinds", [["bearing"], ["bearing", "range", "range_rate"],
                                   ["range_rate", "range"], ["bearing", "range_rate"]])
def test_planar_closed_form_equals_the_general_path(kinds):
    from tmakit.planning.compiled import planar_information, supports_planar

    rng = np.random.default_rng(5)
    sig = rng.uniform(0.01, 2.0, len(kinds))
    a = rng.normal(size=(len(kinds), len(kinds))) * 0.2 + np.eye(len(kinds))
    for cov in (None, np.diag(sig) @ (a @ a.T) @ np.diag(sig)):
        plan = SensorPlan(kinds, sig)
        group = plan.group   # built with the independent sigmas, for the reference
        rinv = np.linalg.inv(group.covariance if cov is None else cov)
        object.__setattr__(plan, "covariance", cov)
        states = rng.normal(size=(200, 4)) * [800, 800, 5, 5] + [-2000, 15000, 25, 0]
        w = rng.random(200)
        w /= w.sum()
        sensors = np.zeros((7, 6))
        sensors[:, [0, 1, 3, 4]] = rng.normal(size=(7, 4)) * [50, 50, 30, 30]
        assert supports_planar(plan, sensors)
        h = plan.group.jacobian(states, sensors[:, None, None, :])
        expect = np.einsum("cnmi,mk,cnkj,n->cij", h, rinv, h, w)
        np.testing.assert_allclose(planar_information(plan, states, w, sensors), expect,
                                   rtol=1e-9, atol=1e-12 * np.abs(expect).max())


def test_bound_covariance_is_the_inverse_and_floors_an_indefinite_matrix():
    from tmakit.bounds.pcrb_recursion import information_inverse
    from tmakit.planning.criteria import bound_covariance

    rng = np.random.default_rng(4)
    a = rng.normal(size=(200, 4, 4))
    scales = np.array([1e-6, 1e-6, 1e-2, 1e-2])   # SI units: position and velocity information
    info = (a @ np.swapaxes(a, -1, -2) + 0.01 * np.eye(4)) * np.sqrt(np.outer(scales, scales))
    info[:50] += np.diag(scales) * 1e4              # some well determined, some barely
    inv = bound_covariance(info)
    d = np.sqrt(np.einsum("kii->ki", info))
    cond = np.linalg.cond(info / (d[:, :, None] * d[:, None, :]))
    err = np.abs(np.einsum("kij,kjl->kil", info, inv) - np.eye(4)).max(axis=(1, 2))
    assert np.all(err <= 1e-13 * cond)              # J J^{-1} = I to cond * eps
    np.testing.assert_allclose(bound_covariance(info[0]), np.linalg.inv(info[0]), rtol=1e-9)
    bad = info[:3].copy()
    bad[1] = np.eye(4)
    bad[1, 0, 1] = bad[1, 1, 0] = 2.0             # indefinite, positive diagonal
    np.testing.assert_array_equal(bound_covariance(bad), information_inverse(bad))
