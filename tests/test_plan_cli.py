"""The scenario ``[planning]`` table, ``recommend``, ``tk.plan`` and ``tma plan`` (fast)."""

from __future__ import annotations

import copy
import math
import re
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.filters import ExtendedKalmanFilter
from tmakit.planning import MinimumRange, Planner, SensorPlan, recommend
from tmakit.planning.setup import planning_from_dict
from tmakit.scenario.files import ScenarioFileError
from tmakit.sensors import PlatformState, platform_configuration

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()
FAST = ["--runs", "1", "--duration", "40", "--particles", "200", "--no-progress"]


def example() -> dict:
    text = (resources.files("tmakit.scenario") / "builtin" / "plan-bearings-only.toml").read_text()
    return tomllib.loads(text)


def test_the_builtin_planning_table_builds_its_setup():
    setup = tk.load_planning("plan-bearings-only")
    assert setup.sensor == "observer" and setup.steps == 60 and setup.interval == 10.0
    assert setup.start.time == 0.0 and float(setup.start.speed) == 8.0
    assert float(setup.start.heading) == pytest.approx(math.radians(45.0))
    assert np.allclose(setup.target, [4000.0, 9000.0, -6.0, -3.0])
    p = setup.planner
    assert len(p.actions) == 5 and p.kinematics.max_turn_rate == pytest.approx(math.radians(9))
    assert np.allclose(np.degrees(p.actions.heading_change), [-90, -45, 0, 45, 90])
    assert p.plan.kinds == ("bearing",) and p.plan.sigmas[0] == pytest.approx(math.radians(1))
    assert isinstance(p.constraints[0], MinimumRange) and p.constraints[0].distance == 1000.0
    assert setup.prior_std == (5000.0, 10.0) and setup.tracker == "pf"


def test_named_platform_angle_convention_and_polygons():
    data = example()
    data["angle_convention"] = "east_ccw"
    data["sensors"][0]["heading_deg"] = 45.0
    data["origin"] = [45.0, 7.0, 0.0]
    pl = data["planning"]
    pl.pop("interval")
    pl.pop("actions")
    pl.pop("limits")
    pl["platform"] = "hurtado_nehorai_2008"
    pl["duration"] = 5.0
    pl["criterion"] = "logdet"
    pl["constraints"] = [
        {"type": "keep_out", "polygons": [[[0, 0], [100, 0], [100, 100]]], "hard": False},
        {"type": "operating_area", "polygon_geodetic": [[44.9, 6.9], [44.9, 7.1], [45.1, 7.1],
                                                        [45.1, 6.9]]}]
    setup = planning_from_dict(data)
    assert setup.steps == 10 and len(setup.planner.actions) == 15
    assert setup.planner.criterion.name == "log det"
    assert [c.name for c in setup.planner.constraints] == ["keep-out zone", "operating area"]


@pytest.mark.parametrize(("change", "field"), [
    (lambda p: p.update(gamma="median"), "planning.gamma"),
    (lambda p: p.update(tracker="kalman"), "planning.tracker"),
    (lambda p: p.update(horizon=0), "planning.horizon"),
    (lambda p: p.update(surprise=1), "planning.surprise"),
    (lambda p: p.pop("prior"), "planning.prior"),
    (lambda p: p["limits"].update(max_turn_rate_deg_s=-1), "planning.limits.max_turn_rate_deg_s"),
    (lambda p: p["actions"].update(speed_factors=[0.0]), "planning.actions.speed_factors"),
    (lambda p: p["measurements"][0].update(sigma=0), "planning.measurements[0].sigma"),
    (lambda p: p["measurements"][0].update(kind="smell"), "planning.measurements[0].kind"),
    (lambda p: p["constraints"][0].update(type="near"), "planning.constraints[0]"),
    (lambda p: p["constraints"][0].update(distance=-5), "planning.constraints[0]"),
    (lambda p: p.update(sensor="ghost"), "planning.sensor"),
    (lambda p: p.update(duration=55.0), "planning.duration"),
    (lambda p: p.update(weights=[1.0, 1.0]), "planning.weights"),
    (lambda p: p["limits"].update(min_speed=9.0), "planning.limits"),
    (lambda p: p.update(constraints=[{"type": "operating_area",
                                      "polygon_geodetic": [[0, 0], [0, 1], [1, 1]]}]),
     "planning.constraints[0]"),
])
def test_bad_planning_fields_are_refused_naming_the_field(change, field):
    data = copy.deepcopy(example())
    change(data["planning"])
    with pytest.raises(ScenarioFileError) as info:
        planning_from_dict(data, "mine.toml")
    message = str(info.value)
    assert message.startswith("mine.toml:") and field in message, message


