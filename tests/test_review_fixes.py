"""Fixes found by a new user's review: each case a bad or odd input and its honest outcome."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.measurements import KINDS, range_difference_covariance
from tmakit.observation.noise import NoiseModel
from tmakit.observation.rows import MAX_GROUP_ROWS, correlated_blocks, overlapping_groups
from tmakit.planning import Planner, SensorPlan
from tmakit.sensors import PlatformState, platform_configuration

runner = CliRunner()


def _rd_blocks(t, t_ref, sigma):
    """The noise blocks of range differences of one sensor (every row in some block)."""
    t, t_ref, sigma = (np.asarray(a, dtype=float) for a in (t, t_ref, sigma))
    m = t.shape[0]
    return correlated_blocks({"range_difference": KINDS["range_difference"]()},
                             {"range_difference": np.arange(m)}, t, t_ref, sigma,
                             np.zeros(m, dtype=np.int64))


def _groups(t, t_ref):
    """Each row's group number, groups numbered in order of their first reference time."""
    t, t_ref = np.asarray(t, dtype=float), np.asarray(t_ref, dtype=float)
    group = np.empty(t.shape[0], dtype=np.intp)
    for k, rows in enumerate(overlapping_groups(np.arange(t.shape[0]), t, t_ref)):
        group[rows] = k
    return group


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
    blocks = _rd_blocks(t, t_ref, sigma)
    np.testing.assert_array_equal(_dense(blocks, t.shape[0]),
                                  range_difference_covariance(t, t_ref, sigma))
    assert all(np.all(np.diff(rows) > 0) for rows, _ in blocks)
    assert sorted(np.concatenate([rows for rows, _ in blocks]).tolist()) == list(range(300))


def test_consecutive_range_differences_are_independent_groups():
    t = np.arange(1.0, 50001.0)
    group = _groups(t, t - 1.0)  # (t-1, t]: touching, not overlapping
    assert np.array_equal(group, np.arange(50000))
    blocks = _rd_blocks(t, t - 1.0, np.full(t.shape[0], 0.7))
    assert max(rows.size for rows, _ in blocks) == 1  # no 50,000 x 50,000 matrix
    assert _groups([2.0, 3.0, 2.5], [1.0, 2.0, 1.5]).tolist() == [0, 0, 0]
    assert _groups([2.0, 4.0, 3.0], [1.0, 3.0, 2.0]).tolist() == [0, 2, 1]


def test_a_noise_model_of_many_small_groups_whitens_as_the_dense_covariance():
    t = np.repeat(np.arange(1.0, 41.0), 2)
    t_ref = t - np.tile([1.0, 0.5], 40)  # pairs that share the last half interval
    sigma = np.tile([0.7, 0.5], 40)
    blocks = _rd_blocks(t, t_ref, sigma)
    noise = NoiseModel.independent(sigma)
    noise._setup(sigma, blocks)
    w = noise.whiten(np.eye(t.shape[0]), axis=0)
    np.testing.assert_allclose(np.linalg.inv(w.T @ w),
                               range_difference_covariance(t, t_ref, sigma), atol=1e-12)


def test_one_chain_of_too_many_overlapping_range_differences_is_refused():
    n = MAX_GROUP_ROWS + 1
    t = np.arange(1.0, n + 1.0)
    with pytest.raises(ValueError, match=r"share pulse intervals.*consecutive samples"):
        _rd_blocks(t, np.zeros(n), np.ones(n))


# -- planning: settings that cannot work are refused before any run ---------------------------

PLAN_TOML = Path(tk.__file__).parent / "scenario" / "builtin" / "plan-bearings-only.toml"


def _plan_file(tmp_path, edit):
    path = tmp_path / "mine.toml"
    path.write_text(edit(PLAN_TOML.read_text()))
    return path


@pytest.mark.parametrize(("edit", "words"), [
    (lambda t: t + '\n[[planning.constraints]]\ntype = "max_range"\ndistance = 500.0\n',
     "planning.constraints: the minimum range 1000 m is not below the maximum range 500 m"),
    (lambda t: t.replace('criterion = "trace"',
                         'criterion = "trace"\nweights = [0.0, 0.0, 0.0, 0.0]'),
     "planning.weights: all zero"),
    (lambda t: t.replace("horizon = 1", "horizon = 4").replace(
        "heading_changes_deg = [-90.0, -45.0, 0.0, 45.0, 90.0]",
        "heading_changes_deg = [-90.0, -70.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 70.0, 90.0]"
    ).replace("speed_factors = [1.0]", "speed_factors = [0.5, 1.0, 1.5]"),
     "30 actions over a horizon of 4 make 810,000 sequences"),
    (lambda t: t.replace("duration = 600.0", "duration = 1e12"),
     "planning.duration: 100,000,000,000 decisions of 10 s, more than the limit of 1,000,000"),
], ids=["min-above-max-range", "zero-weights", "too-many-sequences", "endless-duration"])
def test_a_plan_that_cannot_work_is_refused_with_the_field(tmp_path, edit, words):
    path = _plan_file(tmp_path, edit)
    result = runner.invoke(app, ["plan", str(path), "--runs", "1", "--no-progress"])
    assert result.exit_code == 2, result.output
    assert result.output.startswith(f"error: {path}") or "mine.toml" in result.output
    assert words in " ".join(result.output.split())


