"""Answers in the user's terms (issue 12, item 3): computed once in results, used everywhere."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.results import track_answer
from tmakit.results.answers import KNOT, estimate_answer, position_ellipse

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, list(args))


@pytest.fixture(scope="module")
def bo():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=3)
    return scn, meas, tk.estimate(meas, scn.motion)


def test_course_speed_range_bearing_match_an_independent_computation(bo):
    _, meas, res = bo
    a = res.answer(meas)
    assert a.time == meas.time.max() and a.sensor == "observer"
    # The bound's own delta method (another code path) at the same time.
    derived = res.bound.derived(a.time)
    assert a.speed == pytest.approx(derived["speed"][0])
    assert a.speed_std == pytest.approx(derived["speed"][1])
    assert a.course_deg == pytest.approx(np.degrees(derived["course"][0]) % 360)
    assert a.course_std_deg == pytest.approx(np.degrees(derived["course"][1]))
    assert a.speed_knots == pytest.approx(a.speed / KNOT)
    # Range and bearing from the observer's recorded position at that time.
    k = int(np.argmax(meas.time))
    d = np.array([a.enu[0], a.enu[1]]) - meas.sensor_state[k, :2]
    assert a.range_m == pytest.approx(np.hypot(*d))
    assert a.bearing_deg == pytest.approx(np.degrees(np.arctan2(d[0], d[1])) % 360)
    # The estimate is near the truth (a well-conditioned geometry): within 4 sigma.
    truth = np.array([4000 - 6 * a.time, 9000 - 3 * a.time])
    assert abs(a.enu[0] - truth[0]) < 4 * a.enu_std[0]
    assert abs(a.enu[1] - truth[1]) < 4 * a.enu_std[1]
    assert abs(a.course_deg - np.degrees(np.arctan2(-6, -3)) % 360) < 4 * a.course_std_deg


def test_bearing_std_is_the_linearised_std_of_the_bearing(bo):
    _, meas, res = bo
    a = res.answer(meas, time=300.0)
    where = meas.sensor_state[np.argmin(np.abs(meas.time - 300.0)), :3]
    # Finite-difference gradient of the bearing with respect to the motion parameters.
    theta = res.estimate

    def bearing(th):
        s = res.motion.states(th, np.array([300.0]))[0]
        return np.arctan2(s[0] - where[0], s[1] - where[1])

    g = np.array([(bearing(theta + h) - bearing(theta - h)) / (2e-3)
                  for h in np.eye(theta.size) * 1e-3])
    assert a.bearing_std_deg == pytest.approx(np.degrees(np.sqrt(g @ res.covariance @ g)),
                                              rel=1e-4)


def test_ellipse_holds_the_stated_probability():
    cov = np.array([[400.0, 120.0], [120.0, 100.0]])
    e = position_ellipse(cov, 0.95)
    rng = np.random.default_rng(0)
    pts = rng.multivariate_normal([0, 0], cov, 200_000)
    # Inside the ellipse: rotate into its axes (orientation is clockwise from North).
    th = np.radians(e.orientation_deg)
    major = pts[:, 0] * np.sin(th) + pts[:, 1] * np.cos(th)
    minor = pts[:, 0] * np.cos(th) - pts[:, 1] * np.sin(th)
    inside = (major / e.semi_major) ** 2 + (minor / e.semi_minor) ** 2 <= 1
    assert inside.mean() == pytest.approx(0.95, abs=0.003)


def stationary_set():
    t = np.arange(0.0, 400.0, 2.0)
    own = np.stack([5 * t, 200 * np.sin(t / 40), 0 * t, 5 + 0 * t, 5 * np.cos(t / 40), 0 * t],
                   axis=1)
    emitter = np.array([3000.0, 6000.0])
    b = np.arctan2(emitter[0] - own[:, 0], emitter[1] - own[:, 1])
    rng = np.random.default_rng(5)
    sigma = np.radians(0.5)
    return tk.MeasurementSet.from_si(t, ["ship"] * t.size, ["bearing"] * t.size,
                                     b + sigma * rng.standard_normal(t.size),
                                     np.full(t.size, sigma), own), emitter


def test_stationary_emitter_is_a_position_without_course_or_speed(tmp_path):
    meas, emitter = stationary_set()
    res = tk.estimate(meas, "static2d")
    a = res.answer(meas)
    assert a.stationary and a.course_deg is None and a.speed is None
    assert np.hypot(a.enu[0] - emitter[0], a.enu[1] - emitter[1]) < 4 * max(a.enu_std[:2])
    path = tmp_path / "fixed.csv"
    tk.write_measurements(meas, path)
    out = run("estimate", str(path), "--motion", "static2d")
    assert out.exit_code == 0, out.output
    assert "emitter position (stationary)" in out.output
    assert "course" not in out.output and "speed" not in out.output
    assert "t = 0" not in out.output


def write_geo_file(tmp_path, meas, name="geo.csv"):
    path = tmp_path / name
    tk.write_measurements(meas, path)
    lines = path.read_text().splitlines()
    meta = ["# origin_lat: 50.1", "# origin_lon: -4.2", "# origin_alt: 0",
            "# time_origin: 2024-05-01T12:00:00Z"]
    path.write_text("\n".join([lines[0], *meta, *lines[1:]]) + "\n")
    return path


def test_lat_lon_clock_time_and_json_keys(tmp_path, bo):
    _, meas, _ = bo
    path = write_geo_file(tmp_path, meas)
    out = run("estimate", str(path), "--motion", "cv2d", "--json", "--at",
              "2024-05-01T12:05:00Z", "--units", "nautical")
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    for key in ("parameters", "estimate", "std", "status", "chi2", "geodetic"):
        assert key in data  # the existing keys stay
    ans = data["answer"]
    assert ans["time_s"] == 300.0 and ans["clock"] == "2024-05-01T12:05:00.000Z"
    lat, lon, _ = tk.enu_to_geodetic(ans["position"]["east_m"]["value"],
                                     ans["position"]["north_m"]["value"], 0.0,
                                     (50.1, -4.2, 0.0))
    assert ans["position"]["lat_deg"] == pytest.approx(float(lat))
    assert ans["position"]["lon_deg"] == pytest.approx(float(lon))
    assert ans["speed_kn"]["value"] == pytest.approx(ans["speed_mps"]["value"] / KNOT)
    assert ans["ellipse"]["level"] == 0.95
    cov = np.array(data["covariance"], dtype=float)
    assert cov.shape == (4, 4) and np.allclose(np.sqrt(np.diag(cov)), data["std"])
    assert len(ans["state_covariance"]) == 6
    assert data["warnings"] == [] and data["chi2_p_value"] > 0.001
    text = run("estimate", str(path), "--motion", "cv2d", "--units", "nautical")
    assert "2024-05-01T12:10:00.000Z" in text.output  # the last measurement, in UTC
    for header in ("latitude", "longitude", "course (true)", "| kn", "nmi", "deg"):
        assert header.replace("| ", "") in text.output


def test_from_to_solve_one_leg(tmp_path, bo):
    _, meas, _ = bo
    path = write_geo_file(tmp_path, meas)
    out = run("estimate", str(path), "--motion", "cv2d", "--json", "--from",
              "2024-05-01T12:02:00Z", "--to", "400")
    data = json.loads(out.stdout)
    assert data["dof"] == (400 - 120 + 1) - 4
    assert data["answer"]["time_s"] == 400.0
    bad = run("estimate", str(path), "--motion", "cv2d", "--from", "9000")
    assert bad.exit_code == 2 and "no measurement" in bad.output


def test_unobservable_quantities_are_never_numbers(tmp_path, bo):
    _, meas, _ = bo
    rad = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind,
                                    np.radians(meas.value_si), meas.sigma_si,
                                    meas.sensor_state, metadata=meas.metadata)
    path = write_geo_file(tmp_path, rad, "rad.csv")
    out = run("estimate", str(path), "--motion", "cv2d", "--json")
    data = json.loads(out.stdout)
    assert data["status"] == "unobservable"
    pos = data["answer"]["position"]
    assert pos["east_m"]["value"] is None and pos["lat_deg"] is None
    assert data["answer"]["ellipse"] is None and data["geodetic"] is None
    text = run("estimate", str(path), "--motion", "cv2d")
    assert text.exit_code == 4
    assert "e+09" not in text.stdout and "e+10" not in text.stdout
    assert "unobservable" in text.stdout


def test_track_answers_and_json(tmp_path, bo):
    _, meas, _ = bo
    path = tmp_path / "bo.csv"
    tk.write_measurements(meas, path)
    tr = tk.track(meas, "ekf")
    a = track_answer(tr, meas)
    assert a.time == tr.times[-1] and a.enu[0] == pytest.approx(tr.states[-1, 0])
    v = tr.states[-1, 2:]
    assert a.speed == pytest.approx(np.hypot(*v))
    out = run("track", str(path), "--json")
    assert json.loads(out.stdout)["answer"]["course_deg"]["value"] == pytest.approx(
        a.course_deg)
    text = run("track", str(path), "--units", "nautical")
    assert "emitter at t = 600 s" in text.output and "kn" in text.output


def test_a_track_answers_for_itself_like_an_estimate(bo):
    """Issue 12 item 3: answers from the Python result objects, the track's as the estimate's."""
    _, meas, res = bo
    tr = tk.track(meas, "ekf")
    a = tr.answer(meas)
    assert a.as_dict() == track_answer(tr, meas).as_dict()
    mid = tr.answer(meas, index=len(tr) // 2, sensor="observer", level=0.9)
    assert mid.time == tr.times[len(tr) // 2] and mid.ellipse.level == 0.9
    # The track's last answer agrees with the batch estimate's at the same time within 3 sigma.
    b = res.answer(meas, time=a.time)
    assert abs(a.course_deg - b.course_deg) < 3 * np.hypot(a.course_std_deg, b.course_std_deg)
    assert abs(a.range_m - b.range_m) < 3 * np.hypot(a.range_std, b.range_std)
    assert 0 <= a.bearing_deg < 360 and a.speed_knots == pytest.approx(a.speed / KNOT)


def test_estimate_answer_without_a_bound_uses_the_method_covariance():
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(rng=1)
    from tmakit.batch.methods import estimate_with

    res = estimate_with("ratio", meas, scn.motion,
                        init={"x": 4900, "y": 1200, "vx": 0, "vy": 0})
    assert res.bound is None
    a = estimate_answer(res, meas, time=0.0)
    assert a.enu_std[0] == pytest.approx(res.std[0])
    assert a.enu_std[1] == pytest.approx(res.std[1])


def test_clock_time_in_tables_when_the_file_records_its_time_origin(tmp_path, bo):
    _, meas, _ = bo
    path = write_geo_file(tmp_path, meas)
    shown = run("show", str(path)).output
    assert "UTC" in shown and "2024-05-01T12:00:01 .. 12:10:00" in shown
    tracked = run("track", str(path), "--rows", "3").output
    assert "2024-05-01T12:10:00" in tracked.split("std: position")[0]  # in the table
    plain = tmp_path / "plain.csv"
    tk.write_measurements(meas, plain)
    assert "UTC" not in run("show", str(plain)).output  # seconds only without an origin


@pytest.mark.parametrize(("option", "value", "words"), [
    ("--sensor", "nobody", "no such sensor"),
    ("--units", "imperial", "expected si or nautical"),
    ("--at", "yesterday", "ISO-8601"),
    ("--at", "2024-05-01T12:00:00Z", "time origin"),  # a clock time without one in the file
])
def test_bad_answer_options_are_refused_naming_the_option(tmp_path, bo, option, value, words):
    _, meas, _ = bo
    path = tmp_path / "bo.csv"
    tk.write_measurements(meas, path)
    out = run("estimate", str(path), "--motion", "cv2d", option, value)
    assert out.exit_code == 2 and option in out.output and words in out.output
    assert "Traceback" not in out.output


def test_altitude_is_labelled_by_the_files_altitude_reference(tmp_path):
    """A Debrief file's altitudes are above mean sea level: no output calls them WGS-84."""
    from sample_logs import replay_sample

    from tmakit.results.answers import answer_from_state

    rep = tmp_path / "s.rep"
    rep.write_text(replay_sample(3)[0])
    ms = tk.read_measurements(rep)
    assert ms.metadata["altitude_reference"] == "msl"
    state, cov = np.array([100.0, 200.0, 5.0, 1.0, 2.0, 0.0]), np.eye(6)
    a = answer_from_state(state, cov, 60.0, ms, dim=3)
    assert a.altitude_reference == "mean sea level"
    assert a.as_dict()["position"]["altitude_reference"] == "mean sea level"
    gps = ms.take(np.arange(len(ms)))
    gps.metadata["altitude_reference"] = "ellipsoid"
    assert answer_from_state(state, cov, 60.0, gps, dim=3).altitude_reference == \
        "WGS-84 ellipsoid"
    csv = tmp_path / "s3.csv"
    assert run("import", "rep", str(rep), "--dim", "3", "-o", str(csv)).exit_code == 0
    out = run("estimate", str(csv), "--motion", "cv3d")
    assert "altitude (mean sea level)" in out.output and "WGS-84" not in out.output
    data = json.loads(run("estimate", str(csv), "--motion", "cv3d", "--json").stdout)
    assert data["answer"]["position"]["altitude_reference"] == "mean sea level"