def test_a_scenario_without_planning_is_refused_by_load_planning():
    with pytest.raises(ScenarioFileError, match=r"no \[planning\] table"):
        tk.load_planning("bearings-only-2d")


def ekf_and_planner():
    cfg = platform_configuration("hurtado_nehorai_2008")
    plan = SensorPlan(["bearing", "range"], [math.radians(1.0), 30.0])
    planner = Planner(cfg.kinematics, cfg.actions, cfg.interval, plan)
    ekf = ExtendedKalmanFilter([-2000.0, 15000.0, 25.0, 0.0],
                               np.diag([500.0**2] * 2 + [10.0**2] * 2), 0.0, q=0.1)
    return ekf, planner


def test_recommend_from_an_ekf_picks_the_least_predicted_bound():
    ekf, planner = ekf_and_planner()
    platform = PlatformState((0.0, 0.0), 0.0, 50.0)
    rec = recommend(ekf, platform, planner)
    assert rec.bound.shape == (15,) and np.all(np.isfinite(rec.bound))
    assert rec.index == int(np.argmin(rec.bound))
    assert np.ptp(rec.bound) > 0          # the candidates differ
    pair = recommend((ekf.state, ekf.covariance), platform, planner, q=0.1)
    assert pair.index == rec.index and np.allclose(pair.bound, rec.bound)


def test_recommend_refuses_a_tracker_at_another_time_and_a_bad_estimate():
    ekf, planner = ekf_and_planner()
    with pytest.raises(ValueError, match="predict the tracker"):
        recommend(ekf, PlatformState((0.0, 0.0), 0.0, 50.0, time=5.0), planner)
    with pytest.raises(ValueError, match="mean"):
        recommend((np.zeros(3), np.eye(3)), PlatformState((0.0, 0.0), 0.0, 50.0), planner)


def test_tma_plan_runs_the_example_and_writes_its_table(tmp_path):
    out = tmp_path / "plan.csv"
    result = runner.invoke(app, ["plan", "plan-bearings-only", "-o", str(out), *FAST])
    assert result.exit_code == 0, result.output
    assert "final position RMSE" in result.output and "minimum range" in result.output
    import pandas as pd

    table = pd.read_csv(out)
    assert len(table) == 8 and list(table["step"]) == [1, 2, 3, 4] * 2
    assert list(table["case"]) == ["planned"] * 4 + ["fixed"] * 4
    for col in ("sensor_x", "sensor_y", "estimate_x", "truth_x", "criterion_m", "error_m",
                "range_m", "action", "violation_m"):
        assert col in table.columns
    planned = table[table["case"] == "planned"]
    assert np.all(planned["range_m"] >= 1000.0)        # the hard minimum range


