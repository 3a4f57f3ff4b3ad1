"""What steers in the closed loop (fixed pattern, mission planner) and the bound it is held to."""

from __future__ import annotations

import json
import math
import tomllib
from importlib import resources

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.bounds import deterministic_pcrb, pcrb_over_runs
from tmakit.bounds.pcrb_recursion import PosteriorInformation, ratio_interval
from tmakit.cli import app
from tmakit.data import MeasurementSet
from tmakit.montecarlo.closed_loop import LoopSetup, closed_loop_study, run_closed_loop
from tmakit.montecarlo.planned import policy
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, SensorPlan
from tmakit.planning.policies import (
    FixedPolicy,
    MissionPolicy,
    TrackPolicy,
    passive,
    range_hypotheses,
)
from tmakit.planning.setup import planning_from_dict
from tmakit.reproduce import hurtado2008
from tmakit.sensors.platform import HURTADO_NEHORAI_2008 as HN
from tmakit.sensors.platform import PlatformState

runner = CliRunner()
RADAR = SensorPlan(("bearing", "range", "range_rate"), [math.radians(2.0), 100.0, 5.0])


def example(leg: float = 60.0) -> dict:
    text = (resources.files("tmakit.scenario") / "builtin" / "plan-bearings-only.toml").read_text()
    data = tomllib.loads(text)
    data["planning"]["mission"]["leg_duration"] = leg
    return data


def test_the_pcrb_over_one_run_is_the_deterministic_pcrb_of_its_measurements():
    """One run, no process noise: the recorded information at the truth, carried by the
    recursion, is the PCRB of the same rows at the true trajectory (an independent path)."""
    setup = LoopSetup([-2000.0, 15000.0, 25.0, 0.0], PlatformState([0.0, 0.0], 0.0, 50.0),
                      12, q=0.0, tracker="ekf")
    rec = run_closed_loop(FixedPolicy(HN.kinematics, RADAR), RADAR, setup, 4)
    ours = pcrb_over_runs(rec.information[None], rec.times, setup.prior_covariance,
                          NearlyConstantVelocity(2, 0.0), 0.0)
    k = len(RADAR.kinds)
    rows = MeasurementSet(np.repeat(rec.times, k), ["radar"] * (k * len(rec)),
                          list(RADAR.kinds) * len(rec), np.zeros(k * len(rec)),
                          np.tile([2.0, 100.0, 5.0], len(rec)), np.repeat(rec.sensor, k, 0),
                          check=False)
    theirs = deterministic_pcrb(rows, setup.target, setup.prior_covariance, 0.0)
    np.testing.assert_allclose(ours, theirs.covariance, rtol=1e-8, atol=1e-12)


def test_the_interval_of_the_ratio_holds_for_few_runs_and_for_a_heavy_tail():
    """Ten equal errors look precise to a bootstrap, not to the chi-square; one huge error
    among small ones is what the bootstrap sees; two runs give no interval."""
    round_ = np.diag([50.0**2, 50.0**2])
    thin = np.diag([70.0**2, 1.0])
    even = np.full(10, 0.7 * 70.7)
    r, lo, hi = ratio_interval(even, round_)
    assert r == pytest.approx(0.7, rel=1e-3) and lo < r < hi and hi > 0.9
    assert ratio_interval(even, thin)[2] > hi          # half the degrees of freedom
    assert ratio_interval(np.full(1000, 0.7 * 70.7), round_)[2] < 0.75   # many runs: narrow
    tail = np.array([10.0] * 19 + [3000.0])             # RMSE 671 m over a 70.7 m bound
    r, lo, hi = ratio_interval(tail, round_)
    assert lo < 1.0 < r                                 # one run carries it all
    assert ratio_interval(even[:2], round_)[1:] == (None, None)


def test_the_recorded_information_is_at_the_truth_not_at_the_trackers_cloud():
    setup = LoopSetup([-2000.0, 15000.0, 25.0, 0.0], PlatformState([0.0, 0.0], 0.0, 50.0),
                      5, tracker="pf", particles=200)
    rec = run_closed_loop(FixedPolicy(HN.kinematics, RADAR), RADAR, setup, 1)
    for k in range(len(rec)):
        xi = RADAR.information(rec.truth[k][None], rec.sensor[k])[0]
        np.testing.assert_allclose(rec.information[k], xi, rtol=1e-10)


@pytest.mark.parametrize("tracker", ["ekf", "pf"])
def test_no_case_of_hurtado2008_beats_the_posterior_crb(tracker):
    """RMSE over the bound below 1 beyond its Monte Carlo interval fails (seeded)."""
    study = closed_loop_study(hurtado2008.cases("derived", 300, 40, tracker)[:2], runs=12,
                              seed=5, progress=False)
    for case in study.cases:
        s = study.summary(case)
        assert s["rmse_over_pcrb_high"] >= 1.0, (case, s)
        assert s["rmse_over_pcrb_low"] <= s["rmse_over_pcrb"] <= s["rmse_over_pcrb_high"]
        # the bound is the recursion of the runs' information at the truth
        post = PosteriorInformation.from_prior(study.setups[case].prior_covariance,
                                               NearlyConstantVelocity(2, 0.1), 0.0)
        xi = study.stack(case, "information")
        for k, t in enumerate(study.times(case)):
            post = post.predict_to(t).update(xi[:, k].mean(axis=0))
        assert s["final_pcrb_m"] == pytest.approx(float(post.position_rms), rel=1e-10)


