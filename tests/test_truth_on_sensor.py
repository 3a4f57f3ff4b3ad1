"""A bound evaluated with the target on a sensor is refused, never a LAPACK message."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

runner = CliRunner()

SCENARIO = """
name = "crossing"
title = "a target that crosses fixed sensor a at t = 10 s"

[target]
motion = "cv2d"
ref_time = 0.0
truth = {{ x = {x0}, y = 0.0, vx = 10.0, vy = 0.0 }}

[[sensors]]
type = "fixed"
id = "a"
position = [0.0, 0.0, 0.0]

[[sensors]]
type = "fixed"
id = "b"
position = [0.0, 5000.0, 0.0]

[[measurements]]
kind = "bearing"
sensor = "a"
times = {{ start = 0.0, stop = 20.0, step = 1.0 }}
sigma = 1.0

[[measurements]]
kind = "bearing"
sensor = "b"
times = {{ start = 0.0, stop = 20.0, step = 1.0 }}
sigma = 1.0
"""


@pytest.fixture()
def fixed_sensors(tmp_path):
    """Three fixed bearing sensors, one at the origin, looking at (500, 500) m."""
    rows = ["time,sensor,kind,value,sigma,sensor_x,sensor_y"]
    for t in range(1, 21):
        for name, (sx, sy) in {"a": (0, 0), "b": (1000, 0), "c": (0, 1000)}.items():
            b = np.degrees(np.arctan2(500 - sx, 500 - sy)) % 360
            rows.append(f"{t},{name},bearing,{b},1.0,{sx},{sy}")
    path = tmp_path / "fixed.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


def assert_clear(result, *words):
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and "RuntimeWarning" not in result.output
    assert "Eigenvalues" not in result.output and "please report" not in result.output
    for w in words:
        assert w in result.output, result.output


@pytest.mark.parametrize(("motion", "truth"), [("cv2d", "x=0,y=0,vx=0,vy=0"),
                                                ("static2d", "x=0,y=0")])
def test_truth_on_a_sensor_is_refused_naming_truth(fixed_sensors, motion, truth):
    res = runner.invoke(app, ["crlb", str(fixed_sensors), "--motion", motion,
                              "--truth", truth])
    assert_clear(res, "--truth", "sensor 'a'", "undefined")
    # A truth 1 m away is a bound like any other: finite, full rank.
    near = runner.invoke(app, ["crlb", str(fixed_sensors), "--motion", motion,
                               "--truth", truth.replace("x=0", "x=1", 1), "--json"])
    assert near.exit_code == 0, near.output


def test_library_crlb_raises_a_clear_value_error(fixed_sensors):
    meas = tk.read_measurements(fixed_sensors)
    with pytest.raises(ValueError, match=r"on sensor 'a' at t = 1 s.*undefined"):
        tk.crlb(meas, tk.motion_from_name("cv2d"), {"x": 0, "y": 0, "vx": 0, "vy": 0})
    # A truth that reaches sensor a only at t = 5 s is refused too, naming that time.
    with pytest.raises(ValueError, match=r"sensor 'a' at t = 5 s"):
        tk.crlb(meas, tk.motion_from_name("cv2d"), {"x": -50, "y": 0, "vx": 10, "vy": 0})
    b = tk.crlb(meas, tk.motion_from_name("cv2d"), {"x": 1, "y": 0, "vx": 0, "vy": 0})
    assert np.all(np.isfinite(b.std))


def test_scenario_crossing_a_sensor_is_refused_with_at(tmp_path):
    path = tmp_path / "crossing.toml"
    path.write_text(SCENARIO.format(x0=-100.0))
    res = runner.invoke(app, ["crlb", str(path), "--at", "10"])
    assert_clear(res, "sensor 'a'", "t = 10 s")
    with pytest.raises(ValueError, match="sensor 'a'"):
        tk.crlb(tk.load_scenario(path))
    path.write_text(SCENARIO.format(x0=-105.0))  # passes 5 m from it: a valid bound
    ok = runner.invoke(app, ["crlb", str(path), "--at", "10.5"])
    assert ok.exit_code == 0 and "course" in ok.output and "deg" in ok.output, ok.output