def test_tma_plan_interrupted_keeps_its_finished_chunks(tmp_path, monkeypatch):
    """Ctrl-C in a long tma plan lost every finished run; its chunks are saved as they end."""
    import pandas as pd

    import tmakit.montecarlo.closed_loop as loop

    real = loop.execute

    def interrupted_after_first_chunk(tasks, client, label, runs, progress, on_chunk=None,
                                      **kwargs):
        real(tasks[:1], client, label, len(tasks[0].seeds), progress, on_chunk, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(loop, "execute", interrupted_after_first_chunk)
    out = tmp_path / "plan.parquet"
    result = runner.invoke(app, ["plan", "plan-bearings-only", "-o", str(out), "--runs", "6",
                                 "--duration", "20", "--particles", "100", "--no-progress"])
    assert result.exit_code == 130, result.output
    assert not out.exists()
    assert f"1 finished chunk(s) of the per-step table kept in {tmp_path / 'plan.parquet.parts'}" \
        in result.output
    parts = sorted((tmp_path / "plan.parquet.parts").glob("*.parquet"))
    assert [p.name for p in parts] == ["planned-000000.parquet"]
    table = pd.read_parquet(parts[0])
    assert sorted(set(table["run"])) == [0, 1, 2, 3, 4] and set(table["step"]) == {1, 2}


def test_tma_plan_refuses_bad_outputs_before_running(tmp_path):
    existing = tmp_path / "plan.csv"
    existing.write_text("keep me\n")
    for args in (["-o", str(existing)], ["-o", str(tmp_path / "missing" / "p.csv")],
                 ["--plot", str(tmp_path / "nowhere" / "p.png")], ["-o", str(tmp_path / "p.txt")]):
        result = runner.invoke(app, ["plan", "plan-bearings-only", *args, *FAST])
        assert result.exit_code == 2, (args, result.output)
        assert "error:" in result.output and "Traceback" not in result.output
        assert result.exception is None or isinstance(result.exception, SystemExit)
    assert existing.read_text() == "keep me\n"
    bad = tmp_path / "bad.toml"
    data = (resources.files("tmakit.scenario") / "builtin" / "plan-bearings-only.toml").read_text()
    bad.write_text(data.replace('gamma = "mean"', 'gamma = "median"'))
    result = runner.invoke(app, ["plan", str(bad), *FAST])
    assert result.exit_code == 2 and "planning.gamma" in result.output


def snippets(kind: str) -> list[str]:
    text = (ROOT / "docs" / "planning.md").read_text(encoding="utf-8")
    return re.findall(rf"```{kind}\n(.*?)```", text, flags=re.S)


def test_the_toml_of_docs_planning_is_a_valid_planning_table():
    block = snippets("toml")[0]
    data = example()
    data["planning"] = tomllib.loads(block)["planning"]
    setup = planning_from_dict(data, "docs/planning.md")
    assert setup.planner.horizon >= 1


def test_plan_counts_every_violated_step_of_every_run():
    data = example()
    data["planning"]["constraints"] = [{"type": "min_range", "distance": 50000.0,
                                        "hard": False, "weight": 1.0}]
    run = tk.plan(planning_from_dict(data), runs=2, duration=20.0, particles=100, rng=3)
    summary = run.summary()
    assert summary["violations"] == 4 and summary["runs"] == 2 and summary["steps"] == 2
    assert summary["max_violation_m"] > 1000.0
    assert np.all(run.table()["violation_minimum_range_m"] > 0.0)


def test_tma_plan_names_the_missing_table_and_the_bad_duration():
    result = runner.invoke(app, ["plan", "bearings-only-2d"])
    assert result.exit_code == 2 and "no [planning] table" in result.output
    result = runner.invoke(app, ["plan", "plan-bearings-only", "--duration", "15"])
    assert result.exit_code == 2 and "--duration" in result.output
    # the count was printed in full: 301 digits with their commas
    result = runner.invoke(app, ["plan", "plan-bearings-only", "--runs", "1000000000"])
    assert result.exit_code == 2 and "--runs 1,000,000,000: more than the limit" in result.output
    result = runner.invoke(app, ["plan", "plan-bearings-only", "--duration", "1e300"])
    assert result.exit_code == 2 and ("--duration 1e+300 s: 1e+299 decisions of 10 s per run, "
                                      "more than the limit of 1,000,000") in result.output
