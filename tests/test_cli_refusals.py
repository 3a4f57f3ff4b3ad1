"""`tma` refuses what it cannot honour in words that name the option, file or row.

The defects a new user's trials found (tenth session): a reversed Debrief window, a second file
after one ``--export``, sigmas beyond what their kind can mean (a bearing's above 180 deg)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

EXAMPLES = Path(tk.__file__).parent / "examples"
REPLAY = [EXAMPLES / "Freq_BlueSensor.rep", EXAMPLES / "Freq_BlueTrack.rep"]
runner = CliRunner()


def run(*args: object):
    result = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in result.output
    return result, " ".join(result.output.split())


@pytest.mark.parametrize("command", [["estimate", "--motion", "cv2d"], ["track"]])
def test_a_reversed_window_of_a_replay_names_both_options_and_says_it_is_empty(command):
    """Was: "1 problem in the measurement file: no cut between 12:00 and 11:00", blaming the
    file for the options' order."""
    result, text = run(command[0], *REPLAY, *command[1:], "--from", "12:00", "--to", "11:00")
    assert result.exit_code == 2
    assert ("error: --from 12:00 is after --to 11:00 (2010-01-12T12:00:00Z > "
            "2010-01-12T11:00:00Z): the window ends before it starts, so it is empty") in text
    assert "problem in the measurement file" not in text


def test_an_empty_window_of_a_replay_names_the_options_not_a_file_problem():
    result, text = run("estimate", *REPLAY, "--motion", "cv2d", "--from", "15:00", "--to", "16:00")
    assert result.exit_code == 2
    assert "error: --from/--to: no cut between 15:00 and 16:00 in" in text
    assert "the window is empty (the cuts span 2010-01-12T12:00:00Z to" in text
    assert "problem in the measurement file" not in text


def test_a_reversed_window_from_python_is_a_value_error_naming_the_window():
    with pytest.raises(ValueError, match="--from 12:00 is after --to 11:00"):
        tk.read_measurements(REPLAY, window=("12:00", "11:00"))


@pytest.mark.parametrize("second", ["b.kml", "b.rep"])
def test_two_files_after_one_export_say_to_give_export_once_per_file(tmp_path, second):
    """Was: ``--export a.rep b.kml`` read b.kml as a measurement file ("b.kml: no such file", or
    "several files are read as one only for Debrief replays" when it existed)."""
    a, b = tmp_path / "a.rep", tmp_path / second
    for where in (["--export", a, b, EXAMPLES / "contact.rep"],
                  [EXAMPLES / "contact.rep", f"--export={a}", b]):
        result, text = run("estimate", *where, "--motion", "cv2d")
        assert result.exit_code == 2
        assert (f"error: {b}: no such file, and it stands after --export {a}: an option takes "
                f"one value, so give --export once per file: --export {a} --export {b}") in text
        assert not a.exists()
    if second.endswith(".kml"):  # an existing file of no format read: said so, before any work
        b.write_text("<kml/>")
        result, text = run("estimate", EXAMPLES / "contact.rep", "--motion", "cv2d", "--export",
                           a, b)
        assert result.exit_code == 2
        assert f"error: {b}: not a measurement file, and it stands after --export {a}" in text
        assert not a.exists()


def test_files_after_an_export_that_are_measurement_files_are_read_as_ever(tmp_path):
    out = tmp_path / "solution.rep"
    result, _ = run("estimate", "--export", out, *REPLAY, "--motion", "cv2d")
    assert result.exit_code == 0, result.output
    assert out.read_text().count(";TMA_POS:") > 1


def test_a_list_option_given_a_second_value_says_so():
    result, text = run("estimate", EXAMPLES / "bearings.csv", "--mapping",
                       EXAMPLES / "bearings.toml", "--kinds", "bearing", "frequency")
    assert result.exit_code == 2
    assert ("error: frequency: no such file, and it stands after --kinds bearing: an option "
            "takes one value (values of a list joined by commas)") in text


@pytest.mark.parametrize(("option", "message"), [
    (["--bearing-sigma", "5000"], "--bearing-sigma 5000: expected a noise standard deviation of "
                                  "at most 180 deg for a bearing (half a turn"),
    (["--bearing-sigma", "sonar=500"], "--bearing-sigma sonar=500: expected a noise standard "
                                       "deviation of at most 180 deg for a bearing"),
    (["--bearing-sigma", "-1"], "--bearing-sigma -1: expected a noise standard deviation > 0 "
                                "(deg)"),
    (["--range-sigma", "1e12"], "--range-sigma 1e+12: expected a noise standard deviation of "
                                "at most 1e+09 m for a range"),
    (["--frequency-sigma", "0"], "--frequency-sigma 0: expected a noise standard deviation > 0 "
                                 "(Hz)"),
    # the last one was taken without a word
    (["--bearing-sigma", "sonar=1,sonar=2"], "--bearing-sigma 'sonar=1,sonar=2': sonar is given "
                                             "twice")])
