"""Separated solutions: reported, ranked, warned about, drawn; the region covers the truth.

Issue 26, item 4: where separated solutions fit the data about equally well, all of them are
reported with their chi2 and answers, and one solution's std is not printed as if it were the
whole uncertainty.  ``benchmarks/solutions_coverage.py`` measures the coverage of the reported
region over 200 seeded runs; :func:`test_coverage_of_the_reported_region_does_not_collapse` is
its fast, seeded subset.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.results import separated_solutions

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import solutions_coverage

TA_DUMMY = Path(__file__).parent / "data" / "debrief" / "ta_dummy" / "Freq_BlueSensor.rep"
runner = CliRunner()


@pytest.fixture(scope="module")
def ta_dummy():
    """Debrief's TA_DUMMY bearings and the curvilinear:2 estimate of issue 26."""
    meas = tk.read_measurements(TA_DUMMY, kinds=["bearing"])
    return meas, tk.estimate(meas, "curvilinear:2")


def test_ta_dummy_reports_every_solution_and_warns(ta_dummy):
    """The issue's case: one fit with a 3.4 deg std was printed; now the others too, warned."""
    meas, res = ta_dummy
    assert len(res.solutions) >= 2
    assert res.solutions[0].result is res and res.solutions[0].rank == 1
    courses = [s.answer(meas).course_deg for s in res.solutions]
    spread = max(courses) - min(courses)
    # the solutions disagree by far more than the reported fit's own std
    assert spread > 5 * res.answer(meas).course_std_deg
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


def test_the_test_keeps_equal_fits_once_and_drops_improbable_ones(ta_dummy):
    """The same fit twice is one solution; a fit far worse than the best is no solution."""
    meas, res = ta_dummy
    assert len(separated_solutions(res, [res, res], meas)) == 1
    worse = replace(res, chi2=res.chi2 + 200.0, solutions=[])
    assert len(separated_solutions(res, [worse], meas)) == 1
    other = res.solutions[1].result
    kept = separated_solutions(res, [other], meas)
    assert len(kept) == 2 and kept[1].result is other


@pytest.mark.parametrize(("name", "runs", "least"), [("hoerst2010", 8, 7), ("ta-dummy", 6, 2)])
def test_coverage_of_the_reported_region_does_not_collapse(name, runs, least):
    """Seeded runs of the benchmark: the truth inside the reported 95 % region at the end.

    Measured over 200 runs (docs/estimation.md): ``hoerst2010`` bearings only near 100 %,
    the TA_DUMMY geometry far lower (its last position is barely observable); these counts
    fail when either collapses.
    """
    out = solutions_coverage.coverage(name, runs, seed=0)
    assert sum(r.inside for r in out) >= least
