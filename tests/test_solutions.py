"""Separated solutions: reported, ranked, warned about, drawn; the region covers the truth.

Issue 26, item 4: where separated solutions fit the data about equally well, all of them are
reported with their chi2 and answers, and one solution's std is not printed as if it were the
whole uncertainty.  ``benchmarks/solutions_coverage.py`` measures the coverage of the reported
region over 200 seeded runs; :func:`test_coverage_of_the_reported_region_does_not_collapse` is
its fast, seeded subset.
"""

from __future__ import annotations

import functools
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.results.solutions import separated_solutions

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import solutions_coverage

TA_DUMMY = Path(__file__).parent / "data" / "debrief" / "ta_dummy" / "Freq_BlueSensor.rep"
runner = CliRunner()


@pytest.fixture(scope="module")
def ta_dummy():
    """Debrief's TA_DUMMY bearings and the curvilinear:2 estimate of issue 26."""
    meas = tk.read_measurements(TA_DUMMY, kinds=["bearing"])
    return meas, tk.estimate(meas, "curvilinear:2")


@functools.cache
def ta_dummy_run(r: int):
    """TA_DUMMY geometry, seeded run ``r``: the scenario, the measurements and the estimate.

    Cached: two tests fit run 1, and a worker of pytest-xdist that runs both fits it once.
    """
    scn, how = solutions_coverage.ta_dummy()
    meas = scn.simulate(rng=np.random.default_rng([0, r]))
    return scn, meas, tk.estimate(meas, **how)


def test_ta_dummy_reports_every_solution_and_warns(ta_dummy):
    """The issue's case: one fit with a 3.4 deg std was printed; now the others too, warned."""
    meas, res = ta_dummy
    assert len(res.solutions) >= 2
    assert res.solutions[0].result is res and res.solutions[0].rank == 1
    courses = [s.answer(meas).course_deg for s in res.solutions]
    spread = max(courses) - min(courses)
    # the solutions disagree by far more than the reported fit's own std (before it is
    # widened to contain the close fits it stands for)
    assert spread > 5 * replace(res, covers=[]).answer(meas).course_std_deg
    assert [s.rank for s in res.solutions] == list(range(1, len(res.solutions) + 1))
    lr = [s.lr_statistic for s in res.solutions[1:]]
    assert lr == sorted(lr)
    assert all(s.p_value >= 0.05 for s in res.solutions)
    codes = [w.code for w in res.warnings(meas)]
    assert "several-solutions" in codes
    assert "separated solutions" in res.summary()


def test_cli_json_table_and_picture_carry_every_solution(tmp_path):
    """``tma estimate --json``: ``solutions`` ranked with chi2, the test, estimate, answers."""
    got = runner.invoke(app, ["estimate", str(TA_DUMMY), "--kinds", "bearing",
                              "--motion", "curvilinear:2", "--json"])
    assert got.exit_code == 0, got.output
    data = json.loads(got.stdout)
    sols = data["solutions"]
    assert len(sols) >= 2 and [s["rank"] for s in sols] == list(range(1, len(sols) + 1))
    for s in sols:
        assert {"chi2", "lr_statistic", "p_value", "estimate", "covariance", "answer"} <= set(s)
        assert s["answer"]["course_deg"]["value"] is not None
    assert sols[0]["estimate"] == data["estimate"]
    assert "several-solutions" in [w["code"] for w in data["warnings"]]
    picture = tmp_path / "ta.png"
    got = runner.invoke(app, ["estimate", str(TA_DUMMY), "--kinds", "bearing", "--motion",
                              "curvilinear:2", "--plot", str(picture)])
    assert got.exit_code == 0, got.output
    assert "separated solutions at t = 7200 s" in got.stdout
    assert picture.stat().st_size > 10_000


def test_one_solution_reports_itself_alone():
    """A well observed fit: no other solution, no warning, the region is its ellipse.

    (Azimuth and azimuth rate, one of each every 10 s: in some runs the one-manoeuvre fit
    still passes the test, as in run 3; run 4 has one solution.)
    """
    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=4)
    meas = meas.take(meas.time % 10.0 == 0.0)
    res = tk.estimate(meas, "curvilinear:2")
    assert res.solutions == [] and len(res.ranked_solutions()) == 1
    assert "several-solutions" not in [w.code for w in res.warnings(meas)]
    truth = scn.target_states(np.array([meas.time.max()]))[0, :2]
    a = res.answer(meas)
    assert res.region_contains(truth, meas)
    far = np.array([a.enu[0] + 10 * a.ellipse.semi_major, a.enu[1]])
    assert not res.region_contains(far, meas)


def test_a_fit_without_the_search_for_solutions_is_the_same_fit():
    """``MaximumLikelihood(solutions=False)``: the same fit, no separated solutions looked for.

    (gu2007 seed 4, the first 20 s: the fit has 4 separated solutions; the tracker's window
    search fits this way.)
    """
    from tmakit.batch.ml import MaximumLikelihood
    from tmakit.motion import ConstantVelocity

    meas = tk.load_scenario("gu2007").simulate(rng=4)
    rows = meas.take(meas.time <= meas.time.min() + 20.0)
    motion = ConstantVelocity(2, float(rows.time.max()))
    full = MaximumLikelihood().fit(rows, motion)
    bare = MaximumLikelihood(solutions=False).fit(rows, motion)
    assert len(full.solutions) == 4 and bare.solutions == []
    assert bare.status == full.status and bare.chi2 == full.chi2
    np.testing.assert_array_equal(bare.estimate, full.estimate)
    np.testing.assert_array_equal(bare.covariance, full.covariance)


