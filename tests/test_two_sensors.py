"""Two bearing sensors on one own ship (a hull array and a towed array), fitted together.

Each sensor keeps its own name and sigma; the fit takes both sets of bearings of the one
emitter. What a user relies on: the truth inside the printed 95 % ellipse in about 95 % of
seeded runs, the fused fit at least as good as either sensor alone, and the own ship's legs
found from both sensors' rows.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.cli.guard import EXIT_NO_ANSWER
from tmakit.io.errors import reader_notes
from tmakit.results.own_legs import own_ship_legs, own_ship_sensors

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
from two_sensors import scenario, study  # the benchmark's own definitions


def test_two_sensors_of_one_ship_are_one_own_ship_with_its_legs():
    meas = scenario().simulate(rng=0)
    assert sorted(meas.sensors) == ["hull", "towed"]
    assert sorted(own_ship_sensors(meas)) == ["hull", "towed"]
    legs = own_ship_legs(meas)  # no sensor named: the one own ship's
    assert [round(g.course_deg) for g in legs.legs] == [45, 315, 45, 315]
    # a fixed station 5 km away is no sensor of the ship
    station = tk.MeasurementSet.from_si(
        meas.time[:3], np.array(["tower"] * 3), np.array(["bearing"] * 3), meas.value_si[:3],
        meas.sigma_si[:3], np.tile([5000.0, 0, 0, 0, 0, 0], (3, 1)))
    both = tk.MeasurementSet.concatenate([meas, station])
    assert sorted(own_ship_sensors(both, "hull")) == ["hull", "towed"]
    with pytest.raises(ValueError, match="not on one own ship"):
        own_ship_legs(both)


@pytest.mark.long
def test_fused_fit_is_honest_and_at_least_as_good_as_either_sensor():
    """200 seeded runs (benchmarks/two_sensors.py): the truth inside the fused fit's 95 % region
    in 95 % +- 3 binomial sigmas of them (181 to 199 of 200), its final-position RMS within
    1.25x its CRLB, and that RMS no larger than either sensor's alone (its bound below both)."""
    r = study(200, 20261207)
    assert all(r[k]["converged"] == 200 for k in r), r
    assert 181 <= r["both"]["inside"] <= 199, r
    assert r["both"]["rms_m"] <= 1.25 * r["both"]["bound_m"], r
    assert r["both"]["rms_m"] <= min(r["hull"]["rms_m"], r["towed"]["rms_m"]), r
    assert r["both"]["bound_m"] < min(r["hull"]["bound_m"], r["towed"]["bound_m"]), r


# --- real files: Debrief samples (tests/data/debrief, README there) and a wide log ---------

DEBRIEF = Path(__file__).parent / "data" / "debrief"


def answers(output: str) -> dict[str, str]:
    return {p[0]: p[1] for p in ([c.strip() for c in line.strip("│ ").split("│")]
                                 for line in output.splitlines()) if len(p) == 4}


def test_a_hull_and_a_towed_array_of_one_debrief_own_ship_are_fitted_together():
    """AssetData's Ambig pair: the towed array TA (ambiguous bearings) and the hull array HM of
    own ship SENSOR, once refused for cuts at one time; fitted together after the subject's
    last manoeuvre they give its leg (160.76 deg, 6 kn) and the own ship's legs from both."""
    files = [str(DEBRIEF / "asset_ambig" / n) for n in
             ("Ambig_tracks2.rep", "Ambig_cuts_TA.rep", "Ambig_cuts_HM.rep")]
    result = CliRunner().invoke(app, ["estimate", *files, "--motion", "cv2d", "--from", "14:00",
                                      "--units", "nautical"])
    assert result.exit_code == 0, result.output
    assert "2 sensors of own ship 'SENSOR' (TA; HM) measure bearing" in result.output
    assert "own-ship legs of SENSOR/TA, SENSOR/HM" in result.output
    rows = answers(result.output)
    assert abs(float(rows["course (true)"]) - 160.76) < 1.0
    assert abs(float(rows["speed"]) - 6.0) < 0.3


OFFSET_SAMPLE = DEBRIEF / "multistatics" / "Vessel_with_Sensor_Offset_first_8_min.rep"


def test_two_sensors_set_apart_on_one_ship_give_what_neither_gives_alone():
    """Debrief's Vessel_with_Sensor_Offset (first 8 minutes): a bow sensor and a tail sensor
    about 1 km astern, each cut at its own stated position, the own ship on one leg. Either
    alone is unobservable; together their baseline gives the subject's 320 deg at 9 kn."""
    runner = CliRunner()
    both = runner.invoke(app, ["estimate", str(OFFSET_SAMPLE), "--motion", "cv2d",
                               "--units", "nautical"])
    assert both.exit_code == 0, both.output
    rows = answers(both.output)
    assert abs(float(rows["course (true)"]) - 320.0) < 2.0
    assert abs(float(rows["speed"]) - 9.0) < 0.3
    for sensor in ("BOW_BRG", "TAIL_BRG"):
        alone = runner.invoke(app, ["estimate", str(OFFSET_SAMPLE), "--contact", sensor,
                                    "--motion", "cv2d"])
        assert alone.exit_code == EXIT_NO_ANSWER, alone.output
        assert answers(alone.output)["speed"] == "unobservable"


