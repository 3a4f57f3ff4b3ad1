"""The `tma` command: simulate, show, demo, scenarios; refusals and error messages."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, list(args))


def test_scenarios_lists_every_builtin_with_a_line_each():
    result = run("scenarios")
    assert result.exit_code == 0
    for name in ("gu2007", "doppler-lecture", "hoerst2010", "chen-sun-1", "chen-sun-2",
                 "chen-sun-3", "hurtado2008"):
        assert name in result.output


def test_simulate_writes_a_file_that_reads_back_and_matches_the_library(tmp_path):
    out = tmp_path / "obs.csv"
    result = run("simulate", "gu2007", "--seed", "5", "-o", str(out))
    assert result.exit_code == 0, result.output
    assert "wrote 240 measurements" in result.output
    meas = tk.read_measurements(out)
    direct = tk.load_scenario("gu2007").simulate(rng=5)
    assert np.array_equal(meas.value, direct.value)
    assert meas.metadata["seed"] == "5"


def test_simulate_parquet_and_no_noise(tmp_path):
    out = tmp_path / "clean.parquet"
    assert run("simulate", "chen-sun-2", "--no-noise", "-o", str(out)).exit_code == 0
    meas = tk.read_measurements(out)
    clean = tk.load_scenario("chen-sun-2").simulate(noise=False)
    assert np.array_equal(meas.value, clean.value)


def test_simulate_refuses_to_overwrite_without_force(tmp_path):
    out = tmp_path / "obs.csv"
    out.write_text("precious data\n")
    result = run("simulate", "gu2007", "-o", str(out))
    assert result.exit_code == 2
    assert "already exists" in result.output and "--force" in result.output
    assert out.read_text() == "precious data\n"
    assert run("simulate", "gu2007", "-o", str(out), "--force").exit_code == 0
    assert len(tk.read_measurements(out)) == 240


def test_simulate_unknown_scenario_is_a_clear_error(tmp_path):
    out = tmp_path / "obs.csv"
    result = run("simulate", "gu2008", "-o", str(out))
    assert result.exit_code == 2
    assert "unknown scenario 'gu2008'" in result.output
    assert not out.exists()


def test_show_prints_a_table_per_sensor_and_kind_and_draws(tmp_path):
    obs = tmp_path / "obs.csv"
    png = tmp_path / "obs.png"
    run("simulate", "gu2007", "--seed", "1", "-o", str(obs))
    result = run("show", str(obs), "--plot", str(png))
    assert result.exit_code == 0, result.output
    for text in ("uav", "power", "frequency", "120", "dBm", "Hz"):
        assert text in result.output
    assert png.exists() and png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = run("show", str(obs), "--plot", str(png))
    assert again.exit_code == 2 and "already exists" in again.output


def test_show_refuses_a_bad_file_naming_row_and_column_and_writes_nothing(tmp_path):
    obs = tmp_path / "obs.csv"
    png = tmp_path / "obs.png"
    run("simulate", "hoerst2010", "--seed", "1", "-o", str(obs))
    lines = obs.read_text().splitlines()
    header_at = next(i for i, line in enumerate(lines) if line.startswith("time,"))
    cols = lines[header_at].split(",")
    row = lines[header_at + 3].split(",")
    row[cols.index("sigma")] = "-2.0"
    lines[header_at + 3] = ",".join(row)
    obs.write_text("\n".join(lines) + "\n")
    result = run("show", str(obs), "--plot", str(png))
    assert result.exit_code == 2
    assert "row 3" in result.output and "sigma" in result.output
    assert not png.exists()


def test_show_missing_file(tmp_path):
    result = run("show", str(tmp_path / "nothing.csv"))
    assert result.exit_code == 2 and "no such file" in result.output


def test_demo_is_rerunnable_in_its_own_folder_and_spares_other_folders(tmp_path):
    folder = tmp_path / "demo"
    result = run("demo", "--out-dir", str(folder))
    assert result.exit_code == 0, result.output
    assert (folder / "gu2007.csv").exists() and (folder / "gu2007.png").exists()
    assert "gu2007" in result.output
    (folder / "stale.txt").write_text("left by an earlier run")
    again = run("demo", "--out-dir", str(folder))  # its own folder: replaced
    assert again.exit_code == 0, again.output
    assert (folder / "gu2007.csv").exists() and not (folder / "stale.txt").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("the user's")
    refused = run("demo", "--out-dir", str(mine))
    assert refused.exit_code == 2 and "--force" in refused.output
    assert (mine / "notes.txt").read_text() == "the user's"


@pytest.mark.parametrize("origin", ["1,2", "a,b,c"])
def test_bad_origin_is_refused(tmp_path, origin):
    obs = tmp_path / "obs.csv"
    run("simulate", "gu2007", "-o", str(obs))
    result = run("show", str(obs), "--origin", origin)
    assert result.exit_code == 2 and "LAT,LON,ALT" in result.output


def test_crlb_of_a_scenario_says_which_nuisance_convention(tmp_path):
    unknown = run("crlb", "gu2007")
    assert unknown.exit_code == 0
    assert "unknown" in unknown.output and "6.04" in unknown.output
    known = run("crlb", "gu2007", "--known-nuisance")
    assert known.exit_code == 0 and "known" in known.output and "3.923" in known.output


def test_crlb_of_a_file_json_keys_and_unobservable_nulls(tmp_path):
    import json

    obs = tmp_path / "obs.csv"
    run("simulate", "doppler-lecture", "-o", str(obs))
    result = run("crlb", str(obs), "--motion", "cv3d", "--ref-time", "120",
                 "--truth", "x=-6400,y=21000,z=8000,vx=-180,vy=-126,vz=0", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert {"parameters", "std", "covariance", "rank", "unobservable"} <= set(data)
    assert data["rank"] == 4 and data["std"][:6] == [None] * 6
    assert len(data["unobservable"]) == 3
    # the trust of estimate and track: a warning naming each unobservable direction in words
    assert data["trust"] == "warning"
    reasons = data["trust_reasons"]
    assert [r["code"] for r in reasons] == ["unobservable"] * 3
    assert [r["message"].split(": ", 1)[1] for r in reasons] == [
        d["sentence"] for d in data["unobservable"]]


def test_crlb_trust_ok_when_every_parameter_is_bounded():
    """``tma crlb``: ``trust: ok`` in the table and JSON when the bound is finite throughout."""
    import json

    data = json.loads(run("crlb", "gu2007", "--json").output)
    assert data["unobservable"] == []
    assert data["trust"] == "ok" and data["trust_reasons"] == []
    text = run("crlb", "gu2007")
    assert text.exit_code == 0 and "trust: ok" in text.output


def test_crlb_refuses_a_bad_truth(tmp_path):
    obs = tmp_path / "obs.csv"
    run("simulate", "gu2007", "-o", str(obs))
    result = run("crlb", str(obs), "--motion", "cv2d", "--truth", "x=1,y")
    assert result.exit_code == 2 and "name=value" in result.output
    result = run("crlb", str(obs), "--motion", "cv2d", "--truth", "x=1,y=2")
    assert result.exit_code == 2 and "missing vx, vy" in result.output
    # a truth at 1e300 m was bounded as 'rank 0 of 4 - NOT fully observable'
    result = run("crlb", str(obs), "--motion", "cv2d", "--truth", "x=1e300,y=0,vx=0,vy=0")
    assert result.exit_code == 2 and ("truth x=1e+300: expected positions within 1e+09 m of "
                                      "the origin") in " ".join(result.output.split())
    with pytest.raises(ValueError, match="truth vx=1e"):
        tk.crlb(tk.read_measurements(obs), tk.ConstantVelocity(2, 0.0),
                truth={"x": 0.0, "y": 0.0, "vx": 1e9, "vy": 0.0})
    # --at 1e12 was answered (std 3e11 m) where tma estimate refuses it
    result = run("crlb", str(obs), "--motion", "cv2d", "--truth", "x=1,y=2,vx=0,vy=0",
                 "--at", "1e12")
    assert result.exit_code == 2 and "--at 1000000000000: 1e+12 s from the measurements" in (
        " ".join(result.output.split()))


def test_estimate_without_a_guess_text_and_json(tmp_path):
    import json

    obs = tmp_path / "obs.csv"
    run("simulate", "gu2007", "--seed", "2", "-o", str(obs))
    text = run("estimate", str(obs), "--motion", "cv2d")
    assert text.exit_code == 0, text.output
    assert "converged" in text.output and "carrier" in text.output
    result = run("estimate", str(obs), "--json")  # motion taken from the file's metadata
    data = json.loads(result.output)
    assert {"parameters", "estimate", "std", "nuisance", "status", "iterations", "chi2",
            "dof"} <= set(data)
    assert data["status"] == "converged"
    assert abs(data["estimate"][0] - 3200) < 5 * data["std"][0]
    ratio = run("estimate", str(obs), "--motion", "cv2d", "--method", "ratio",
                "--init", "x=4900,y=1200,vx=0,vy=0")
    assert ratio.exit_code == 0 and "ratio" in ratio.output


def test_estimate_reports_unobservable_with_exit_status_4(tmp_path):
    obs = tmp_path / "obs.csv"
    run("simulate", "doppler-lecture", "-o", str(obs))
    result = run("estimate", str(obs), "--motion", "cv3d", "--ref-time", "120")
    assert result.exit_code == 4
    assert "unobservable" in result.output and "rotation" in result.output


def test_a_reference_time_far_from_the_data_is_refused(tmp_path):
    # An absolute clock given to relative times (or a typo) would make the fit lose its
    # digits: refused with the data's times and the reach, before any fit; near is fitted.
    obs = tmp_path / "obs.csv"
    run("simulate", "bearings-only-2d", "-o", str(obs))
    for command in ("estimate", "crlb"):
        far = run(command, str(obs), "--motion", "cv2d", "--ref-time", "1777887010")
        assert far.exit_code == 2, far.output
        assert "--ref-time 1777887010:" in far.output and "(t = 1 ... 600 s)" in far.output
        assert "Traceback" not in far.output
    near = run("estimate", str(obs), "--motion", "cv2d", "--ref-time", "-5000")
    assert near.exit_code == 0, near.output
    # The time the parameters are at is said, in the text and in the JSON.
    assert "parameters at the motion's reference time t = -5000 s" in near.output
    as_json = run("estimate", str(obs), "--motion", "cv2d", "--ref-time", "-5000", "--json")
    assert json.loads(as_json.output)["ref_time"] == -5000.0
    static = tk.estimate(tk.load_scenario("bearings-only-2d").simulate(rng=1), "static2d")
    assert static.as_dict()["ref_time"] is None  # (a fixed emitter is at no time)
    fixed = run("crlb", str(obs), "--motion", "static2d", "--ref-time", "1e7",
                "--truth", "x=1000,y=9000")  # (a fixed emitter: no velocity to lose digits to)
    assert fixed.exit_code == 0, fixed.output
    # A file's own motion and reference time (a number assigned into its metadata is written
    # as text): the same refusal, naming where the time came from.
    meas = tk.load_scenario("bearings-only-2d").simulate(rng=1)
    meas.metadata.update(motion="cv2d", ref_time=1e12)
    tk.write_measurements(meas, tmp_path / "far.parquet")
    far = run("estimate", str(tmp_path / "far.parquet"))
    assert far.exit_code == 2 and "the file's ref_time 1000000000000" in far.output, far.output
    assert "--motion" in far.output  # (the remedy: the file's time is its own)
    # An empty one is no reference time (the reader's rule): the fit chooses one.
    meas.metadata.update(ref_time="")
    tk.write_measurements(meas, tmp_path / "empty.parquet")
    assert run("crlb", str(tmp_path / "empty.parquet")).exit_code == 0
    # A manoeuvring target's file: the same refusal before its search.
    hoerst = tk.load_scenario("hoerst2010").simulate(rng=1)
    hoerst.metadata.update(motion="curvilinear:2", ref_time=1e9)
    tk.write_measurements(hoerst, tmp_path / "hoerst.parquet")
    far = run("estimate", str(tmp_path / "hoerst.parquet"))
    assert far.exit_code == 2 and "the file's ref_time 1000000000" in far.output, far.output


def test_crlb_refuses_options_it_would_ignore_or_misread(tmp_path):
    # A scenario's bound is at its own truth and motion: --motion, --ref-time, --truth refused.
    for flag, value in (("--motion", "cv3d"), ("--ref-time", "1e9"),
                        ("--truth", "x=1,y=2,vx=0,vy=0")):
        got = run("crlb", "bearings-only-2d", flag, value)
        assert got.exit_code == 2 and f"{flag}: for a measurement file" in got.output
    # A file's truth is stated at its reference time: read at another it is another
    # trajectory (the bound of another geometry, silently, before).
    obs = tmp_path / "obs.csv"
    run("simulate", "bearings-only-2d", "-o", str(obs))
    moved = run("crlb", str(obs), "--ref-time", "300")
    assert moved.exit_code == 2 and "the file's truth is stated at its reference time 0" in (
        moved.output)
    assert run("crlb", str(obs), "--ref-time", "0").exit_code == 0
    shifted = run("crlb", str(obs), "--ref-time", "300", "--motion", "cv2d",
                  "--truth", "x=1000,y=9000,vx=-6,vy=-3")
    assert shifted.exit_code == 0, shifted.output


def test_montecarlo_and_reproduce_commands(tmp_path):
    table = tmp_path / "runs.csv"
    result = run("montecarlo", "gu2007", "--runs", "6", "--no-progress", "-o", str(table))
    assert result.exit_code == 0, result.output
    assert "RMSE/CRLB" in result.output and table.exists()
    pool = run("montecarlo", "gu2007", "--runs", "6", "--no-progress", "--workers", "2",
               "--chunk", "3", "-o", str(tmp_path / "pool.csv"))
    assert pool.exit_code == 0 and "2 processes" in pool.output, pool.output
    here, pooled = pd.read_csv(table), pd.read_csv(tmp_path / "pool.csv")
    assert (here["status"] == pooled["status"]).all()
    np.testing.assert_allclose(here.filter(like="est_"), pooled.filter(like="est_"), rtol=1e-6)
    both = run("montecarlo", "gu2007", "--runs", "2", "--workers", "2", "--dask",
               "tcp://127.0.0.1:1")
    assert both.exit_code == 2 and "not both" in both.output
    again = run("montecarlo", "gu2007", "--runs", "6", "--no-progress", "-o", str(table))
    assert again.exit_code == 2 and "already exists" in again.output
    rep = run("reproduce", "gu2007", "--runs", "0")
    assert rep.exit_code == 0 and "Table 3" in rep.output and "157.8205" in rep.output
    assert run("reproduce", "nothing").exit_code == 2


def test_estimate_reports_wgs84_when_the_file_has_an_origin(tmp_path):
    import json

    from tmakit.core.geodesy import enu_to_geodetic

    scn = tk.load_scenario("hurtado2008")
    scn.origin = (52.0, 4.0, 0.0)
    path = tmp_path / "obs.csv"
    tk.write_measurements(scn.simulate(rng=1), path)
    result = run("estimate", str(path), "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    lat, lon, _ = enu_to_geodetic(*data["estimate"][:2], 0.0, scn.origin)
    assert data["geodetic"]["lat"] == pytest.approx(float(lat))
    assert data["geodetic"]["lon"] == pytest.approx(float(lon))
    assert abs(data["geodetic"]["lat"] - 52.0) < 0.2
