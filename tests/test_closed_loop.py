"""The closed loop (planner, measurements, tracker, bound), its Monte Carlo and reproduction."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from tmakit.cli import app
from tmakit.io.tables import LoopCheckpoint
from tmakit.montecarlo.closed_loop import (
    LoopCase,
    LoopSetup,
    closed_loop_study,
    run_closed_loop,
    simulate_group,
)
from tmakit.planning import MinimumRange, OperatingArea, Planner, SensorPlan
from tmakit.planning.policies import FixedPolicy
from tmakit.sensors.platform import HURTADO_NEHORAI_2008 as HN
from tmakit.sensors.platform import Actions, PlatformState

PLAN = SensorPlan(("bearing", "range", "range_rate"), [math.radians(2.0), 100.0, 5.0])
# the radar's sigmas (range rate of no use): the planner goes for the target
RADAR = SensorPlan(("bearing", "range", "range_rate"), [math.radians(2.35), 150.0, 1000.0])


def _setup(steps: int = 30, tracker: str = "pf", target=(-2000.0, 15000.0, 25.0, 0.0),
           **kw) -> LoopSetup:
    return LoopSetup(target=target, platform=PlatformState([0.0, 0.0], 0.0, 50.0),
                     steps=steps, tracker=tracker, **{"particles": 300, **kw})


def test_one_candidate_planner_reproduces_the_fixed_path_exactly():
    setup = _setup()
    fixed = run_closed_loop(FixedPolicy(HN.kinematics, PLAN), PLAN, setup, 7)
    one = run_closed_loop(Planner(HN.kinematics, Actions([0.0]), 0.5, PLAN), PLAN, setup, 7)
    assert np.array_equal(fixed.estimate, one.estimate)
    assert np.array_equal(fixed.covariance, one.covariance)
    assert np.array_equal(fixed.sensor, one.sensor)
    assert np.array_equal(fixed.criterion_m, one.criterion_m)
    assert np.array_equal(fixed.information, one.information)
    # the fixed path flies North at 50 m/s
    assert np.allclose(fixed.sensor[:, 1], 50.0 * fixed.times)
    assert np.allclose(fixed.sensor[:, 0], 0.0, atol=1e-9)


@pytest.mark.parametrize("tracker", ["pf", "ekf", "ukf"])
def test_seeded_runs_are_deterministic_and_trackers_follow_the_target(tracker):
    setup = _setup(40, tracker)
    pol = Planner(HN.kinematics, HN.actions, 0.5, PLAN)
    a = run_closed_loop(pol, PLAN, setup, 3)
    b = run_closed_loop(pol, PLAN, setup, 3)
    assert np.array_equal(a.estimate, b.estimate) and np.array_equal(a.action, b.action)
    assert len(set(a.action.tolist())) > 1  # the planner manoeuvres
    # the estimate stays within a few bounds of the truth (a working tracker)
    assert np.all(a.error_m < 6 * a.criterion_m + 50.0)
    assert a.criterion_m[-1] < a.criterion_m[0]


def test_recorded_criterion_is_the_planners_prediction_when_both_use_the_mean():
    setup = _setup(20, criterion_gamma="mean")
    rec = run_closed_loop(Planner(HN.kinematics, HN.actions, 0.5, PLAN), PLAN, setup, 2)
    assert np.allclose(rec.criterion_m, rec.predicted_criterion_m, rtol=1e-9)


def test_hard_constraints_are_respected_in_a_seeded_closed_loop():
    limit = 2000.0
    target = (0.0, 4000.0, 25.0, 0.0)
    area = OperatingArea([(-6000.0, -3000.0), (6000.0, -3000.0), (6000.0, 8000.0),
                          (-6000.0, 8000.0)])
    free = run_closed_loop(Planner(HN.kinematics, HN.actions, 0.5, RADAR), RADAR,
                           _setup(80, target=target), 4)
    assert free.range_m.min() < limit  # the limit binds: unconstrained, the radar goes closer
    cons = (MinimumRange(limit + 600.0), area)
    setup = _setup(80, target=target)
    rec = run_closed_loop(Planner(HN.kinematics, HN.actions, 0.5, RADAR, constraints=cons),
                          RADAR, setup, 4)
    assert set(rec.violations) == {"minimum_range", "operating_area"}
    assert np.all(rec.violations["operating_area"] == 0.0)
    # A one-step planner reaching the padded limit at speed cannot always turn away in one
    # step (it then flies the least violating candidate); the 600 m pad, about the turn
    # radius at 200 m/s, is what keeps the limit itself.
    assert np.all(rec.violations["minimum_range"] < 600.0)
    # checked again here: at each step's end, range to the estimated target moved on
    f = np.array([[1, 0, 0.5, 0], [0, 1, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    est_end = rec.estimate[:-1] @ f.T
    ranges = np.linalg.norm(rec.sensor[1:, :2] - est_end[:, :2], axis=1)
    assert ranges.min() >= limit
    # the recorded amounts (largest over the step) cover the step ends (to the metre: the
    # planner sees the cloud after resampling, the estimate is the mean before it)
    assert np.all(rec.violations["minimum_range"][1:]
                  >= np.clip(limit + 600.0 - ranges, 0, None) - 1.0)
    assert rec.range_m.min() >= limit
    assert np.all(np.abs(rec.sensor[:, :2]) <= [6000.0, 8000.0])


def test_simulated_noise_has_the_groups_covariance():
    group = PLAN.group
    rng = np.random.default_rng(0)
    x = np.array([1000.0, 9000.0, 20.0, -5.0])
    s = np.array([0.0, 0.0, 0.0, 0.0, 50.0, 0.0])
    clean = group.predict(x, s[None])
    draws = np.array([simulate_group(group, x, s, rng, 3.0).value_si for _ in range(4000)])
    cov = np.cov((draws - clean).T)
    assert np.allclose(np.sqrt(np.diag(cov)), PLAN.sigmas, rtol=0.05)
    one = simulate_group(group, x, s, rng, 3.0)
    assert np.all(one.time == 3.0) and list(one.kind) == list(PLAN.kinds)


def test_bad_setups_are_refused_by_name():
    with pytest.raises(ValueError, match="particles"):
        _setup(particles=1)
    with pytest.raises(ValueError, match="tracker"):
        _setup(tracker="kalman")
    with pytest.raises(ValueError, match="steps"):
        _setup(0)
    with pytest.raises(ValueError, match="criterion_gamma"):
        _setup(criterion_gamma="all")
    with pytest.raises(ValueError, match="once per decision"):
        plan = SensorPlan(("bearing",), [0.01], times=(0.25, 0.5))
        run_closed_loop(FixedPolicy(HN.kinematics, plan), plan, _setup(2), 0)


def _cases(steps: int = 8) -> list[LoopCase]:
    setup = _setup(steps)
    return [LoopCase("fixed", FixedPolicy(HN.kinematics, PLAN), PLAN, setup),
            LoopCase("adaptive", Planner(HN.kinematics, HN.actions, 0.5, PLAN,
                                         constraints=(MinimumRange(5000.0, hard=False),)),
                     PLAN, setup)]


def _drop_timing(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["decision_ms"])


def test_study_is_the_same_local_chunked_and_run_by_run():
    a = closed_loop_study(_cases(), runs=3, seed=11, progress=False)
    b = closed_loop_study(_cases(), runs=3, seed=11, chunk=1, progress=False)
    pd.testing.assert_frame_equal(_drop_timing(a.table()), _drop_timing(b.table()))
    # run r is the run with child r of the study's seed, whatever the number of runs
    c = closed_loop_study(_cases(), runs=2, seed=11, progress=False)
    assert np.array_equal(c.stack("adaptive", "estimate"), a.stack("adaptive", "estimate")[:2])
    # the cases meet the same draws: the first decision's measurement is the same
    assert np.array_equal(a.stack("fixed", "truth"), a.stack("adaptive", "truth"))
    s = a.summary("adaptive")
    assert set(s) == {"final_rmse_m", "final_pcrb_m", "rmse_over_pcrb", "rmse_over_pcrb_low",
                      "rmse_over_pcrb_high", "final_criterion_m", "min_range_m",
                      "mean_decision_ms", "runs"} and s["runs"] == 3
    assert s["rmse_over_pcrb_low"] is None     # no interval from 3 runs


def test_per_step_table_round_trips_through_parquet_chunk_by_chunk(tmp_path):
    path = tmp_path / "loop.parquet"
    ckpt = LoopCheckpoint(path)
    study = closed_loop_study(_cases(5), runs=2, seed=1, chunk=1, progress=False,
                              on_chunk=ckpt)
    assert len(list(ckpt.parts.glob("*.parquet"))) == 4  # each chunk saved when done
    ckpt.finish(study)
    assert not ckpt.parts.exists()
    back = pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, study.table())
    assert {"run", "case", "step", "time", "sensor_x", "sensor_y", "action", "criterion_m",
            "error_m", "range_m", "decision_ms", "violation_m"} <= set(back.columns)
    assert "violation_minimum_range_m" in back.columns
    with pytest.raises(FileExistsError):
        LoopCheckpoint(path)


runner = CliRunner()


def test_reproduce_hurtado2008_runs_and_writes_json(tmp_path):
    out = tmp_path / "steps.parquet"
    res = runner.invoke(app, ["reproduce", "hurtado2008", "--runs", "2", "--steps", "6",
                              "--particles", "100", "--radar", "scenario", "--json",
                              "--output", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)     # the progress bar is on standard error
    assert "closed loop" in res.stderr
    cases = data["figures"]["cases"]
    assert list(cases) == ["fixed", "adaptive", "min-range hard", "min-range penalty"]
    for figures in cases.values():
        assert set(figures) == {"final_rmse_m", "final_pcrb_m", "rmse_over_pcrb",
                                "rmse_over_pcrb_low", "rmse_over_pcrb_high",
                                "final_criterion_m", "min_range_m", "mean_decision_ms", "runs"}
        assert figures["runs"] == 2
    assert len(pd.read_parquet(out)) == 4 * 2 * 6


@pytest.mark.parametrize(("args", "message"), [
    (["--particles", "1"], "--particles must be 2 or more"),
    (["--steps", "1"], "--steps must be 3 or more"),
    (["--radar", "sonar"], "--radar must be one of"),
    (["--tracker", "kalman"], "--tracker must be one of"),
    (["--runs", "0"], "--runs must be >= 1"),
    (["--output", "x.txt"], "--output"),
    # 1e8 steps ran on for hours (a plan's duration is held to 1,000,000 decisions)
    (["--steps", "100000000"], "--steps must be within [3, 1,000,000] (decisions per run"),
    # a billion runs filled 1.8 GB with their seeds in 25 s, nothing said
    (["--runs", "1000000000"], "--runs 1,000,000,000: more than the limit of 1,000,000 runs"),
])
def test_reproduce_hurtado2008_refuses_bad_options(args, message):
    res = runner.invoke(app, ["reproduce", "hurtado2008", "--radar", "scenario", *args]
                        if "--radar" not in args else ["reproduce", "hurtado2008", *args])
    assert res.exit_code == 2
    assert message in res.output
    assert "Traceback" not in res.output


def test_other_reproductions_refuse_the_loop_options():
    res = runner.invoke(app, ["reproduce", "gu2007", "--runs", "0", "--particles", "10"])
    assert res.exit_code == 2 and "takes no such option" in res.output


@pytest.mark.parametrize("tracker", ["ekf", "pf"])
def test_the_tracker_updates_with_the_plans_full_covariance(tracker, monkeypatch):
    """A plan with correlated rows (the derived radar's range and range rate) reaches the
    tracker whole: its update is the group with R, not the rows' marginal sigmas."""
    from tmakit.filters import FILTERS
    from tmakit.observation import MeasurementGroup

    r = np.diag([math.radians(2.0), 100.0, 50.0]) ** 2
    r[1, 2] = r[2, 1] = -0.99 * 100.0 * 50.0
    plan = SensorPlan(PLAN.kinds, np.sqrt(np.diag(r)), covariance=r)
    seen = []
    cls = FILTERS[tracker]
    update = cls.update

    def spy(self, rows):
        seen.append(rows)
        return update(self, rows)

    monkeypatch.setattr(cls, "update", spy)
    setup = _setup(20, tracker)
    full = run_closed_loop(FixedPolicy(HN.kinematics, plan), plan, setup, 5)
    assert len(seen) == 20
    assert all(isinstance(g, MeasurementGroup) for g in seen)
    np.testing.assert_array_equal(seen[0].covariance, r)
    # the same seed with independent rows of the same sigmas: the tracker is given no R
    seen.clear()
    marginal = SensorPlan(PLAN.kinds, np.sqrt(np.diag(r)))
    alone = run_closed_loop(FixedPolicy(HN.kinematics, marginal), marginal, setup, 5)
    assert not any(isinstance(g, MeasurementGroup) for g in seen)
    assert not np.allclose(full.estimate, alone.estimate)
    # the correlation pins range given range rate: the tracker is better for it
    assert np.mean(full.error_m[-5:]) < np.mean(alone.error_m[-5:])
