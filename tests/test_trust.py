"""Never confidently wrong (issue 26, item 4): the height chosen by the data, exit statuses and
``trust``, a chi-square too small flagged, and no number for what the data do not determine."""

from __future__ import annotations

import dataclasses
import json
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.cli.estimate import print_estimate
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.results import SanityWarning, trust_of
from tmakit.results.checks import chi2_low_warning, scale_sigma
from tmakit.scenario.files import scenario_from_dict

runner = CliRunner()
INSIDE_95 = 5.991  # chi-square with 2 dof at 0.95


def run(*args: object):
    return runner.invoke(app, [str(a) for a in args])


# --- the height ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def drone():
    folder = resources.files("tmakit") / "examples"
    truth = json.loads((folder / "truth.json").read_text())["drone.csv"]
    with resources.as_file(folder / "drone.csv") as log, \
            resources.as_file(folder / "drone.toml") as mapping:
        log, mapping = Path(log), Path(mapping)
        meas = tk.read_measurements(log, format="wide", mapping=mapping)
        yield log, mapping, meas, truth


def _truth_en(meas, truth):
    origin = [float(meas.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(truth["lat"], truth["lon"], origin[2], origin)
    return np.array([float(e), float(n)])


def _miss(answer_enu, cov, truth_en):
    err = np.array(answer_enu[:2], dtype=float) - truth_en
    return float(np.hypot(*err)), float(err @ np.linalg.solve(np.asarray(cov)[:2, :2], err))


def test_the_drone_log_in_2d_is_confidently_wrong_and_the_height_check_puts_it_right(drone):
    _, _, meas, truth = drone
    assert meas.dim == 2  # the surface rule: altitudes within 25 m
    flat = tk.estimate(meas, "static2d")
    choice = tk.choose_height(meas, flat)
    truth_en = _truth_en(meas, truth)
    a_flat = flat.answer(meas)
    d_flat, m2_flat = _miss(a_flat.enu, a_flat.covariance, truth_en)
    assert m2_flat > 30 and d_flat > 10  # what the 2-D fit says of a drone 90 m up
    assert choice.dim == 3 and choice.result.motion.name == "static3d"
    assert choice.p_value < 1e-3 and choice.delta_chi2 > 10
    a = choice.result.answer(meas)
    d, m2 = _miss(a.enu, a.covariance, truth_en)
    assert m2 <= INSIDE_95 and d <= 5.0
    # below the plane (the drone flies at 120 m): within 3 std of the truth's 90 m
    z, sz = choice.result.estimate[2], choice.result.std[2]
    assert z < 0 and abs(z - (truth["alt"] - float(meas.metadata["origin_alt"]))) < 3 * sz
    assert "below" in choice.note and "--dim 2" in choice.note


def test_the_defaults_of_tma_estimate_on_the_drone_log_put_the_truth_inside_the_ellipse(drone):
    log, mapping, meas, truth = drone
    result = run("estimate", log, "--mapping", mapping, "--motion", "static2d", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["motion"] == "static3d" and data["height"]["dim"] == 3
    assert data["height"]["p_value"] < 1e-3 and data["trust"] == "ok"
    cov = np.array(data["answer"]["state_covariance"], dtype=float)
    pos = data["answer"]["position"]
    d, m2 = _miss((pos["east_m"]["value"], pos["north_m"]["value"]), cov,
                  _truth_en(meas, truth))
    assert m2 <= INSIDE_95 and d <= 5.0
    text = run("estimate", log, "--mapping", mapping, "--motion", "static2d")
    words = " ".join(text.stdout.split())  # (rich wraps lines)
    assert "the data need the height" in words and "altitude (mean sea level)" in words
    flat = run("estimate", log, "--mapping", mapping, "--motion", "static2d", "--dim", "2",
               "--json")
    assert json.loads(flat.stdout)["motion"] == "static2d"


def test_over_seeded_drone_logs_the_defaults_cover_the_truth_and_2d_alone_does_not(tmp_path):
    from sample_logs import drone_sample

    inside = inside_2d = 0
    for seed in range(20):
        text, mapping, truth = drone_sample(seed)
        (tmp_path / "d.csv").write_text(text)
        (tmp_path / "d.toml").write_text(mapping)
        meas = tk.read_measurements(tmp_path / "d.csv", format="wide",
                                    mapping=tmp_path / "d.toml")
        choice = tk.choose_height(meas, tk.estimate(meas, "static2d"))
        assert choice.dim == 3 and choice.result.estimate[2] < 0  # airborne: below
        for result, count in ((choice.result, "3"), (choice.flat, "2")):
            a = result.answer(meas)
            inside_now = _miss(a.enu, a.covariance, _truth_en(meas, truth))[1] <= INSIDE_95
            if count == "3":
                inside += inside_now
            else:
                inside_2d += inside_now
    assert inside >= 17 and inside_2d <= 5  # 95 % expected; the 2-D fit alone: 4 % of 100


def test_dim_is_refused_where_no_height_can_be_fitted(tmp_path):
    obs = tmp_path / "bo.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=1), obs)
    bearings = run("estimate", obs, "--motion", "cv2d", "--dim", "3")
    assert bearings.exit_code == 2 and "--dim 3" in bearings.output
    assert run("estimate", obs, "--motion", "cv2d", "--dim", "4").exit_code == 2
    manoeuvre = run("estimate", obs, "--motion", "curvilinear:1", "--dim", "2")
    assert manoeuvre.exit_code == 2 and "--dim" in manoeuvre.output


def test_bearings_only_fits_are_not_refitted_in_3d(tmp_path):
    meas = tk.load_scenario("bearings-only-2d").simulate(rng=1)
    flat = tk.estimate(meas, "cv2d")
    choice = tk.choose_height(meas, flat)
    assert choice.result is flat and choice.raised is None and choice.dim == 2


# --- one straight own-ship leg -----------------------------------------------------------------


def _straight_leg(duration: float = 600.0):
    """``bearings-only-2d`` whose observer holds course and speed throughout."""
    import tomllib

    text = (resources.files("tmakit.scenario") / "builtin" / "bearings-only-2d.toml").read_text()
    d = tomllib.loads(text)
    d["sensors"][0]["legs"] = [{"duration": math.inf}]
    d["measurements"][0]["times"]["stop"] = duration
    return scenario_from_dict(d, "<straight leg>")


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    scn = _straight_leg()
    meas = scn.simulate(rng=3)
    path = tmp_path_factory.mktemp("straight") / "straight.csv"
    tk.write_measurements(meas, path)
    return scn, meas, path


def test_range_from_one_straight_leg_is_explained_in_words_with_the_leg(straight):
    _, meas, _ = straight
    res = tk.estimate(meas, "cv2d")
    assert res.status == "unobservable"
    (direction,) = res.bound.observability.directions
    s = direction.sentence
    assert s.startswith("range is not observable: the own ship observer did not manoeuvre")
    assert "t = 1 .. 600 s, course 45° at 8 m/s" in s and "turn of 30°" in s
    assert "combination" not in s
    a = res.answer(meas)
    assert a.enu[:2] == (None, None) and a.range_m is None and a.ellipse is None
    assert a.course_deg is None and a.speed is None  # they move with the range
    truth = json.loads(meas.metadata["truth"])
    true_xy = np.array([truth["x"] + truth["vx"] * 600, truth["y"] + truth["vy"] * 600])
    own = meas.sensor_state[-1, :2]
    true_bearing = np.degrees(np.arctan2(*(true_xy - own))) % 360
    assert abs(a.bearing_deg - true_bearing) < 4 * a.bearing_std_deg  # what the data give


def test_a_stationary_emitter_seen_from_one_straight_leg_keeps_its_range(straight):
    # the rule is about a moving target: a stationary one is triangulated by the moving sensor
    scn = dataclasses.replace(_straight_leg(), motion=tk.motion_from_name("static2d"),
                              truth={"x": 4000.0, "y": 9000.0})
    meas = scn.simulate(rng=4)
    res = tk.estimate(meas, "static2d")
    assert res.status == "converged"
    assert res.answer(meas).range_m is not None


def test_a_manoeuvre_model_does_not_invent_range_from_one_straight_leg(straight, tmp_path):
    _, meas, path = straight
    res = tk.estimate(meas, "curvilinear:1", exact=True)
    assert res.status == "unobservable"
    sentence = res.bound.observability.directions[0].sentence
    assert "did not manoeuvre" in sentence and "no information about range" in sentence
    a = res.answer(meas)
    assert a.speed is None and a.course_deg is None and a.enu[:2] == (None, None)
    data = res.as_dict()
    assert data["final_state"]["x"]["value"] is None
    assert all(v is None for v, n in zip(data["estimate"], data["parameters"], strict=True)
               if n in ("x", "y", "speed", "course"))
    out = run("estimate", path, "--motion", "curvilinear:1", "--exact", "--plot",
              tmp_path / "c.svg")
    assert out.exit_code == 4
    words = " ".join(out.stdout.split())
    assert " kn" not in words and "e+0" not in words
    assert "position at t = 600 s: unobservable" in words and "trust: none" in words


def test_the_picture_of_an_unobservable_fit_has_no_track_but_the_fan_and_the_words(
        straight, tmp_path):
    import matplotlib

    from tmakit.plot.solution import plot_solution
    from tmakit.results import normalised_residuals

    _, meas, _ = straight
    res = tk.estimate(meas, "cv2d")
    with matplotlib.rc_context({"svg.fonttype": "none"}):  # text kept as text
        path = plot_solution(meas, res, tmp_path / "u.svg",
                             residuals=normalised_residuals(res, meas))
    svg = path.read_text()
    assert "no track: the estimate is unobservable" in svg
    assert "did not manoeuvre" in svg and "bearings (" in svg
    assert "estimate (" not in svg and "ellipses" not in svg
    good = tk.estimate(tk.load_scenario("bearings-only-2d").simulate(rng=1), "cv2d")
    m2 = tk.load_scenario("bearings-only-2d").simulate(rng=1)
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        drawn = plot_solution(m2, good, tmp_path / "g.svg",
                              residuals=normalised_residuals(good, m2)).read_text()
    assert "estimate (converged)" in drawn and "no track" not in drawn


def test_the_command_line_says_no_answer_with_exit_4_and_no_number(straight):
    _, _, path = straight
    text = run("estimate", path, "--motion", "cv2d")
    assert text.exit_code == 4
    words = " ".join(text.stdout.split())
    assert "did not manoeuvre" in words and "combination" not in words
    assert "no answer" in words and "trust: none" in words
    data = json.loads(run("estimate", path, "--motion", "cv2d", "--json").stdout)
    assert data["trust"] == "none" and data["status"] == "unobservable"
    assert data["trust_reasons"][0]["code"] == "unobservable"
    assert "did not manoeuvre" in data["trust_reasons"][0]["message"]
    assert data["estimate"] == [None] * 4 and data["covariance"][0] == [None] * 4
    assert data["answer"]["course_deg"]["value"] is None
    assert data["answer"]["from_sensor"]["bearing_deg"]["value"] is not None


# --- trust and exit statuses ---------------------------------------------------------------------


def _with_sigma(meas, factor):
    return tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                     meas.sigma_si * factor, meas.sensor_state,
                                     metadata=meas.metadata)


@pytest.fixture(scope="module")
def bo():
    return tk.load_scenario("bearings-only-2d").simulate(rng=5)


def test_an_improbable_fit_exits_0_only_with_its_warning(bo, tmp_path):
    path = tmp_path / "tight.csv"
    tk.write_measurements(_with_sigma(bo, 0.02), path)  # chi2/dof about 2500
    result = run("estimate", path, "--motion", "cv2d", "--json")
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    assert data["chi2"] / data["dof"] > 1000
    assert data["trust"] == "warning"
    assert [r["code"] for r in data["trust_reasons"]] == ["improbable-chi2"]
    assert "warning: the fit is improbable" in result.output  # on stderr


def test_a_chi2_far_below_its_dof_is_flagged_with_the_factor_scale_sigma_applies(bo, tmp_path):
    loose = _with_sigma(bo, 10.0)
    res = tk.estimate(loose, "cv2d")
    w = chi2_low_warning(res.chi2, res.dof)
    assert w is not None and w.code == "chi2-too-small"
    factor = 1.0 / math.sqrt(res.chi2 / res.dof)
    assert f"about {factor:.3g} times too large" in w.message and "--scale-sigma" in w.message
    assert res.trust(loose).level == "warning"
    assert chi2_low_warning(res.dof * 0.9, res.dof) is None  # an ordinary low value is fine
    path = tmp_path / "loose.csv"
    tk.write_measurements(loose, path)
    out = run("estimate", path, "--motion", "cv2d")
    assert out.exit_code == 0 and "too good to be true" in out.output
    assert "trust: warning" in out.stdout
    scaled = run("estimate", path, "--motion", "cv2d", "--scale-sigma", "--json")
    data = json.loads(scaled.stdout)
    assert data["sigma_scale"]["bearing"] == pytest.approx(1.0 / factor, rel=0.05)
    assert data["trust"] == "ok"


def test_noise_free_data_are_flagged_and_not_rescaled_to_zero(tmp_path):
    exact = tk.load_scenario("bearings-only-2d").simulate(noise=False)  # chi2 = 0.00
    res = tk.estimate(exact, "cv2d")
    w = chi2_low_warning(res.chi2, res.dof)
    assert w is not None and res.chi2 / res.dof < 1e-6
    assert "noise-free data?" in w.message or "times too large" in w.message
    with pytest.raises(ValueError, match="noise-free"):
        scale_sigma(exact, np.zeros(len(exact)), res.dof)


def test_trust_is_derived_in_one_place_from_the_status_and_every_warning(bo):
    res = tk.estimate(bo, "cv2d")
    assert trust_of(res, []).level == "ok" and res.trust(bo).level == "ok"
    other = SanityWarning("ambiguous", "several solutions fit the data")
    t = trust_of(res, [other])
    assert t.level == "warning" and t.as_dict()["trust_reasons"][0]["code"] == "ambiguous"
    stopped = dataclasses.replace(res, status="did not converge",
                                  message="the iteration limit was reached")
    t = trust_of(stopped, [other])
    assert t.level == "none" and not t.answer
    assert [r.code for r in t.reasons] == ["did not converge", "ambiguous"]


def test_a_fit_that_did_not_converge_prints_no_number_and_exits_4(bo, capsys):
    res = tk.estimate(bo, "cv2d")
    stopped = dataclasses.replace(res, status="did not converge",
                                  message="the iteration limit was reached")
    data = stopped.as_dict()
    assert data["estimate"] == [None] * 4 and data["last_iterate"][0] == pytest.approx(
        res.estimate[0])
    assert "no answer" in stopped.summary() and f"{res.estimate[0]:.8g}" not in stopped.summary()
    with pytest.raises(typer.Exit) as e:
        print_estimate(bo, stopped, as_json=True, warnings=[])
    assert e.value.exit_code == 4
    out = json.loads(capsys.readouterr().out)
    assert out["trust"] == "none" and out["answer"] is None
    assert out["covariance"][0] == [None] * 4