def test_planner_sensor_plan_and_recommend_refuse_wrong_types_by_name():
    cfg = platform_configuration("hurtado_nehorai_2008")
    radar = SensorPlan(["bearing", "range"], [math.radians(1.0), 30.0])
    planner = Planner(cfg.kinematics, cfg.actions, cfg.interval, radar)
    platform = PlatformState((0.0, 0.0), 0.0, 50.0)
    estimate = (np.array([0.0, 15000.0, 25.0, 0.0]), np.diag([500.0**2] * 2 + [10.0**2] * 2))
    assert 0 <= tk.recommend(estimate, platform, planner).index < 15
    for args, words in [((estimate, None, planner), "platform must be a PlatformState"),
                        ((estimate, (0.0, 0.0), planner), "platform must be a PlatformState"),
                        ((estimate, platform, "x"), "planner must be a Planner")]:
        with pytest.raises(TypeError, match=words):
            tk.recommend(*args)
    with pytest.raises(TypeError, match="posterior must be"):
        tk.recommend(estimate, platform, planner, posterior=np.eye(4))
    with pytest.raises(ValueError, match="positive definite"):
        tk.recommend((estimate[0], -estimate[1]), platform, planner)
    with pytest.raises(ValueError, match="one per kind"):
        SensorPlan(["bearing", "range"], [1.0])  # was broadcast: the range sigma became 1 m
    with pytest.raises(ValueError, match="unknown 'bearng'"):
        SensorPlan(["bearng"], [1.0])
    with pytest.raises(ValueError, match="15 actions over a horizon of 9"):
        Planner(cfg.kinematics, cfg.actions, cfg.interval, radar, horizon=9)
    assert Planner(cfg.kinematics, cfg.actions, cfg.interval, radar, horizon=9, beam=5).beam == 5
    with pytest.raises(TypeError, match="actions must be"):
        Planner(cfg.kinematics, None, cfg.interval, radar)
    with pytest.raises(TypeError, match="PlanningSetup"):
        tk.plan(tk.load_scenario("plan-bearings-only"), runs=1)


# -- tma track: a particle filter too small to hold a covariance ------------------------------

def test_track_refuses_fewer_particles_than_a_covariance_needs(tmp_path):
    obs = tmp_path / "obs.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(
        rng=np.random.default_rng(1)), obs)
    for n in ("2", "6"):  # 2 ended in an internal error (a singular covariance)
        result = runner.invoke(app, ["track", str(obs), "--filter", "pf", "--particles", n])
        assert result.exit_code == 2 and result.output.startswith(f"error: --particles {n}:")


def test_the_final_check_of_a_track_says_when_its_covariance_is_singular(capsys):
    from types import SimpleNamespace

    from tmakit.cli.track import print_track_checks

    tr = SimpleNamespace(dof=np.array([0, 1]), nis=np.array([0.0, 1.0]),
                         log_likelihood=np.array([0.0, -1.0]),
                         states=np.array([[0.0, 0.0, 1.0, 1.0]] * 2),
                         covariances=np.zeros((2, 4, 4)))
    print_track_checks(tr, np.array([[3.0, 4.0, 1.0, 1.0]] * 2), 2)
    said = " ".join(capsys.readouterr().out.split())
    assert "final position error 5.0 m, the final covariance is singular" in said


# -- tma montecarlo --workers: no more processes than chunks and CPUs -------------------------

def test_a_huge_worker_count_starts_no_more_processes_than_chunks_and_cpus(monkeypatch):
    from tmakit.montecarlo import execution, monte_carlo

    monkeypatch.setattr(execution, "_cpus", lambda: 2)
    res = monte_carlo("gu2007", runs=4, rng=1, chunk=1, workers=10**20, progress=False)
    assert res.executor == "2 processes, 100,000,000,000,000,000,000 asked: 4 chunks, 2 CPUs"
    one = monte_carlo("gu2007", runs=4, rng=1, chunk=1, progress=False)
    pd.testing.assert_frame_equal(res.table, one.table)
    few = monte_carlo("gu2007", runs=3, rng=1, workers=8, progress=False)  # one chunk
    assert few.executor == "local, 8 asked: 1 chunks, 2 CPUs"


# -- messages --------------------------------------------------------------------------------

def test_a_latlon_file_without_origin_has_one_problem_not_one_per_range_difference(tmp_path):
    from fuzzing import GEO_HEADER, latlon_rows

    path = tmp_path / "geo.csv"
    path.write_text("\n".join([GEO_HEADER, *latlon_rows(10)]) + "\n")
    result = runner.invoke(app, ["show", str(path)])
    assert result.exit_code == 2
    assert result.output.startswith(f"error: {path}: 1 problem in the measurement file")
    assert "no ENU origin is known" in result.output and "time_ref" not in result.output
    ok = runner.invoke(app, ["show", str(path), "--origin", "48.137,11.575,520"])
    assert ok.exit_code == 0, ok.output


