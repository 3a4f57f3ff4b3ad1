"""Nothing lost, nothing silently wrong, no traceback: the guarantees of docs/reliability.md.

Each test is named in docs/reliability.md beside the guarantee it backs.
"""

from __future__ import annotations

import fcntl
import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.io.tables import atomic_write, clean_stale_temporaries

runner = CliRunner()


def run(*args: object):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def obs(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("data") / "obs.csv"
    assert run("simulate", "gu2007", "--seed", "1", "-o", path).exit_code == 0
    return path


# -- no traceback reaches the user (guard) ---------------------------------------------------

def test_internal_error_is_one_line_with_a_log_and_exit_3(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("a bug nobody foresaw")

    monkeypatch.setenv("TMA_LOG_DIR", str(tmp_path))
    monkeypatch.setattr(tk.Scenario, "simulate", broken)
    result = run("simulate", "gu2007", "-o", tmp_path / "x.csv")
    assert result.exit_code == 3
    assert "internal error in `tma simulate`" in result.output
    assert "a bug nobody foresaw" in result.output and "please report" in result.output
    assert "Traceback" not in result.output
    (log,) = tmp_path.glob("tma-error-*.log")
    assert "Traceback" in log.read_text() and "RuntimeError" in log.read_text()
    assert not (tmp_path / "x.csv").exists()


def test_debug_shows_the_traceback(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("a bug nobody foresaw")

    monkeypatch.setattr(tk.Scenario, "simulate", broken)
    result = run("--debug", "simulate", "gu2007", "-o", tmp_path / "x.csv")
    assert isinstance(result.exception, RuntimeError)  # not caught: Python prints it
    run("simulate", "--help")  # --debug is per invocation: the next one resets it


def test_a_library_warning_is_shown_once_and_the_command_finishes(tmp_path, monkeypatch):
    # A warning meant for the user (say a dependency's deprecation) is shown after the command,
    # once; showing it while warnings were still being recorded would record it again, forever.
    real = tk.Scenario.simulate

    def warns(self, *args, **kwargs):
        warnings.warn("a dependency is deprecated", DeprecationWarning, stacklevel=1)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(tk.Scenario, "simulate", warns)
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        result = run("simulate", "gu2007", "-o", tmp_path / "x.csv")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "x.csv").exists()
    assert [str(w.message) for w in shown].count("a dependency is deprecated") == 1


def test_numerical_failure_names_what_was_computed(tmp_path, monkeypatch):
    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setenv("TMA_LOG_DIR", str(tmp_path))
    monkeypatch.setattr("tmakit.scenario.model.ObservationModel", singular)
    result = run("simulate", "gu2007", "-o", tmp_path / "x.csv")
    assert result.exit_code == 3
    assert "while computing tmakit.scenario.model.simulate_values" in result.output
    assert "LinAlgError: SVD did not converge" in result.output
    assert "Traceback" not in result.output


def test_interrupt_is_exit_130(tmp_path, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tk.Scenario, "simulate", interrupted)
    result = run("simulate", "gu2007", "-o", tmp_path / "x.csv")
    assert result.exit_code == 130
    assert not list(tmp_path.iterdir())


def test_runtime_warnings_do_not_reach_the_terminal(obs, monkeypatch):
    import importlib

    cmd = importlib.import_module("tmakit.cli.scenarios")
    table = cmd.summary_table

    def noisy(*args, **kwargs):
        np.log(np.zeros(3))  # RuntimeWarning: divide by zero
        return table(*args, **kwargs)

    monkeypatch.setattr(cmd, "summary_table", noisy)
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        result = run("show", obs)
    assert result.exit_code == 0
    assert "RuntimeWarning" not in result.output and "divide by zero" not in result.output


def test_bad_seed_and_folder_as_file_are_clear_errors(tmp_path):
    result = run("simulate", "gu2007", "--seed", "-1", "-o", tmp_path / "x.csv")
    assert result.exit_code == 2 and "--seed" in result.output
    folder = tmp_path / "d.csv"
    folder.mkdir()
    result = run("show", folder)
    assert result.exit_code == 2 and "is a folder" in result.output


# -- outputs checked before any work --------------------------------------------------------

def test_plot_without_suffix_never_overwrites_the_png_matplotlib_would_write(obs, tmp_path):
    fig = tmp_path / "fig.png"
    fig.write_bytes(b"precious")
    result = run("show", obs, "--plot", tmp_path / "fig")
    assert result.exit_code == 2 and "fig.png already exists" in result.output
    assert fig.read_bytes() == b"precious"
    result = run("show", obs, "--plot", tmp_path / "other")
    assert result.exit_code == 0
    assert (tmp_path / "other.png").read_bytes()[:4] == b"\x89PNG"
    assert not list(tmp_path.glob(".*"))  # no temporary file left


@pytest.mark.parametrize("args, message", [
    (("simulate", "gu2007", "-o", "{tmp}/nodir/x.csv"), "does not exist"),
    (("simulate", "gu2007", "-o", "{tmp}"), "is a folder"),
    (("simulate", "gu2007", "-o", "{tmp}/x.txt"), "unknown format"),
    (("show", "{obs}", "--plot", "{tmp}/nodir/p.png"), "does not exist"),
    (("show", "{obs}", "--plot", "{tmp}/p.jpg"), "unknown format"),
    (("track", "{obs}", "--plot", "{tmp}/nodir/p.png"), "does not exist"),
    (("track", "{obs}", "-o", "{tmp}/t.csv", "--plot", "{tmp}/t.csv"), "unknown format"),
    (("montecarlo", "gu2007", "--runs", "3000", "-o", "{tmp}/nodir/runs.csv"), "does not exist"),
    (("montecarlo", "gu2007", "--runs", "3000", "-o", "{tmp}/r.csv", "--json", "{tmp}/r.csv"),
     "the same file"),
])
def test_bad_output_paths_are_refused_before_any_work(obs, tmp_path, monkeypatch, args,
                                                      message):
    def never(*a, **k):
        raise AssertionError("the work started")

    monkeypatch.setattr("tmakit.montecarlo.monte_carlo", never)
    monkeypatch.setattr(tk.Scenario, "simulate", never)
    result = run(*(a.format(tmp=tmp_path, obs=obs) for a in args))
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_stale_temporaries_of_killed_writers_are_removed_by_the_next_write(tmp_path):
    stale = tmp_path / ".obs.csv.0123456789ab.tmp"
    stale.write_text("half a file")
    held = tmp_path / ".other.csv.abcdef012345.tmp"
    held.write_text("being written")
    fd = os.open(held, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)  # a live writer holds its temporary file
    try:
        with atomic_write(tmp_path / "new.txt") as tmp:
            tmp.write_text("new")
        assert not stale.exists()
        assert held.exists()
    finally:
        os.close(fd)
    assert clean_stale_temporaries(tmp_path) == [held]
    assert (tmp_path / "new.txt").read_text() == "new"
    (tmp_path / "user.tmp").write_text("not ours")
    clean_stale_temporaries(tmp_path)
    assert (tmp_path / "user.tmp").exists()


def test_montecarlo_interrupted_keeps_the_finished_runs(tmp_path, monkeypatch):
    import tmakit.montecarlo.study as study

    real = study.execute

    def interrupted_after_first_chunk(tasks, client, label, runs, progress, on_chunk=None,
                                      workers=1, **kwargs):
        real(tasks[:1], client, label, len(tasks[0].seeds), progress, on_chunk)
        raise KeyboardInterrupt

    monkeypatch.setattr(study, "execute", interrupted_after_first_chunk)
    out = tmp_path / "runs.csv"
    result = run("montecarlo", "gu2007", "--runs", "40", "--chunk", "8", "--no-progress",
                 "-o", out)
    assert result.exit_code == 130
    assert not out.exists()
    partial = tmp_path / "runs.partial.csv"
    import pandas as pd

    table = pd.read_csv(partial)
    assert list(table["run"]) == list(range(8))
    assert set(table["status"]) <= {"converged", "did not converge", "unobservable",
                                    "diverged", "failed"}


# -- one validation rule everywhere ---------------------------------------------------------

def _row_args(**change):
    cols = dict(time=[0.0, 1.0, 2.0], sensor=["s"] * 3, kind=["bearing"] * 3,
                value=[10.0, 11.0, 12.0], sigma=[1.0, 1.0, 1.0], sensor_state=np.zeros((3, 6)))
    cols.update(change)
    return cols


@pytest.mark.parametrize("change, expected", [
    ({"value": [10.0, np.inf, 12.0]}, "row 2, column 'value': expected a finite number"),
    ({"sigma": [1.0, -1.0, 1.0]}, "row 2, column 'sigma': expected a noise standard deviation"),
    ({"time": [0.0, 2.0, 1.0]}, "row 3, column 'time': expected a time >= 2.0 s"),
    ({"value": [10.0, 1000.0, 12.0]}, "row 2, column 'value': expected a bearing"),
])
def test_the_constructor_refuses_what_the_reader_refuses_with_its_words(tmp_path, change,
                                                                         expected):
    with pytest.raises(ValueError) as library:
        tk.MeasurementSet(**_row_args(**change))
    assert expected in str(library.value)
    # the same rows in a file: the reader's message has the same words for the same cell
    cols = _row_args(**change)
    lines = ["time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z"] + [
        f"{t!r},s,bearing,{v!r},{s!r},0,0,0"
        for t, v, s in zip(cols["time"], cols["value"], cols["sigma"], strict=True)]
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError) as reader:
        tk.read_measurements(path)
    words = expected.split(": expected ")[1]
    assert words.split(" >= ")[0] in str(reader.value)


def test_scenario_files_refuse_nan_inf_and_an_origin_off_the_earth(tmp_path):
    base = (Path(tk.__file__).parent / "scenario" / "builtin" / "gu2007.toml").read_text()
    cases = {
        "truth": base.replace("x = 3200.0", "x = nan", 1),
        "sigma": _replace_first_sigma(base, "inf"),
        "origin": 'origin = [1000.0, 0.0, 0.0]\n' + base,
    }
    for field, text in cases.items():
        if text == base:
            continue
        path = tmp_path / f"{field}.toml"
        path.write_text(text)
        out = tmp_path / f"{field}.csv"
        result = run("simulate", path, "-o", out)
        assert result.exit_code == 2, (field, result.output)
        assert field in result.output and not out.exists()


def _replace_first_sigma(text: str, value: str) -> str:
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip().startswith("sigma"):
            lines[i] = f"sigma = {value}"
            break
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("line, key", [("# truth: {bad json", "truth"),
                                       ("# ref_time: yesterday", "ref_time"),
                                       ("# origin_lat: 1000", "origin_lat"),
                                       ("# seed: -4", "seed")])
def test_metadata_the_library_reads_is_checked_when_the_file_is_read(obs, tmp_path, line,
                                                                      key):
    text = [t for t in obs.read_text().splitlines() if not t.startswith(f"# {key}:")]
    path = tmp_path / "meta.csv"
    path.write_text("\n".join([text[0], line, *text[1:]]) + "\n")
    result = run("crlb", path)
    assert result.exit_code == 2, result.output
    assert f"metadata '{key}'" in result.output and "Traceback" not in result.output


# -- the time origin does not matter --------------------------------------------------------

@pytest.fixture(scope="module")
def base_set(obs):
    return tk.read_measurements(obs)


@settings(max_examples=4, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(origin=st.sampled_from([1e5, 1.7e9]), eighths=st.integers(0, 7))
def test_bound_and_estimate_do_not_depend_on_the_time_origin(base_set, origin, eighths):
    m = base_set  # times from 0; a clock far from them: 1e5 s, or Unix time 1.7e9 s
    shift = origin + eighths / 8  # fractional seconds, exactly representable
    moved = tk.MeasurementSet(m.time + shift, m.sensor, m.kind, m.value, m.sigma,
                              m.sensor_state)
    plain = tk.MeasurementSet(m.time, m.sensor, m.kind, m.value, m.sigma, m.sensor_state)
    a, b = tk.estimate(plain, "cv2d"), tk.estimate(moved, "cv2d")
    assert a.status == b.status == "converged"
    assert b.motion.ref_time == pytest.approx(a.motion.ref_time + shift, abs=0, rel=1e-15)
    np.testing.assert_allclose(b.estimate, a.estimate, rtol=1e-9)
    np.testing.assert_allclose(b.std, a.std, rtol=1e-9)
    ba = tk.crlb(plain, a.motion, truth=a.estimate)
    bb = tk.crlb(moved, b.motion, truth=a.estimate)
    np.testing.assert_allclose(bb.std, ba.std, rtol=1e-9)
    assert bb.observability.rank == ba.observability.rank


def test_the_command_line_fits_an_absolute_clock_like_a_relative_one(base_set, tmp_path):
    m = base_set
    moved = tk.MeasurementSet(m.time + 1.7e9 + 0.5, m.sensor, m.kind, m.value, m.sigma,
                              m.sensor_state)
    path = tmp_path / "epoch.csv"
    tk.write_measurements(moved, path)
    result = run("estimate", path, "--motion", "cv2d", "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["status"] == "converged"


# -- work limits ----------------------------------------------------------------------------

@pytest.mark.parametrize("args, words", [
    (("montecarlo", "gu2007", "--runs", "10000000000000"), "--max-runs"),
    (("estimate", "{obs}", "--motion", "curvilinear:1000"), "cannot be identified"),
    (("track", "{obs}", "--filter", "pf", "--particles", "1000000000"), "TMA_MAX_MEMORY_GB"),
])
def test_runaway_work_is_refused_up_front_with_size_limit_and_option(obs, args, words):
    result = run(*(a.format(obs=obs) for a in args))
    assert result.exit_code == 2, result.output
    assert words in result.output


def test_a_scenario_asking_for_too_many_rows_is_refused(tmp_path):
    text = (Path(tk.__file__).parent / "scenario" / "builtin" / "bearings-only-2d.toml").read_text()
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip().startswith("times") and "step" in line:
            lines[i] = "times = { start = 0.0, stop = 1e8, step = 1.0 }"
            break
    else:
        pytest.skip("no times range in the scenario")
    path = tmp_path / "big.toml"
    path.write_text("\n".join(lines) + "\n")
    result = run("simulate", path, "-o", tmp_path / "big.csv")
    assert result.exit_code == 2, result.output
    assert "TMA_MAX_SAMPLES" in result.output


# -- non-finite and repeated options; undefined geometry ------------------------------------

@pytest.mark.parametrize("args, words", [
    (("crlb", "gu2007", "--at", "nan"), "--at nan: expected a finite number"),
    (("crlb", "{obs}", "--motion", "cv2d", "--ref-time", "inf"), "--ref-time inf"),
    (("crlb", "{obs}", "--motion", "cv2d", "--truth", "x=4000,x=5"), "x is given twice"),
    (("crlb", "{obs}", "--motion", "cv2d", "--truth", "x=nan,y=1"), "not a finite number"),
    (("track", "{obs}", "--prior-time", "nan"), "--prior-time nan"),
    (("track", "{obs}", "--range-prior", "1000:inf"),
     "--range-prior '1000:inf': expected MIN:MAX in metres (finite numbers)"),
    (("track", "{obs}", "--height-prior", "nan:10"), "--height-prior 'nan:10'"),
    (("estimate", "{obs}", "--motion", "cv2d", "--from", "100", "--to", "50"),
     "--from 100 is after --to 50"),
])
def test_non_finite_or_repeated_option_values_are_refused(obs, args, words):
    result = run(*(a.format(obs=obs) for a in args))
    assert result.exit_code == 2, result.output
    assert words in result.output


def test_a_target_exactly_on_a_sensor_is_refused_not_given_a_bearing_of_zero(tmp_path):
    path = tmp_path / "on.toml"
    path.write_text("""name = "on"
[target]
motion = "cv2d"
truth = { x = 0.0, y = 0.0, vx = 0.0, vy = 0.0 }
[[sensors]]
id = "post"
type = "fixed"
position = [0.0, 0.0]
[[measurements]]
kind = "bearing"
sensor = "post"
times = { start = 0.0, stop = 10.0, step = 1.0 }
sigma = 1.0
""")
    result = run("simulate", path, "-o", tmp_path / "on.csv")
    assert result.exit_code == 2, result.output
    assert "exactly at sensor 'post'" in result.output
    assert not (tmp_path / "on.csv").exists()


def test_a_parquet_list_column_is_a_clear_error_not_a_schema_dump(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({"time": [0.0, 1.0], "sensor": ["a", "a"], "kind": ["bearing"] * 2,
                      "value": [[1.0], [2.0]], "sigma": [1.0, 1.0], "sensor_x": [0.0, 0.0],
                      "sensor_y": [0.0, 0.0], "sensor_z": [0.0, 0.0]})
    path = tmp_path / "list.parquet"
    pq.write_table(table, path)
    result = run("show", path)
    assert result.exit_code == 2, result.output
    assert "column 'value': expected numbers" in result.output
    assert "DATATYPE_COERCION" not in result.output


def test_an_mplbackend_matplotlib_does_not_know_does_not_stop_a_picture(obs, tmp_path):
    import subprocess
    import sys

    out = tmp_path / "p.png"
    done = subprocess.run([sys.executable, "-m", "tmakit.cli", "show", str(obs), "--plot",
                           str(out)], env={**os.environ, "MPLBACKEND": "nonsense"},
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 0