def test_estimate_states_the_origin_it_defaulted_to_and_the_clock(tmp_path):
    """Issue 12: the origin defaults to the first fix, stated in the output."""
    from sample_logs import replay_sample

    rep = tmp_path / "c.rep"
    rep.write_text(replay_sample(0)[0])
    out = run("estimate", str(rep), "--motion", "cv2d", "--units", "nautical")
    text = " ".join(out.output.split())
    assert ("frame: ENU origin lat 47.950000 deg, lon -5.250000 deg, alt 0.0 m (the first fix), "
            "altitudes above mean sea level; t = 0 s is 2026-05-04T09:30:00Z (UTC)") in text
    given = run("estimate", str(rep), "--motion", "cv2d", "--origin", "48,-5.3,0")
    assert "lat 48.000000 deg, lon -5.300000 deg, alt 0.0 m (given)" in " ".join(
        given.output.split())


def test_an_unobservable_height_leaves_the_horizontal_answers(tmp_path):
    """A 3-D bearings-only fit: Up is unobservable, East/North, lat/lon and course are not."""
    from sample_logs import replay_sample

    rep = tmp_path / "c.rep"
    rep.write_text(replay_sample(0)[0])
    flat = tk.read_measurements(rep, bearing_sigma_deg=0.5)
    tall = tk.read_measurements(rep, bearing_sigma_deg=0.5, dim=3)
    assert tall.dim == 3
    a2 = tk.estimate(flat, tk.motion_from_name("cv2d")).answer(flat)
    res3 = tk.estimate(tall, tk.motion_from_name("cv3d"))
    assert res3.status == "unobservable"
    a3 = res3.answer(tall)
    assert a3.enu[2] is None and a3.geodetic[2] is None and a3.range_m is None
    assert a3.enu[0] == pytest.approx(a2.enu[0], abs=1.0)
    assert a3.geodetic[0] == pytest.approx(a2.geodetic[0], abs=1e-5)  # not moved by Up
    assert a3.geodetic[1] == pytest.approx(a2.geodetic[1], abs=1e-5)
    assert a3.course_deg == pytest.approx(a2.course_deg, abs=0.05)
    assert a3.bearing_deg == pytest.approx(a2.bearing_deg, abs=0.01)


