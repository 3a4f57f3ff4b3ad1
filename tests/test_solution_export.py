"""Solutions out (issue 29 item 6): Debrief ;TMA_POS:/;TMA_RB: lines, GeoJSON and KML.

The .rep export read back by tmakit's own Debrief reader gives the positions, courses, speeds
and ellipses that were written; the GeoJSON is a valid RFC 7946 FeatureCollection; the KML is
XML whose names are text; nothing is overwritten without --force.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.cli.common import SOLUTION_SUFFIXES as CLI_SUFFIXES
from tmakit.io.debrief import replay_solutions
from tmakit.io.solution_files import SOLUTION_SUFFIXES, YARD, solution_answers, write_solution
from tmakit.results.answers import KNOT

XSS = "<img src=x onerror=alert(1)>"
runner = CliRunner()


@pytest.fixture(scope="module")
def contact(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ex")
    assert runner.invoke(app, ["examples", str(folder)]).exit_code == 0
    meas = tk.read_measurements(folder / "contact.rep")
    return folder, meas, tk.estimate(meas, "cv2d")


def _origin(meas):
    from tmakit.results.context import origin_of

    return origin_of(meas)


def test_suffixes_are_one_list():
    assert CLI_SUFFIXES == SOLUTION_SUFFIXES


def test_rep_round_trip_through_our_debrief_reader(contact, tmp_path):
    folder, meas, result = contact
    out = tmp_path / "solution.rep"
    r = runner.invoke(app, ["estimate", str(folder / "contact.rep"), "--motion", "cv2d",
                            "--export", str(out), "--export-rb", "--export-every", "300"])
    assert r.exit_code == 0, r.output
    assert f"wrote {out}" in " ".join(r.output.split())
    lines = replay_solutions(out)
    pos = [s for s in lines if s.lat is not None]
    rb = [s for s in lines if s.bearing is not None]
    answers = solution_answers(meas, result, every=300.0)
    assert len(pos) == len(rb) == len(answers) == 13  # 0 .. 3600 s every 300 s, and the end
    for s, q, a in zip(pos, rb, answers, strict=True):
        lat, lon, _ = a.geodetic
        assert s.lat == pytest.approx(lat, abs=2e-7) and s.lon == pytest.approx(lon, abs=2e-7)
        assert s.time_ns == q.time_ns
        assert np.datetime64(s.time_ns, "ns") == np.datetime64(a.clock.rstrip("Z"), "ns")
        assert s.course == pytest.approx(a.course_deg, abs=0.05)
        assert s.speed_kn == pytest.approx(a.speed / KNOT, abs=0.005)
        assert s.maxima_yd * YARD == pytest.approx(a.ellipse.semi_major, abs=0.1)
        assert s.minima_yd * YARD == pytest.approx(a.ellipse.semi_minor, abs=0.1)
        assert s.orientation == pytest.approx(a.ellipse.orientation_deg % 360, abs=0.05)
        assert s.vessel == q.vessel == "OWNSHIP" and s.solution == "TMAKIT"
        assert q.range_yd * YARD == pytest.approx(a.range_m, abs=0.1)
        assert q.bearing == pytest.approx(a.bearing_deg % 360, abs=0.005)
    # the positions are the solution's: the fitted track at those times
    est = result.motion.states(result.estimate, np.array([a.time for a in answers]))
    back = tk.geodetic_to_enu(np.array([s.lat for s in pos]), np.array([s.lon for s in pos]),
                              np.zeros(len(pos)), _origin(meas))
    assert np.max(np.hypot(back[0] - est[:, 0], back[1] - est[:, 1])) < 0.05  # m


def test_debrief_documented_lines_read():
    """Debrief's own importer test lines (ImportTMA_Pos, ImportTMA_RngBrg) read as it reads them."""
    from tmakit.io.debrief import parse_replay_text

    text = (";TMA_POS: 030211 120312 CARPET S@ 22 11 10.63 N 21 41 52.37 W TRACK_060 045.0  "
            "4000 2000 050 12.4 100 Trial label\n"
            ";TMA_RB: 030211 120312 CARPET S@ 124.5 12000 TRACK_060 NULL 050 12.4 100 Trial "
            "label\n")
    p = parse_replay_text(text)
    assert not p.problems
    a, b = p.solutions
    assert (a.vessel, a.solution, a.orientation, a.maxima_yd, a.minima_yd) == (
        "CARPET", "TRACK_060", 45.0, 4000.0, 2000.0)
    assert a.lat == pytest.approx(22 + 11 / 60 + 10.63 / 3600)
    assert a.lon == pytest.approx(-(21 + 41 / 60 + 52.37 / 3600))
    assert (a.course, a.speed_kn, a.depth, a.label) == (50.0, 12.4, 100.0, "Trial label")
    assert (b.bearing, b.range_yd, b.orientation) == (124.5, 12000.0, None)