def test_two_sensors_set_apart_but_placed_at_the_ship_are_not_answered_confidently(tmp_path):
    """The same cuts with positions NULL (as Debrief's Offset_null_positions.rep has them): both
    sensors are placed at the ship, their bearings disagree by 3.5 to 10 deg, and the fit says
    it is improbable and unobservable rather than answering."""
    null = re.sub(r"(;SENSOR: \d+ \d+ SENSOR @A) \d\d \d\d \d\d\.\d\d N \d{3} \d\d \d\d\.\d\d E",
                  r"\1 NULL", OFFSET_SAMPLE.read_text())
    (tmp_path / "null.rep").write_text(null)
    result = CliRunner().invoke(app, ["estimate", str(tmp_path / "null.rep"), "--motion",
                                      "cv2d", "--json"])
    assert result.exit_code == EXIT_NO_ANSWER, result.output
    out, _ = json.JSONDecoder().raw_decode(result.output[result.output.index("{"):])
    assert out["trust"] == "none"
    assert {"improbable-chi2", "unobservable"} <= {r["code"] for r in out["trust_reasons"]}


WIDE_MAPPING = """time = "utc"
sensor = "ship"
[position]
east = "east"
north = "north"
[[measurement]]
column = "hull_brg"
kind = "bearing"
unit = "deg"
sigma = 2.0
[[measurement]]
column = "towed_brg"
kind = "bearing"
unit = "deg"
sigma = 1.0
"""


def test_a_wide_log_with_two_bearing_columns_is_two_sensors_of_one_platform(tmp_path):
    meas = scenario().simulate(rng=3)
    lines = ["utc,east,north,hull_brg,towed_brg"]
    for k in np.argsort(meas.time, kind="stable"):  # a row per cut, the other cell empty
        t, (x, y) = int(meas.time[k]), meas.sensor_state[k, :2].tolist()
        cells = [repr(float(np.rad2deg(meas.value_si[k]))), ""]
        lines.append(f"2026-01-01T00:{t // 60:02d}:{t % 60:02d}Z,{x!r},{y!r},"
                     + ",".join(cells if meas.sensor[k] == "hull" else cells[::-1]))
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "log.toml").write_text(WIDE_MAPPING)
    read = tk.read_measurements(tmp_path / "log.csv", format="wide", mapping=tmp_path / "log.toml")
    assert sorted(read.sensors) == ["ship/hull_brg", "ship/towed_brg"]
    sigma = {n: set(np.rad2deg(read.sigma_si[read.sensor_mask(n)]).round(9)) for n in read.sensors}
    assert sigma == {"ship/hull_brg": {2.0}, "ship/towed_brg": {1.0}}
    assert "2 columns measure one kind on one sensor" in "\n".join(reader_notes(read.metadata))
    named = WIDE_MAPPING.replace('sigma = 1.0\n', 'sigma = 1.0\nsensor = "towed"\n')
    (tmp_path / "named.toml").write_text(named)
    read = tk.read_measurements(tmp_path / "log.csv", format="wide",
                                mapping=tmp_path / "named.toml")
    assert sorted(read.sensors) == ["ship", "towed"]
    assert tk.estimate(read, "cv2d").converged


def test_each_debrief_sensor_takes_its_own_bearing_sigma():
    """``--bearing-sigma HM=0.05,TA=0.1``: each array's own noise; a name that is no sensor of
    the own ship, or a sigma that is no number > 0, is refused naming the sensors."""
    files = [DEBRIEF / "asset_ambig" / n for n in
             ("Ambig_tracks2.rep", "Ambig_cuts_TA.rep", "Ambig_cuts_HM.rep")]
    meas = tk.read_measurements(files, bearing_sigma_deg={"HM": 0.05, "SENSOR/TA": 0.1})
    sigma = {n: set(np.rad2deg(meas.sigma_si[meas.sensor_mask(n)]).round(9)) for n in
             meas.sensors}
    assert sigma == {"SENSOR/HM": {0.05}, "SENSOR/TA": {0.1}}
    with pytest.raises(tk.MeasurementFileError, match=r"bearing sigma of sensor 'XX': no cut of "
                       r"own ship 'SENSOR' is from it \(sensors: TA; HM\)"):
        tk.read_measurements(files, bearing_sigma_deg={"XX": 1.0})
    runner = CliRunner()
    result = runner.invoke(app, ["estimate", *map(str, files), "--motion", "cv2d", "--from",
                                 "14:00", "--bearing-sigma", "HM=0.05,TA=0.1", "--units",
                                 "nautical"])
    assert result.exit_code == 0, result.output
    rows = answers(result.output)
    assert abs(float(rows["course (true)"]) - 160.76) < 0.2
    assert abs(float(rows["speed"]) - 6.0) < 0.05
    bad = runner.invoke(app, ["show", *map(str, files), "--bearing-sigma", "HM=x"])
    assert bad.exit_code == 2 and "expected a std in degrees (0.5), or one per sensor" in (
        bad.output)