def test_import_help_writes_measure_as_it_is_given():
    result = runner.invoke(app, ["import", "--help"])
    assert "--measure COLUMN=KIND:UNIT:SIGMA" in result.output  # was COLUMN:KIND:UNIT:SIGMA


# -- --at / --from / --to: a time the answers can be given at --------------------------------

@pytest.mark.parametrize("args", [
    ["estimate", "{obs}", "--motion", "cv2d", "--at", "nan"],
    ["estimate", "{obs}", "--motion", "cv2d", "--from", "inf"],
    ["crlb", "bearings-only-2d", "--at", "1e300"],
    ["crlb", "bearings-only-2d", "--at", "nan"],
])
def test_a_time_that_is_not_finite_or_overflows_is_refused(tmp_path, args):
    obs = tmp_path / "obs.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(
        rng=np.random.default_rng(1)), obs)
    result = runner.invoke(app, [a.replace("{obs}", str(obs)) for a in args])
    assert result.exit_code == 2, result.output  # was exit 0 with "t = nan" or inf ellipses
    assert result.output.startswith(f"error: {args[-2]} ")


def test_origin_out_of_range_is_refused_and_an_unused_one_is_said(tmp_path):
    obs = tmp_path / "obs.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(
        rng=np.random.default_rng(1)), obs)
    for bad in ("91,0,0", "0,400,0", "nan,0,0", "0,0,inf"):
        result = runner.invoke(app, ["show", str(obs), "--origin", bad])
        assert result.exit_code == 2 and result.output.startswith(f"error: --origin '{bad}'")
    result = runner.invoke(app, ["show", str(obs), "--origin", "48,11,0"])  # an ENU file
    assert result.exit_code == 0
    assert "warning: --origin is for files with sensor_lat/sensor_lon" in result.output


def test_plan_refuses_a_duration_of_more_decisions_than_the_limit():
    result = runner.invoke(app, ["plan", "plan-bearings-only", "--runs", "1", "--duration",
                                 "1e12", "--no-progress"])  # ran out of memory, naming no option
    assert result.exit_code == 2
    assert "--duration 1e+12 s: 100,000,000,000 decisions" in " ".join(result.output.split())


def test_plan_refuses_particles_for_a_tracker_that_has_none():
    result = runner.invoke(app, ["plan", str(PLAN_TOML), "--tracker", "ekf", "--particles", "50",
                                "--runs", "1"])
    assert result.exit_code == 2
    assert "--particles applies only to the particle filter" in result.output


def test_plan_says_when_the_sensor_starts_inside_a_keep_out_zone(tmp_path):
    zone = ('\n[[planning.constraints]]\ntype = "keep_out"\n'
            'polygons = [[[-500.0, -500.0], [500.0, -500.0], [500.0, 500.0], [-500.0, 500.0]]]\n')
    path = _plan_file(tmp_path, lambda text: text + zone)
    result = runner.invoke(app, ["plan", str(path), "--runs", "1", "--duration", "30",
                                 "--no-progress"])
    assert result.exit_code == 0, result.output
    said = " ".join(result.output.split())  # the console wraps long lines
    assert "starts in breach of its keep-out zone constraint (by 500 m)" in said


def test_a_manoeuvre_search_beyond_the_limit_is_refused_and_the_limit_can_be_raised(
        tmp_path, monkeypatch):
    obs = tmp_path / "obs.csv"
    assert runner.invoke(app, ["simulate", "bearings-only-2d", "-o", str(obs)]).exit_code == 0
    result = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear:99"])
    assert result.exit_code == 2
    said = " ".join(result.output.split())
    assert "99 manoeuvres is more than the limit of 5" in said
    assert "TMA_MAX_MANOEUVRES=N" in said
    monkeypatch.setenv("TMA_MAX_MANOEUVRES", "1")
    result = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear:2"])
    assert result.exit_code == 2
    assert "limit of 1" in " ".join(result.output.split())


def test_the_track_says_when_its_innovations_contradict_its_covariances():
    from types import SimpleNamespace

    from tmakit.cli.track import nis_verdict

    def verdict(nis_per_dof, dof):  # a track of one-dof updates, the first not an update
        nis = np.r_[np.nan, np.full(dof, nis_per_dof)]
        return nis_verdict(SimpleNamespace(nis=nis, dof=np.r_[0, np.ones(dof, dtype=int)]))

    assert verdict(1.069, 440) == ""  # a consistent bearings-only track
    said = verdict(6.5, 886)  # a manoeuvring target tracked as constant velocity
    assert "larger than the track's covariances allow" in said and "overconfident" in said
    assert "smaller than the measurement sigmas imply" in verdict(300.0 / 440, 440)


def test_tracking_a_manoeuvring_target_as_constant_velocity_is_flagged(tmp_path):
    obs = tmp_path / "h.csv"
    assert runner.invoke(app, ["simulate", "hoerst2010", "-o", str(obs)]).exit_code == 0
    result = runner.invoke(app, ["track", str(obs), "--filter", "ekf"])
    assert result.exit_code == 4, result.output  # diverged: no answer
    assert "warning: the innovations are larger" in " ".join(result.output.split())