def _ring_area(ring):
    x, y = np.array(ring).T
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def _check_geojson(doc):
    """RFC 7946, structurally: types, positions, closed counter-clockwise rings."""
    assert doc["type"] == "FeatureCollection" and isinstance(doc["features"], list)
    kinds = set()
    for f in doc["features"]:
        assert f["type"] == "Feature" and isinstance(f["properties"], dict)
        g = f["geometry"]
        kinds.add(g["type"])
        c = g["coordinates"]
        positions = ([c] if g["type"] == "Point" else c if g["type"] == "LineString"
                     else [p for ring in c for p in ring])
        for lon, lat in positions:
            assert -180 <= lon <= 180 and -90 <= lat <= 90
        if g["type"] == "LineString":
            assert len(g["coordinates"]) >= 2
        if g["type"] == "Polygon":
            for ring in g["coordinates"]:
                assert len(ring) >= 4 and ring[0] == ring[-1]
                assert _ring_area(ring) > 0  # exterior ring counter-clockwise
    return kinds


def test_geojson_is_a_valid_feature_collection(contact, tmp_path):
    _, meas, result = contact
    out = write_solution(tmp_path / "s.geojson", meas, result, every=600.0)
    text = out.read_text()
    doc = json.loads(text)
    json.dumps(doc, allow_nan=False)  # no NaN or Infinity: not JSON
    assert _check_geojson(doc) == {"LineString", "Point", "Polygon"}
    points = [f for f in doc["features"] if f["geometry"]["type"] == "Point"]
    answers = solution_answers(meas, result, every=600.0)
    for f, a in zip(points, answers, strict=True):
        lon, lat = f["geometry"]["coordinates"]
        assert (lat, lon) == pytest.approx(a.geodetic[:2], abs=1e-12)
        assert f["properties"]["speed_kn"] == pytest.approx(a.speed / KNOT)
    # the ellipse polygon's extent is the ellipse's: its farthest point from the centre
    poly = next(f for f in doc["features"] if f["geometry"]["type"] == "Polygon")
    a = answers[0]
    ring = np.array(poly["geometry"]["coordinates"][0])
    e, n, _ = tk.geodetic_to_enu(ring[:, 1], ring[:, 0], np.zeros(len(ring)), _origin(meas))
    d = np.hypot(e - a.enu[0], n - a.enu[1])
    assert d.max() == pytest.approx(a.ellipse.semi_major, rel=1e-3)
    assert d.min() == pytest.approx(a.ellipse.semi_minor, rel=1e-2)


def test_kml_names_are_text(contact, tmp_path):
    _, meas, result = contact
    out = write_solution(tmp_path / "s.kml", meas, result, every=900.0, name=XSS)
    root = ET.parse(out).getroot()
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    names = [e.text for e in root.iter("{http://www.opengis.net/kml/2.2}name")]
    assert XSS in names and f"{XSS}: track" in names
    assert not list(root.iter("img"))
    coords = root.find(".//k:LineString/k:coordinates", ns).text.split()
    assert len(coords) == len(solution_answers(meas, result, every=900.0))