def test_the_test_keeps_equal_fits_once_and_drops_improbable_ones(ta_dummy):
    """The same fit twice is one solution; a fit far worse than the best is no solution."""
    meas, res = ta_dummy
    assert len(separated_solutions(res, [res, res], meas)) == 1
    worse = replace(res, chi2=res.chi2 + 200.0, solutions=[])
    assert len(separated_solutions(res, [worse], meas)) == 1
    other = res.solutions[1].result
    kept = separated_solutions(res, [other], meas)
    assert len(kept) == 2 and kept[1].result is other


def test_coverage_of_the_reported_region_hoerst2010():
    """20 seeded runs of the benchmark: the truth inside the reported 95 % region at the end.

    The issue's figure is >= 93 % over 200 runs (``benchmarks/solutions_coverage.py``,
    docs/estimation.md); over 20 runs at least 18 (90 %: one run of slack below 93 % for the
    binomial spread of 20 draws), every position determined (a circling observer).
    """
    out = solutions_coverage.coverage("hoerst2010", 20, seed=0)
    assert sum(r.inside for r in out) >= 18
    assert not any(r.undetermined for r in out)


def test_ta_dummy_final_position_is_covered_or_said_undetermined():
    """TA_DUMMY geometry, 4 seeded runs: the truth inside the region, and undetermined said.

    The own ship holds its course for the last hour while the contact turns 20 min before the
    end: the final range is not determined, and the answer must say so
    (``position-undetermined``: the widest model leaves it undetermined, or the solutions'
    ranges disagree) instead of small ellipses alone.  Run 1 is one where the solutions' range
    intervals are disjoint (14.3 and 25.0 km, the truth at 33.8 km between no ellipse).
    """
    from tmakit.results.solutions import range_spread

    for r in range(4):
        scn, meas, res = ta_dummy_run(r)
        truth = scn.target_states(np.array([meas.time.max()]))[0, :2]
        assert res.region_contains(truth, meas)
        if not any(s.answer(meas).position_determined and s.region_contains(truth, meas)
                   for s in res.ranked_solutions()):  # covered by a bearing interval alone
            assert "position-undetermined" in [w.code for w in res.warnings(meas)]
            assert res.trust(meas).level == "warning"
        if r == 1:
            assert res.wider is None and range_spread(res.ranked_solutions(), meas) is not None


def test_a_range_left_undetermined_reports_the_bearing_interval():
    """One straight own-ship leg, cv2d: range unobservable, the region is the bearing interval.

    Over 20 seeded runs the truth lies in it in at least 18; a point 6 deg off (sigma 1 deg)
    does not.
    """
    scn = tk.load_scenario("bearings-only-2d")
    inside = 0
    for r in range(20):
        meas = scn.simulate(rng=np.random.default_rng([0, r]))
        meas = meas.take(meas.time <= 100.0)
        res = tk.estimate(meas, "cv2d")
        a = res.answer(meas)
        assert res.status == "unobservable" and not a.position_determined
        truth = scn.target_states(np.array([a.time]))[0, :2]
        inside += res.region_contains(truth, meas)
        where = meas.sensor_state[int(np.argmax(meas.time)), :2]
        off = np.radians(a.bearing_deg + 6.0)
        assert not res.region_contains(where + 1e4 * np.array([np.sin(off), np.cos(off)]), meas)
    assert inside >= 18


def test_covering_scale_contains_the_other_ellipse():
    """The widened ellipse contains the other's boundary; the same ellipse widens nothing."""
    from scipy.stats import chi2

    from tmakit.results.answers import covering_scale

    rng = np.random.default_rng(0)
    q = chi2.ppf(0.95, 2)
    for _ in range(50):
        a, b = rng.normal(size=(2, 2)), rng.normal(size=(2, 2))
        pa, pb = a @ a.T + 0.1 * np.eye(2), b @ b.T + 0.1 * np.eye(2)
        ca, cb = rng.normal(size=2), rng.normal(size=2)
        s = covering_scale(ca, pa, [(cb, pb)])
        u = np.linspace(0, 2 * np.pi, 181)
        edge = cb[:, None] + np.linalg.cholesky(pb) @ np.vstack([np.cos(u), np.sin(u)]) \
            * np.sqrt(q)
        d = edge - ca[:, None]
        m2 = np.einsum("in,ij,jn->n", d, np.linalg.inv(s * pa), d)
        assert np.all(m2 <= q * (1 + 1e-9))
    assert covering_scale(ca, pa, [(ca, pa)]) == pytest.approx(1.0)


def test_the_picture_of_an_undetermined_range_shades_the_bearing_interval():
    """TA_DUMMY run 1 (the solutions' ranges disagree): the map shades the 95 % bearing fan.

    The fan is the reported region, so the truth at the answer time must lie inside the shaded
    polygon, and the words box must say that the position is undetermined.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tmakit.plot.frame import MapFrame
    from tmakit.plot.solution import _draw_map

    scn, meas, res = ta_dummy_run(1)
    fig, ax = plt.subplots()
    _draw_map(ax, res, meas, 3, 0.95)
    fans = [p for p in ax.patches if "range undetermined" in str(p.get_label())]
    assert len(fans) == 1
    truth = scn.target_states(np.array([meas.time.max()]))[0, :2]
    xy = np.array(MapFrame(meas).xy(truth[:1], truth[1:2])).ravel()
    assert fans[0].get_path().contains_point(xy, transform=None)
    assert any("position undetermined" in t.get_text() for t in ax.texts)
    plt.close(fig)