def test_the_hurtado2008_table_names_the_bound_and_the_criterion_and_drops_the_dump():
    res = runner.invoke(app, ["reproduce", "hurtado2008", "--runs", "2", "--steps", "6",
                              "--particles", "100", "--radar", "scenario", "--no-progress"])
    assert res.exit_code == 0, res.output
    words = " ".join(res.stdout.split())
    assert "PCRB" in words and "planning criterion" in words
    assert "the posterior CRB at the true target" in words and "not a bound" in words
    assert "settings:" not in res.stdout and "cases:" not in res.stdout  # no key = value dump
    assert res.stderr == ""


def test_range_hypotheses_are_weighted_quantiles_of_range():
    post = PosteriorInformation.from_prior(np.eye(4), NearlyConstantVelocity(2, 0.0))
    ranges = np.array([5000.0, 1000.0, 3000.0, 2000.0, 4000.0])
    states = np.column_stack([np.zeros(5), ranges, np.zeros(5), np.zeros(5)])
    weights = np.array([0.1, 0.1, 0.1, 0.6, 0.1])     # sorted: 1, 2 (0.6), 3, 4, 5 km
    hyp = range_hypotheses(Belief(post, states, weights), [0.0, 0.0, 0.0], (0.05, 0.5, 0.85))
    assert np.allclose(hyp.states[:, 1], [1000.0, 2000.0, 4000.0])
    assert np.allclose(hyp.weights, 1 / 3)


def test_the_fixed_pattern_is_flown_as_the_scenario_says():
    setup = tk.load_planning("plan-bearings-only")
    track = setup.scenario.sensors["observer"]
    policy = TrackPolicy(track, setup.planner.plan, setup.interval)
    loop = LoopSetup(setup.target, setup.start, 30, setup.interval, setup.q, setup.prior_std,
                     "ekf")
    rec = run_closed_loop(policy, setup.planner.plan, loop, 2)
    np.testing.assert_allclose(rec.sensor, track.states(rec.times), atol=1e-9)


def test_passive_means_no_range_measured():
    assert passive(SensorPlan("bearing", 0.01))
    assert passive(SensorPlan(("bearing", "range_rate"), [0.01, 1.0]))
    assert not passive(RADAR)


def test_a_mission_policy_keeps_its_plan_per_run():
    setup = planning_from_dict(example(120.0))

    steer = policy(setup)
    assert isinstance(steer, MissionPolicy) and steer.pattern is not None
    with pytest.raises(TypeError, match="for_run"):
        steer.recommend(setup.start, None)
    loop = LoopSetup(setup.target, setup.start, 12, setup.interval, setup.q, setup.prior_std,
                     "ekf")
    a = run_closed_loop(steer, setup.planner.plan, loop, 3)
    b = run_closed_loop(steer, setup.planner.plan, loop, 3)   # a fresh plan, the same run
    np.testing.assert_array_equal(a.sensor, b.sensor)
    np.testing.assert_array_equal(a.estimate, b.estimate)


def test_the_mission_planner_flies_a_better_path_than_the_zigzag():
    """Seeded: the planned paths' posterior CRB at the truth is well below the zig-zag's
    (the one-step planner's is far above it; docs/planning.md)."""
    run = tk.plan(planning_from_dict(example(120.0)), runs=2, seed=1, tracker="ekf")
    planned, fixed = run.summary("planned"), run.summary("fixed")
    assert run.setup.kind == "mission"
    assert planned["final_pcrb_m"] < 0.9 * fixed["final_pcrb_m"]


def test_tma_plan_json_has_the_fixed_pattern_beside_the_planned_path():
    res = runner.invoke(app, ["plan", "plan-bearings-only", "--runs", "1", "--duration", "60",
                              "--particles", "200", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["planner"] == "mission" and "range hypotheses" in data["planner_description"]
    for case in ("planned", "fixed"):
        assert {"final_rmse_m", "final_pcrb_m", "rmse_over_pcrb",
                "final_criterion_m"} <= set(data[case])
    assert data["comparison"]["planned_over_fixed"] == pytest.approx(
        data["planned"]["final_rmse_m"] / data["fixed"]["final_rmse_m"])
    assert "closed loop" in res.stderr                 # the progress bar, on stderr


def test_tma_plan_says_when_the_planned_path_is_worse_than_the_pattern():
    """The one-step planner behind a particle filter (the old default) loses to the zig-zag."""
    res = runner.invoke(app, ["plan", "plan-bearings-only", "--runs", "2", "--planner",
                              "horizon", "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "fixed pattern" in res.stdout and "planned / fixed final RMSE" in res.stdout
    assert "warning: the planned path did WORSE" in res.stderr


def test_a_pattern_that_does_not_cover_the_run_is_said():
    data = example()
    sensor = data["sensors"][0]
    for key in ("legs", "start", "heading_deg", "speed"):
        sensor.pop(key)
    sensor.update(type="recorded", times=[0.0, 15.0],
                  positions=[[0.0, 0.0], [15 * 5.6569, 15 * 5.6569]])
    run = tk.plan(planning_from_dict(data), runs=1, duration=20.0, tracker="ekf",
                  planner="horizon")
    assert run.comparison() is None and "does not cover" in run.fixed_note
    assert any("no comparison with a fixed pattern" in w for w in run.warnings())


def test_bad_planner_options_are_refused_by_name():
    res = runner.invoke(app, ["plan", "plan-bearings-only", "--planner", "greedy"])
    assert res.exit_code == 2 and "--planner 'greedy'" in res.output
    data = example()
    data["planning"]["mission"]["leg_duration"] = 15.0
    with pytest.raises(ValueError, match=r"planning\.mission\.leg_duration"):
        planning_from_dict(data)
    with pytest.raises(ValueError, match="quantiles"):
        MissionPolicy(None, (0.0, 0.5))   # type: ignore[arg-type]
