"""Hostile inputs through every door (issue 26): refused or warned, never accepted as sense.

Each case named by the issue is a test (``benchmarks/hostile_inputs.py``, its ``fast``
cases, run in this process); the script runs them all, and more, through ``tma`` itself.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import hostile_inputs as hostile

NAMED = [c for c in hostile.CASES if c.fast]


@pytest.mark.parametrize("case", NAMED, ids=[c.name for c in NAMED])
def test_a_hostile_input_named_by_the_issue_is_refused_or_warned(tmp_path, case):
    outcome, said = hostile.run_case(case, tmp_path, in_process=True)
    assert outcome == case.due, said


def test_the_script_counts_nonsense_tracebacks_and_overwritten_inputs(tmp_path):
    """The classifier itself: an accepting command, an input changed, a refusal."""
    accept = hostile.Case("accepted", lambda f: ["show", str(hostile.simulated(f))])
    overwrite = hostile.Case("overwritten", lambda f: (
        hostile.simulated(f), ["simulate", "bearings-only-2d", "-o", str(f / "obs.csv"),
                               "--force"])[-1])
    refuse = hostile.Case("refused", lambda f: ["show", str(f / "none.csv")])
    counts = hostile.run_all([accept, overwrite, refuse], tmp_path, verbose=False,
                             in_process=True)
    assert counts == {"accepted nonsense": 1, "input overwritten": 1, "ok": 1}


def test_a_second_montecarlo_run_into_a_held_file_is_refused_and_a_stale_hold_is_taken(
        tmp_path):
    out = tmp_path / "runs.csv"
    lock = tmp_path / ".runs.csv.tma-lock"
    lock.write_text(f"{os.getppid()}\n")  # a live process holds it
    runner = CliRunner()
    held = runner.invoke(app, ["montecarlo", "gu2007", "--runs", "3", "--no-progress",
                               "-o", str(out)])
    assert held.exit_code == 2 and "another tma run" in held.output
    assert not out.exists()
    lock.write_text("999999999\n")  # no such process: the run that held it has ended
    taken = runner.invoke(app, ["montecarlo", "gu2007", "--runs", "3", "--no-progress",
                                "-o", str(out)])
    assert taken.exit_code == 0, taken.output
    assert out.exists() and not lock.exists()


def test_rows_written_twice_are_merged_and_two_values_at_one_time_refused(tmp_path):
    hostile.examples(tmp_path)
    log = tmp_path / "bearings.csv"
    lines = log.read_text().splitlines()
    log.write_text("\n".join([*lines[:5], lines[4], *lines[5:]]) + "\n")  # row 4 twice
    meas = tk.read_measurements(tmp_path / "own.gpx", measurements=log,
                                mapping=tmp_path / "bearings.toml")
    assert len(meas) == len(lines) - 1 and meas.metadata["duplicates_merged"] == "1"
    t, b = lines[4].split(",")
    log.write_text("\n".join([*lines[:5], f"{t},{float(b) + 3}", *lines[5:]]) + "\n")
    with pytest.raises(tk.MeasurementFileError, match=r"row 5 \(line 6\).*at the time "
                       r"of row 4 \(line 5\).*two values at one time"):
        tk.read_measurements(tmp_path / "own.gpx", measurements=log,
                             mapping=tmp_path / "bearings.toml")


@pytest.mark.parametrize(("unit", "scale"), [("s", 1), ("ms", 10**3), ("us", 10**6),
                                             ("ns", 10**9)])
def test_epoch_times_in_each_unit_give_the_same_set_and_the_wrong_unit_is_named(
        tmp_path, unit, scale):
    hostile.examples(tmp_path)
    plain = tk.read_measurements(tmp_path / "own.gpx", measurements=tmp_path / "bearings.csv",
                                 mapping=tmp_path / "bearings.toml")
    hostile.bearings_times(scale, unit)(tmp_path)
    again = tk.read_measurements(tmp_path / "own.gpx", measurements=tmp_path / "bearings.csv",
                                 mapping=tmp_path / "bearings.toml")
    assert np.array_equal(again.time, plain.time)
    assert again.metadata["time_origin"] == plain.metadata["time_origin"]
    if unit != "s":  # the same numbers said to be seconds: refused, naming the unit
        toml = tmp_path / "bearings.toml"
        toml.write_text(toml.read_text().replace(f'time_unit = "{unit}"', 'time_unit = "s"'))
        with pytest.raises(tk.MeasurementFileError,
                           match=f'between 1970 and 2200.*give time_unit = "{unit}"'):
            tk.read_measurements(tmp_path / "own.gpx", measurements=tmp_path / "bearings.csv",
                                 mapping=toml)


def test_two_contacts_of_one_sensor_at_one_time_are_refused_naming_them(tmp_path):
    """Debrief's bulk_data.rep: sensor SimpleCookie holds 7 contacts, two at a time."""
    import lzma

    rep = tmp_path / "bulk_data.rep"
    packed = Path(__file__).parent / "data" / "debrief" / "pepys" / "bulk_data.rep.xz"
    rep.write_bytes(lzma.decompress(packed.read_bytes()))
    with pytest.raises(tk.MeasurementFileError, match=r"name 7 contacts \(GreenFV1_011; "
                       r".*two of them at one time \(line 309 and line 308\).*--contact"):
        tk.read_measurements(rep, ownship="MER", contact="SimpleCookie")
    one = tk.read_measurements(rep, ownship="MER", contact="GreenFV1_011")
    bearings = one.select(kind="bearing")
    assert len(bearings) > 100 and (np.diff(bearings.time) > 0).all()