def test_track_table_speed_follows_units(bo, tmp_path):
    """``tma track --units nautical``: the table's speed column is in knots, like the answers."""
    _, meas, _ = bo
    path = tmp_path / "bo.csv"
    tk.write_measurements(meas, path)
    tr = tk.track(meas, "ekf")
    last_speed = float(np.hypot(*tr.states[-1, 2:]))

    def table_speed(text: str, header: str) -> float:
        lines = text.splitlines()
        assert any(header in ln for ln in lines), text
        last_row = [ln for ln in lines if ln.startswith("│")
                    and ln.split("│")[1].strip() == f"{tr.times[-1]:g}"][-1]
        cells = [c.strip() for c in last_row.split("│") if c.strip()]
        return float(cells[4])  # t, x, y, std, speed

    si = run("track", str(path), "--rows", "3")
    kn = run("track", str(path), "--rows", "3", "--units", "nautical")
    assert si.exit_code == 0 and kn.exit_code == 0, kn.output
    assert "(m/s)" in si.output and "(kn)" not in si.output.split("emitter at")[0]
    assert "(kn)" in kn.output.split("emitter at")[0]
    assert table_speed(si.output, "(m/s)") == pytest.approx(last_speed, abs=0.006)
    assert table_speed(kn.output, "(kn)") == pytest.approx(last_speed / KNOT, abs=0.006)