def test_never_overwritten_without_force(contact, tmp_path):
    folder, meas, result = contact
    for suffix in SOLUTION_SUFFIXES:
        out = tmp_path / f"s{suffix}"
        out.write_text("keep me")
        args = ["estimate", str(folder / "contact.rep"), "--motion", "cv2d", "--export", str(out)]
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and "use --force" in r.output
        assert out.read_text() == "keep me"
        r = runner.invoke(app, [*args, "--force"])
        assert r.exit_code == 0, r.output
        assert out.read_text() != "keep me"
    with pytest.raises(FileExistsError):
        write_solution(tmp_path / "s.rep", meas, result)


def test_refusals_name_the_option(contact, tmp_path):
    folder = contact[0]
    base = ["estimate", str(folder / "contact.rep"), "--motion", "cv2d"]
    r = runner.invoke(app, [*base, "--export", str(tmp_path / "s.txt")])
    assert r.exit_code == 2 and "--export" in r.output and ".rep, .geojson or .kml" in r.output
    r = runner.invoke(app, [*base, "--export-rb", "--export", str(tmp_path / "s.kml")])
    assert r.exit_code == 2 and "--export-rb" in r.output
    r = runner.invoke(app, [*base, "--export", str(tmp_path / "s.rep"), "--export-every", "0"])
    assert r.exit_code == 2 and "--export-every" in r.output
    assert not (tmp_path / "s.rep").exists()
    # 1e-9 s: np.arange of 3.6e12 points ran out of memory after the fit
    r = runner.invoke(app, [*base, "--export", str(tmp_path / "s.rep"), "--export-every",
                            "1e-9"])
    assert r.exit_code == 2, r.output
    assert ("solution points at one every 1e-09 s: more than 10000; write fewer (a longer "
            "step, --export-every)") in " ".join(r.output.split())
    assert not (tmp_path / "s.rep").exists()
    r = runner.invoke(app, [*base, "--html", str(tmp_path / "p.png")])
    assert r.exit_code == 2 and "--html" in r.output


def test_no_origin_or_no_answer_is_said(tmp_path):
    from bearing_sets import bearings

    meas = bearings(tk.ConstantVelocity(2), np.array([5000.0, 8000.0, -3.0, 2.0]), 200, 1)
    result = tk.estimate(meas, tk.ConstantVelocity(2))
    with pytest.raises(ValueError, match="no ENU origin"):
        write_solution(tmp_path / "s.geojson", meas, result)
    assert not (tmp_path / "s.geojson").exists()
    stopped = tk.estimate(meas.take(np.arange(3)), tk.ConstantVelocity(2))
    assert stopped.status != "converged"
    with pytest.raises(ValueError, match="not written"):
        write_solution(tmp_path / "s.kml", meas, stopped)
    assert math.isfinite(result.chi2)


def test_an_export_the_data_cannot_place_is_refused_before_the_fit_and_any_output(tmp_path):
    path = tmp_path / "obs.csv"  # a simulated file: ENU positions, no latitude/longitude
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=1), path)
    plot, rep = tmp_path / "fit.png", tmp_path / "s.rep"
    r = runner.invoke(app, ["estimate", str(path), "--motion", "cv2d", "--plot", str(plot),
                            "--export", str(rep)])
    assert r.exit_code == 2
    assert (f"error: --export {rep}: the measurements have no ENU origin"
            in " ".join(r.output.split()))
    assert "ml estimate" not in r.output  # said before the fit, and nothing written
    assert not plot.exists() and not rep.exists()


def test_estimate_html_writes_the_page(contact, tmp_path):
    folder = contact[0]
    out = tmp_path / "page.html"
    r = runner.invoke(app, ["report", str(folder / "contact.rep"), "--motion", "cv2d",
                            "-o", str(out)])
    assert r.exit_code == 0, r.output
    text = Path(out).read_text()
    assert "tmaSolutionPage" in text and "<script src" not in text
    r = runner.invoke(app, ["estimate", str(folder / "contact.rep"), "--motion", "cv2d",
                            "--html", str(out)])
    assert r.exit_code == 2 and "use --force" in r.output
