"""Scenarios: the built-in papers' scenarios, simulation, and scenario-file validation."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tmakit as tk
from tmakit.core.units import free_space_constant, snr_to_sigma_db
from tmakit.observation import ObservationModel
from tmakit.scenario.files import ScenarioFileError, builtin_scenario_names, scenario_from_dict

PAPERS = {"gu2007", "doppler-lecture", "hoerst2010", "chen-sun-1", "chen-sun-2",
          "chen-sun-3", "hurtado2008"}
#: tmakit's own test beds (no paper gives them).
OWN = {"bearings-only-2d", "plan-bearings-only"}
EXPECTED = PAPERS | OWN


def test_every_paper_has_its_builtin_scenario():
    assert set(builtin_scenario_names()) == EXPECTED
    titles = dict(tk.builtin_scenarios())
    assert all(titles[name] for name in EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_builtin_scenarios_simulate_deterministically(name):
    scn = tk.load_scenario(name)
    a = scn.simulate(rng=7)
    b = scn.simulate(rng=np.random.default_rng(7))
    c = scn.simulate(rng=8)
    assert len(a) > 0
    assert np.array_equal(a.value, b.value)
    assert not np.array_equal(a.value, c.value)
    assert np.all(np.isfinite(a.value)) and np.all(a.sigma > 0)
    # Rows grouped by sensor, time non-decreasing within each sensor.
    for s in a.sensors:
        assert np.all(np.diff(a.time[a.sensor == s]) >= 0)
    truth = json.loads(a.metadata["truth"])
    assert truth == pytest.approx(scn.truth)


def test_gu2007_distance_check_from_the_issue():
    """Target-sensor distance over t = 0..120 s: mean 2718 m, max 3634 m, min 1935 m."""
    scn = tk.load_scenario("gu2007")
    t = np.arange(0.0, 121.0)
    r = np.linalg.norm(scn.target_states(t)[:, :3] - scn.sensors["uav"].states(t)[:, :3],
                       axis=1)
    assert round(r.mean()) == 2718
    assert round(r.max()) == 3634
    assert round(r.min()) == 1935
    # Sensor flies at a constant 50 m/s.
    speed = np.linalg.norm(scn.sensors["uav"].states(t)[:, 3:], axis=1)
    assert np.allclose(speed, 50.0)


def test_gu2007_values_and_noise_model():
    scn = tk.load_scenario("gu2007")
    assert scn.truth == {"x": 3200.0, "y": 3200.0, "vx": -21.65, "vy": -12.5}
    assert 10 ** (scn.nuisance["power_constant_db"] / 10) == pytest.approx(1.5766e-4, rel=1e-4)
    assert free_space_constant(1.9e9) == pytest.approx(1.5766e-4, rel=1e-4)
    clean = scn.simulate(noise=False)
    noisy = scn.simulate(rng=11)
    power = clean.kind == "power"
    assert power.sum() == 120 and (~power).sum() == 120
    # The paper's 158.4 Hz is the shift from the target's own 25 m/s; with the UAV's 50 m/s
    # the total shift is bounded by (25 + 50) / c * f_s.
    assert 25.0 / 299_792_458.0 * 1.9e9 == pytest.approx(158.4, abs=0.05)
    shift = clean.value[~power] - 1.9e9
    assert 150.0 < np.abs(shift).max() < 75.0 / 299_792_458.0 * 1.9e9
    # Power noise: var(eta / P) = 1/SNR_p exactly as the paper defines it (40 dB).
    ratio = 10 ** ((noisy.value[power] - clean.value[power]) / 10) - 1
    assert np.std(ratio) == pytest.approx(0.01, rel=0.2)
    assert np.allclose(noisy.sigma[power], snr_to_sigma_db(40.0))
    freq_noise = noisy.value[~power] - clean.value[~power]
    assert np.std(freq_noise) == pytest.approx(1.9, rel=0.2)


def test_gu2007_crlb_table1_is_reproduced_by_the_path():
    """The issue's sensor path reproduces Table 1 of Gu et al. (2007) (C and f_s known) to 1e-3."""
    paper = {("power",): [15.7821, 15.6618, 0.1252, 0.4294],
             ("frequency",): [15.3020, 15.7205, 0.3150, 0.2005],
             ("power", "frequency"): [3.9263, 3.8172, 0.0361, 0.1025]}
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(noise=False)
    for kinds, expected in paper.items():
        part = meas.take(np.isin(meas.kind, kinds))
        obs = ObservationModel(part, scn.motion, scn.measurement_options)
        jac, _ = obs.jacobian(scn.theta, obs.nuisance_vector(scn.nuisance))
        w = jac / obs.sigmas[:, None]
        std = np.sqrt(np.diag(np.linalg.inv(w.T @ w)))
        # The paper prints 4 decimals; 1e-3 relative plus half a printed digit.
        assert np.all(np.abs(std - expected) <= 1e-3 * np.abs(expected) + 5e-5), (kinds, std)