def test_estimate_parameter_table_follows_units(bo):
    """``tma estimate --units nautical``: the parameters' velocities are in knots too."""
    _, _, res = bo
    si, kn = res.summary(), res.summary("nautical")

    def row(text, name):
        return next(ln.split() for ln in text.splitlines() if ln.split()[:1] == [name])

    for name in ("vx", "vy"):
        assert row(si, name)[-1] == "m/s" and row(kn, name)[-1] == "kn"
        assert float(row(kn, name)[1]) == pytest.approx(float(row(si, name)[1]) / KNOT,
                                                        rel=1e-6)
        assert float(row(kn, name)[2]) == pytest.approx(float(row(si, name)[2]) / KNOT,
                                                        rel=1e-3)
    assert row(kn, "x") == row(si, "x")  # positions stay in metres (local East/North)


def test_a_course_the_data_do_not_determine_is_left_out_and_said():
    """A converged fit whose course has a 1-sigma of over 60 deg prints no course (issue 26)."""
    from tmakit.results.answers import answer_from_state

    state = np.array([1000.0, 2000.0, 0.0, 3.0, 4.0, 0.0])
    tight = np.diag([1e2, 1e2, 1.0, 0.01, 0.01, 1.0])
    a = answer_from_state(state, tight, 0.0, dim=2)
    assert a.course_deg == pytest.approx(36.87, abs=0.01) and a.undetermined == ()
    loose = np.diag([1e2, 1e2, 1.0, 400.0, 400.0, 1.0])  # 20 m/s 1-sigma on a 5 m/s speed
    a = answer_from_state(state, loose, 0.0, dim=2)
    assert a.course_deg is None and a.course_std_deg is None
    assert a.speed is None
    assert [w.split(" ")[0] for w in a.undetermined] == ["course", "speed"]
    assert a.enu[0] == 1000.0  # the position stays, with its (wide) ellipse


def test_bearing_interval_holds_the_fit_and_the_bearing_measured_then(bo):
    """At a measurement time the interval is the hull of the fit's and the measured bearing's."""
    from tmakit.results.answers import bearing_interval

    _, meas, res = bo
    a = res.answer(meas)
    k = int(np.argmax(meas.time))
    centre, half = bearing_interval(a, meas)
    z = 1.959963984540054  # the normal 97.5 % quantile
    for b, h in ((a.bearing_deg, z * a.bearing_std_deg),
                 (np.degrees(meas.value_si[k]), z * np.degrees(meas.sigma_si[k]))):
        off = (b - centre + 180.0) % 360.0 - 180.0
        assert abs(off) + h <= half + 1e-6
    assert half < z * np.degrees(meas.sigma_si[k]) + 2 * z * a.bearing_std_deg
    between = res.answer(meas, time=float(meas.time[k]) - 0.5)  # no bearing measured then
    assert bearing_interval(between, meas) == pytest.approx(
        (between.bearing_deg, z * between.bearing_std_deg))
