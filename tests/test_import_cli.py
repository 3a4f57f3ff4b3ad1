"""``tma import`` and ``tma examples``, and the other commands reading real logs directly."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.cli.scenarios import EXAMPLE_FILES

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, [str(a) for a in args])


def examples(tmp_path):
    result = run("examples", tmp_path)
    assert result.exit_code == 0, result.output
    return tmp_path


def test_examples_writes_the_samples_and_refuses_to_overwrite(tmp_path):
    folder = examples(tmp_path / "ex")
    assert sorted(p.name for p in folder.iterdir()) == sorted(EXAMPLE_FILES)
    again = run("examples", folder)
    assert again.exit_code == 2 and "already exists; use --force" in again.output
    assert run("examples", folder, "--force").exit_code == 0


def test_the_legs_printed_say_a_path_that_ends_turning_up_to_the_data_end(tmp_path):
    # the sample drone flies straight for a minute, then circles to the end of its log
    folder = examples(tmp_path / "ex")
    result = run("estimate", folder / "drone.csv", "--mapping", folder / "drone.toml",
                 "--motion", "static2d", "--dim", "2")
    assert result.exit_code == 0, result.output
    legs = result.output.split("own-ship legs of drone")[1].splitlines()[1:]
    assert legs[0].startswith("  leg 1: 09:30:00 to ")
    assert legs[1].endswith(" to 09:32:59 (no straight leg after leg 1)")
    assert legs[1].startswith("  turning: ")


def test_a_range_of_tens_of_kilometres_is_printed_in_whole_metres(tmp_path):
    folder = examples(tmp_path / "ex")  # the contact at 28.7 km at the last bearing
    result = run("estimate", folder / "contact.rep", "--motion", "cv2d")
    assert result.exit_code == 0, result.output
    line = next(x for x in result.output.splitlines() if "range from OWNSHIP" in x)
    value = line.split("│")[2].strip()
    assert value.isdigit() and 28_000 < int(value) < 29_500, line


def test_examples_and_demo_into_a_file_or_under_one_are_refused_naming_the_folder(tmp_path):
    a_file = tmp_path / "obs.csv"
    a_file.write_text("mine\n")
    for args, said in ((("examples", a_file), f"{a_file}: a file of that name exists; "
                        "expected a folder"),
                       (("examples", a_file / "sub"), f"{a_file / 'sub'}: the folder cannot "
                        "be made (Not a directory)"),
                       (("demo", "--out-dir", a_file / "sub"), f"--out-dir {a_file / 'sub'}: "
                        "the folder cannot be made (Not a directory)")):
        result = run(*args)
        assert result.exit_code == 2, result.output
        assert said in " ".join(result.output.split())
    assert a_file.read_text() == "mine\n"


def test_import_rep_writes_tmakits_file_with_clock_time_and_origin(tmp_path):
    folder = examples(tmp_path)
    out = folder / "obs.parquet"
    result = run("import", "rep", folder / "contact.rep", "--ownship", "OWNSHIP", "--contact",
                 "CONTACT", "--bearing-sigma", "0.5", "-o", out)
    assert result.exit_code == 0, result.output
    assert "t = 0 s is 2026-05-04T09:30:00Z (UTC)" in result.output
    assert "ENU origin: lat 47.9500000 deg, lon -5.2500000 deg, alt 0.0 m (msl)" in result.output
    ms = tk.read_measurements(out)
    assert ms.metadata["time_origin"] == "2026-05-04T09:30:00Z" and len(ms) == 720
    assert np.all(ms.sigma == 0.5)
    refused = run("import", "rep", folder / "contact.rep", "-o", out)
    assert refused.exit_code == 2 and "already exists; use --force" in refused.output


def test_import_checks_output_and_arguments_before_work(tmp_path):
    folder = examples(tmp_path)
    bad = run("import", "rep", folder / "contact.rep", "-o", folder / "obs.txt")
    assert bad.exit_code == 2 and "-o" in bad.output and ".parquet" in bad.output
    missing = run("import", "rep", folder / "nothing.rep", "-o", folder / "o.csv")
    assert missing.exit_code == 2 and "no such file" in missing.output
    two = run("import", "gpx", folder / "own.gpx", "-o", folder / "o.csv")
    assert two.exit_code == 2 and "the own track and the measurement log" in two.output
    fmt = run("import", "kml", folder / "own.gpx", "-o", folder / "o.csv")
    assert fmt.exit_code == 2 and "unknown format 'kml'" in fmt.output
    assert not (folder / "o.csv").exists()


def test_import_refusal_names_the_line(tmp_path):
    rep = tmp_path / "bad.rep"
    rep.write_text("260504 093000 OWN @A 47 57 00.00 N 005 15 00.00 E 90.0 x 0.0\n")
    result = run("import", "rep", rep, "-o", tmp_path / "o.parquet")
    assert result.exit_code == 2
    assert f"{rep}: 1 problem" in result.output and "line 1: expected a speed" in result.output
    assert "Traceback" not in result.output


def test_import_wide_gpx_nmea_and_inline_mapping(tmp_path):
    folder = examples(tmp_path)
    drone = run("import", "wide", folder / "drone.csv", "--mapping", folder / "drone.toml",
                "-o", folder / "drone.parquet")
    assert drone.exit_code == 0, drone.output
    assert "sensor velocity: columns (ned)" in drone.output
    inline = run("import", "wide", folder / "drone.csv", "--map",
                 "time=utc,sensor=drone,lat=lat,lon=lon,alt=alt_m,altitude=msl,vn=vn,ve=ve,vd=vd",
                 "--measure", "rssi_dbm=power:dBm:2", "--measure", "freq_hz=frequency:Hz:1",
                 "-o", folder / "inline.parquet")
    assert inline.exit_code == 0, inline.output
    a = tk.read_measurements(folder / "drone.parquet")
    b = tk.read_measurements(folder / "inline.parquet")
    assert np.array_equal(a.value, b.value) and np.array_equal(a.sensor_state, b.sensor_state)
    for fmt, track in (("gpx", "own.gpx"), ("nmea", "own.nmea")):
        result = run("import", fmt, folder / track, folder / "bearings.csv", "--mapping",
                     folder / "bearings.toml", "-o", folder / f"{fmt}.csv")
        assert result.exit_code == 0, result.output
        assert len(tk.read_measurements(folder / f"{fmt}.csv")) == 119


@pytest.mark.parametrize(("args", "words"), [
    # the second lat was taken without a word: the longitudes read as latitudes
    (["wide", "drone.csv", "--map", "time=utc,lat=lat,lon=lon,lat=lon", "--measure",
      "rssi_dbm=power:dBm:2"], "--map 'time=utc,lat=lat,lon=lon,lat=lon': lat is given twice"),
    # 'the column mapping is not valid: measurement: List should have at least 1 item'
    (["rep", "contact.rep", "--map", "time=utc"], "--map and --measure apply to wide logs"),
])
def test_import_refuses_a_mapping_option_it_would_misread(tmp_path, args, words):
    folder = examples(tmp_path)
    result = run("import", args[0], folder / args[1], *args[2:], "-o", tmp_path / "o.csv")
    assert result.exit_code == 2 and words in " ".join(result.output.split()), result.output
    assert not (tmp_path / "o.csv").exists()


def test_estimate_show_crlb_track_read_a_replay_file_directly(tmp_path):
    folder = examples(tmp_path)
    rep = folder / "contact.rep"
    est = run("estimate", rep, "--ownship", "OWNSHIP", "--contact", "CONTACT", "--motion",
              "cv2d", "--bearing-sigma", "0.5")
    assert est.exit_code == 0, est.output
    assert "converged" in est.output
    assert run("show", rep).exit_code == 0
    crlb = run("crlb", rep, "--motion", "cv2d", "--truth", "x=2000,y=5000,vx=-4,vy=-3")
    assert crlb.exit_code == 0, crlb.output
    wide = run("estimate", folder / "drone.csv", "--mapping", folder / "drone.toml",
               "--motion", "static2d")
    assert wide.exit_code == 0, wide.output
    own = run("estimate", folder / "drone.csv", "--ownship", "X", "--motion", "static2d")
    assert own.exit_code == 2 and "--ownship applies to real logs" in own.output


def test_a_failed_3d_start_names_dim_2(tmp_path):
    folder = examples(tmp_path)
    out = folder / "three.csv"
    assert run("import", "rep", folder / "contact.rep", "--dim", "3", "-o", out).exit_code == 0
    assert tk.read_measurements(out).dim == 3  # the Earth's curvature becomes height
    result = run("track", out)
    assert result.exit_code == 2 and "track in 2-D (--dim 2)" in result.output
    assert run("track", out, "--dim", "2", "--rows", "2").exit_code == 0


def test_replay_range_and_frequency_sigmas_from_the_command_line(tmp_path):
    rep = tmp_path / "s.rep"
    rep.write_text(";; test\n"
                   "260504 093000 OWN @A 47 57 00.00 N 005 15 00.00 W 90.0 10.0 0.0\n"
                   "260504 093100 OWN @A 47 57 00.00 N 005 14 12.00 W 90.0 10.0 0.0\n"
                   ";SENSOR2: 260504 093030 OWN @A NULL 10.0 NULL 150.5 1000 TA T1\n"
                   ";SENSOR3: 260504 093040 OWN @A NULL 12.0 0.7 150.6 0.02 1100 TA T1\n")
    out = tmp_path / "o.csv"
    result = run("import", "rep", rep, "--range-sigma", "30", "--frequency-sigma", "0.5",
                 "-o", out)
    assert result.exit_code == 0, result.output
    assert "sigma: bearing 1 deg, range 30 m, frequency 0.5 Hz; 1 ;SENSOR3: lines state their " \
           "own accuracy" in " ".join(result.output.split())
    ms = tk.read_measurements(out)
    assert np.allclose(ms.select(kind="range").sigma_si, 30.0)
    assert np.allclose(ms.select(kind="frequency").sigma_si, 0.5)  # the user's word wins
    assert np.allclose(ms.select(kind="bearing").sigma, [1.0, 0.7])  # the line's accuracy
    shown = run("show", rep, "--range-sigma", "30")
    assert shown.exit_code == 0 and "30" in shown.output
    bad = run("import", "rep", rep, "--range-sigma", "-1", "-o", tmp_path / "b.csv")
    assert bad.exit_code == 2 and ("--range-sigma -1: expected a noise standard deviation > 0 "
                                   "(m)") in bad.output


def test_import_refuses_a_track_whose_suffix_says_the_other_format(tmp_path):
    folder = examples(tmp_path)
    for fmt, track, other in (("nmea", "own.gpx", "gpx"), ("gpx", "own.nmea", "nmea")):
        result = run("import", fmt, folder / track, folder / "bearings.csv", "--mapping",
                     folder / "bearings.toml", "-o", folder / f"{fmt}.parquet")
        assert result.exit_code == 2
        assert f"use tma import {other}" in " ".join(result.output.split())
        assert not (folder / f"{fmt}.parquet").exists()
    # a folder or a missing file given as the track: said as such, not as the other format
    none = tmp_path / "none"
    for track, said in ((tmp_path, f"{tmp_path}: is a folder"), (none, f"{none}: no such file")):
        result = run("import", "gpx", track, folder / "bearings.csv", "--mapping",
                     folder / "bearings.toml", "-o", folder / "gpx.parquet")
        assert result.exit_code == 2 and said in result.output, result.output