def test_a_range_difference_plan_shorter_than_its_lag_is_refused_naming_the_lag(tmp_path):
    """Once an internal KeyError in ``simulate``: a plan that can form no difference at all."""
    text = (Path(tk.__file__).parent / "scenario" / "builtin" / "chen-sun-1.toml").read_text()
    at = text.index('kind = "range_difference"')
    short = text[:at] + text[at:].replace("start = 0.0, stop = 100.0", "start = 5.0, stop = 5.0", 1)
    path = tmp_path / "short.toml"
    path.write_text(short)
    with pytest.raises(ValueError, match=r"span 0 s, less than the shortest lag \(1 x pri 1 s\)"):
        tk.load_scenario(path)
    result = CliRunner().invoke(app, ["simulate", str(path), "-o", str(tmp_path / "m.csv")])
    assert result.exit_code == 2 and "no difference can be formed" in result.output
    assert "internal error" not in result.output and not (tmp_path / "m.csv").exists()
    fits = text[:at] + text[at:].replace("start = 0.0, stop = 100.0", "start = 5.0, stop = 6.0", 1)
    path.write_text(fits)
    assert len(tk.load_scenario(path).simulate(rng=1).select(kind="range_difference")) == 1


def test_a_range_difference_plan_of_too_many_pulse_intervals_is_refused_naming_pri(tmp_path):
    """Once an internal IndexError in ``simulate`` (pri = 1e-300: the interval count overflowed)."""
    text = (Path(tk.__file__).parent / "scenario" / "builtin" / "chen-sun-1.toml").read_text()
    path = tmp_path / "tiny-pri.toml"
    path.write_text(text.replace("pri = 1.0", "pri = 1e-300"))
    with pytest.raises(ValueError, match=r"span 100 s, 1e\+302 pulse intervals of pri 1e-300 s; "
                                         r"at most 1e\+08"):
        tk.load_scenario(path)
    result = CliRunner().invoke(app, ["simulate", str(path), "-o", str(tmp_path / "m.csv")])
    assert result.exit_code == 2 and "give the pulse repetition interval pri" in result.output
    assert "internal error" not in result.output and not (tmp_path / "m.csv").exists()
    path.write_text(text.replace("pri = 1.0", "pri = 1e-6"))  # 1e8 intervals: at the limit
    assert tk.load_scenario(path).plans[1].pri == 1e-6


def test_a_planning_prior_beyond_a_states_reach_is_refused_naming_the_field(tmp_path):
    """Once an internal OverflowError in ``tma plan`` (velocity_std = 1e300: its square)."""
    builtin = Path(tk.__file__).parent / "scenario" / "builtin"
    text = (builtin / "plan-bearings-only.toml").read_text()
    path = tmp_path / "wide-prior.toml"
    for field, value in (("velocity_std = 10.0", "velocity_std = 1e300"),
                         ("position_std = 5000.0", "position_std = 1e200")):
        path.write_text(text.replace(field, value))
        result = CliRunner().invoke(app, ["plan", str(path), "--runs", "1", "--duration", "20",
                                          "--particles", "50", "--no-progress"])
        assert result.exit_code == 2, result.output
        assert f"planning.prior.{field.split()[0]}" in result.output.replace("\n", "")
        assert "less than or equal to" in result.output and "internal error" not in result.output


@pytest.mark.parametrize(("key", "kind"), [("pri = 1.0", "bearing"), ("lags = [2]", "bearing"),
                                           ("snr_db = 20.0", "bearing")])
def test_a_key_of_another_measurement_kind_is_refused_naming_it(tmp_path, key, kind):
    """A bearing plan's ``pri``, ``lags`` or ``snr_db`` was silently ignored (found by fuzz12)."""
    text = (Path(tk.__file__).parent / "scenario" / "builtin" / "bearings-only-2d.toml").read_text()
    path = tmp_path / "stray-key.toml"
    path.write_text(text.replace("sigma = 1.0", f"sigma = 1.0\n{key}"))
    name = key.split()[0]
    with pytest.raises(ValueError, match=rf"{name} is a key of .* measurements only, not of "
                                         rf"{kind}"):
        tk.load_scenario(path)


@pytest.mark.parametrize("snr_db", ["1e300", "-1e300"])
def test_a_power_plan_snr_beyond_300_db_is_refused_naming_it(tmp_path, snr_db):
    """Once an internal OverflowError in ``simulate`` and ``crlb`` (snr_db = 1e300)."""
    text = (Path(tk.__file__).parent / "scenario" / "builtin" / "gu2007.toml").read_text()
    path = tmp_path / "snr.toml"
    path.write_text(text.replace("snr_db = 40.0", f"snr_db = {snr_db}"))
    for command in (["crlb", str(path)], ["simulate", str(path), "-o", str(tmp_path / "m.csv")]):
        result = CliRunner().invoke(app, command)
        assert result.exit_code == 2, result.output
        assert "expected an SNR within [-300, 300] dB" in result.output.replace("\n", " ")
        assert "internal error" not in result.output