def test_chen_sun_range_difference_noise_accumulates_per_interval():
    scn = tk.load_scenario("chen-sun-1")
    clean = scn.simulate(noise=False)
    rd = clean.kind == "range_difference"
    assert np.allclose(clean.time[rd] - clean.time_ref[rd], 1.0)
    # Range differences sum to the range change over the whole track.
    states = scn.target_states(clean.time[rd]) - clean.sensor_state[rd]
    r = np.linalg.norm(states[:, :3], axis=1)
    r0 = np.linalg.norm(scn.target_states([0.0])[0, :3] - np.array([30e3, 0, 0]))
    assert np.cumsum(clean.value[rd])[-1] == pytest.approx(r[-1] - r0, abs=1e-6)
    # A lag-3 plan: sigma grows as sqrt(3); neighbouring differences share noise.
    data = _minimal_dict()
    data["measurements"] = [{"kind": "range_difference", "sensor": "s", "pri": 1.0,
                             "times": {"start": 0, "stop": 2000, "step": 1}, "sigma": 5.0,
                             "lags": [3]}]
    scn3 = scenario_from_dict(data)
    noisy, clean = scn3.simulate(rng=3), scn3.simulate(noise=False)
    err = noisy.value - clean.value
    assert np.allclose(noisy.sigma, 5.0 * np.sqrt(3))
    assert np.std(err) == pytest.approx(5.0 * np.sqrt(3), rel=0.1)
    lag1_corr = np.corrcoef(err[:-1], err[1:])[0, 1]
    assert lag1_corr == pytest.approx(2 / 3, abs=0.08)


def test_hoerst2010_target_and_observer():
    scn = tk.load_scenario("hoerst2010")
    t = np.array([0.0, 400.0, 600.0, 900.0])
    tgt = scn.target_states(t)
    assert tgt[0, :2] == pytest.approx([-9000.0, 12000.0])
    assert tgt[1, :2] == pytest.approx([11000.0, 12000.0])  # 400 s due East at 50 m/s
    assert np.linalg.norm(tgt[:, 3:5], axis=1) == pytest.approx([50.0] * 4)
    obs = scn.sensors["observer"].states(np.array([0.0, 2 * np.pi / 0.025]))
    assert obs[1, :2] == pytest.approx([0.0, 0.0], abs=1e-6)  # full circle
    quarter = scn.sensors["observer"].states(np.array([np.pi / 2 / 0.025]))
    assert quarter[0, :2] == pytest.approx([-2000.0, 2000.0])  # counter-clockwise, radius 2 km
    meas = scn.simulate(rng=1)
    assert meas.time.max() == 900.0