def test_a_sigma_option_beyond_its_kind_is_refused_naming_the_option(option, message):
    """Was: --bearing-sigma 5000 fitted (every answer unobservable, a chi2 'too good to be
    true'), and --bearing-sigma -1 was a 'problem in the measurement file'."""
    result, text = run("estimate", EXAMPLES / "contact.rep", "--motion", "cv2d", *option)
    assert result.exit_code == 2
    assert f"error: {message}" in text and "problem in the measurement file" not in text


def test_a_sigma_cell_beyond_its_kind_is_refused_naming_row_and_line(tmp_path):
    meas = tk.load_scenario("hurtado2008").simulate(rng=1)
    path = tmp_path / "obs.csv"
    tk.write_measurements(meas, path)
    lines = path.read_text().splitlines()
    header = next(k for k, ln in enumerate(lines) if ln.startswith("time,"))
    first = {kind: next(k for k, ln in enumerate(lines) if f",{kind}," in ln)
             for kind in ("bearing", "range")}
    for kind, sigma, unit in (("bearing", "1e9", "180 deg for a bearing"),
                              ("range", "1e200", "1e+09 m for a range")):
        edited = list(lines)
        cells = edited[first[kind]].split(",")
        cells[4] = sigma
        edited[first[kind]] = ",".join(cells)
        path.write_text("\n".join(edited) + "\n")
        result, text = run("estimate", path)
        assert result.exit_code == 2
        assert (f"row {first[kind] - header} (line {first[kind] + 1}), column 'sigma': expected "
                f"a noise standard deviation of at most {unit}") in text
        with pytest.raises(ValueError, match=re.escape(f"at most {unit}")):
            tk.read_measurements(path)


def test_a_mapping_sigma_beyond_its_kind_is_refused_naming_the_mapping(tmp_path):
    mapping = tmp_path / "big.toml"
    mapping.write_text((EXAMPLES / "bearings.toml").read_text().replace(
        "sigma = 1.0", "sigma = 4.0").replace('unit = "deg"', 'unit = "rad"').replace(
        'track = "own.gpx"', f'track = "{EXAMPLES / "own.gpx"}"'))
    result, text = run("estimate", EXAMPLES / "bearings.csv", "--mapping", mapping, "--motion",
                       "cv2d")
    assert result.exit_code == 2
    assert (f"{mapping}: the column mapping is not valid: - measurement.0: sigma 4 rad: "
            "expected a noise standard deviation of at most 180 deg for a bearing") in text


@pytest.mark.parametrize(("option", "message"), [
    (["--dim", "4"], "error: --dim 4: expected 2 or 3"),
    (["--init-window", "0"], "error: --init-window: expected a whole number of measurement "
                             "times from 1 to 720, got 0"),
    (["--start-std", "-1"], "error: --start-std must be > 0, got -1.0")])
def test_track_options_are_named_as_the_user_gave_them(option, message):
    """Was: "contact.rep: 1 problem in the measurement file: dim must be 2 or 3" (the file
    blamed for an option), "init_window: ..." and "max_relative_std must be > 0" (the library's
    keywords, not the options)."""
    result, text = run("track", EXAMPLES / "contact.rep", *option)
    assert result.exit_code == 2
    assert message in text and "problem in the measurement file" not in text


@pytest.mark.parametrize(("option", "message"), [
    (["--settle", "-5"], "error: --settle -5: expected a time >= 0 (s)"),
    (["--alpha", "2"], "error: --alpha 2: expected a significance level in (0, 1)"),
    (["--criterion", "foo"], "error: --criterion 'foo': expected bic or lrt"),
    (["--accelerations", "maybe"], "error: --accelerations 'maybe': expected select or all")])
def test_estimate_options_are_named_as_the_user_gave_them(option, message):
    """Was: "settle_s -5.0: ..." after reading and resolving a replay, "alpha must lie in
    (0, 1)", "criterion must be one of ...": the library's keywords, not the options."""
    result, text = run("estimate", *REPLAY, "--motion", "curvilinear", *option)
    assert result.exit_code == 2
    assert message in text


@pytest.mark.parametrize("command", [["estimate", "--motion", "cv2d"],
                                     ["estimate", "--motion", "cv2d", "--leg", "1"], ["track"]])
def test_a_file_with_a_header_and_no_rows_is_said_to_have_no_measurement(tmp_path, command):
    """Was: "--motion cv2d: 4 parameters from 0 measurements cannot be identified", "--leg/--snap:
    own-ship legs need one moving own ship ... the set has 0 sensor(s)", "the measurement set
    is empty" (no file named)."""
    path = tmp_path / "header.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=1), path)
    path.write_text("".join(ln for ln in path.read_text().splitlines(keepends=True)
                            if ln.startswith(("#", "time,"))))
    result, text = run(command[0], path, *command[1:])
    assert result.exit_code == 2
    assert f"error: {path}: no measurement (a header without rows): nothing to estimate" in text