def _minimal_dict():
    return {
        "name": "t",
        "target": {"motion": "cv2d", "truth": {"x": 1000.0, "y": 5000.0, "vx": 3.0,
                                               "vy": 0.0}},
        "sensors": [{"type": "fixed", "id": "s", "position": [0.0, 0.0]}],
        "measurements": [{"kind": "bearing", "sensor": "s",
                          "times": {"start": 0, "stop": 10, "step": 1}, "sigma": 1.0}],
    }


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d["sensors"][0].update(position=[0.0]), "sensors[0].fixed.position"),
    (lambda d: d["measurements"][0].update(kind="azimuth"), "unknown kind 'azimuth'"),
    (lambda d: d["measurements"][0].update(sigma=-1.0), "measurements[0].sigma"),
    (lambda d: d["target"]["truth"].pop("vy"), "missing vy"),
    (lambda d: d["target"].update(motion="cv4d"), "unknown motion model 'cv4d'"),
    (lambda d: d["measurements"][0].update(sensor="nobody"), "sensor 'nobody'"),
    (lambda d: d.update(colour="blue"), "colour"),
    (lambda d: d["measurements"][0].update(kind="frequency"), "carrier"),
    # both were simulated: the heading 1e300 deg (float garbage mod 360), a turn of 1e9 deg/s
    (lambda d: d["sensors"].__setitem__(0, {
        "type": "legs", "id": "s", "start": [0.0, 0.0], "heading_deg": 1e300, "speed": 8.0,
        "legs": [{"duration": 10.0}]}), "sensors[0].legs.heading_deg: Input should be less "
                                         "than or equal to 360"),
    (lambda d: d["sensors"].__setitem__(0, {
        "type": "legs", "id": "s", "start": [0.0, 0.0], "heading_deg": 45.0, "speed": 8.0,
        "legs": [{"duration": 10.0, "turn_rate_deg_s": -1e9}]}),
     "sensors[0].legs.legs[0].turn_rate_deg_s: Input should be greater than or equal to -360"),
])
def test_bad_scenario_files_are_refused_naming_the_field(mutate, expected):
    data = _minimal_dict()
    mutate(data)
    with pytest.raises(ScenarioFileError) as info:
        scenario_from_dict(data, "bad.toml")
    assert "bad.toml" in str(info.value)
    assert expected in str(info.value)


def test_scenario_file_on_disk_and_unknown_names(tmp_path):
    p = tmp_path / "mine.toml"
    p.write_text('name = "mine"\n[target]\nmotion = "static"\ntruth = {x = 1.0, y = 2.0}\n'
                 '[[sensors]]\ntype = "waypoints"\nid = "a"\npoints = [[0, 0], [100, 0]]\n'
                 'speed = 10\n[[measurements]]\nkind = "bearing"\nsensor = "a"\n'
                 'times = [0, 5, 10]\nsigma = 0.5\n')
    scn = tk.load_scenario(p)
    assert scn.name == "mine" and len(scn.simulate(1)) == 3
    with pytest.raises(ScenarioFileError, match=r"unknown scenario 'nope'.*gu2007"):
        tk.load_scenario("nope")
    bad = tmp_path / "broken.toml"
    bad.write_text("name = \n")
    with pytest.raises(ScenarioFileError, match=r"broken\.toml: not valid TOML"):
        tk.load_scenario(bad)


def test_east_ccw_convention_converts_headings_and_turns():
    data = _minimal_dict()
    data["angle_convention"] = "east_ccw"
    data["sensors"] = [{"type": "legs", "id": "s", "start": [0.0, 0.0], "heading_deg": 0.0,
                        "speed": 10.0, "legs": [{"duration": 1e9, "turn_rate_deg_s": 1.0}]}]
    scn = scenario_from_dict(data)
    st = scn.sensors["s"].states(np.array([0.0, 1.0]))
    assert st[0, 3:5] == pytest.approx([10.0, 0.0])  # heading 0 from East = moving East
    assert st[1, 4] > 0  # counter-clockwise turn from East heads North


def test_geodetic_sensor_positions(tmp_path):
    data = _minimal_dict()
    data["origin"] = [45.0, 7.0, 100.0]
    data["sensors"] = [{"type": "fixed", "id": "s", "position_geodetic": [45.01, 7.0, 100.0]}]
    scn = scenario_from_dict(data)
    pos = scn.sensors["s"].states(np.array([0.0]))[0, :3]
    assert pos[0] == pytest.approx(0.0, abs=1e-6)
    assert pos[1] == pytest.approx(1111.5, abs=2.0)  # 0.01 deg of latitude at 45 deg
    meas = scn.simulate(1)
    assert meas.metadata["origin_lat"] == "45.0"
    data.pop("origin")
    with pytest.raises(ScenarioFileError, match="origin"):
        scenario_from_dict(data)


def test_the_example_in_docs_scenarios_loads(tmp_path):
    from pathlib import Path

    doc = (Path(__file__).parent.parent / "docs" / "scenarios.md").read_text()
    example = doc.split("```toml\n")[1].split("```")[0]
    path = tmp_path / "harbour.toml"
    path.write_text(example)
    meas = tk.load_scenario(path).simulate(rng=1)
    assert set(meas.sensors) == {"tower", "boat"}
    assert meas.kinds == ["bearing", "frequency"]
