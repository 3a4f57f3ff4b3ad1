"""Sanity checks that speak (issue 12, item 5), and the solution picture (item 6)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.results import measurement_warnings, normalised_residuals, scale_sigma
from tmakit.results.checks import CHI2_P_LIMIT, FAR_FROM_ORIGIN, chi2_probability, chi2_warning

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
from sanity_checks import chi2_study, radians_study

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, list(args))


def test_radian_bearings_are_warned_about_in_every_seeded_file_and_degrees_are_not():
    warned, false_alarms = radians_study(files=6, seed=7)
    assert warned == 6 and false_alarms == 0


def test_improbable_chi2_is_flagged_exactly_when_p_is_below_the_limit():
    c = chi2_study(files=8, seed=3)
    assert c["improbable"] > 0 and c["plausible"] > 0  # both sides seen
    assert c["flagged_improbable"] == c["improbable"]
    assert c["flagged_plausible"] == 0
    assert c["rescaled_chi2_dof_max"] == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize(("chi2", "dof"), [(700.0, 600), (680.0, 600), (30.0, 10),
                                           (1103.0 * 40, 40)])
def test_chi2_rule_is_the_stated_probability(chi2, dof):
    w = chi2_warning(chi2, dof)
    assert (w is not None) == (chi2_probability(chi2, dof) < CHI2_P_LIMIT)
    if w is not None:
        for cause in ("manoeuvre", "sigma", "outliers", "--scale-sigma"):
            assert cause in w.message


def test_scale_sigma_rescales_noise_and_covariance():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=11)
    small = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                      meas.sigma_si / 1.5, meas.sensor_state)
    res = tk.estimate(small, scn.motion)
    assert [w.code for w in res.warnings(small)] == ["improbable-chi2"]
    scaled, factors = scale_sigma(small, normalised_residuals(res, small), res.dof)
    again = tk.estimate(scaled, scn.motion)
    assert again.chi2 / again.dof == pytest.approx(1.0, abs=1e-3)
    assert factors["bearing"] == pytest.approx(np.sqrt(res.chi2 / res.dof))
    # One kind: the same estimate (to the solver's tolerance, a hundredth of a std), and
    # the covariance scaled by the factor squared.
    assert np.all(np.abs(again.estimate - res.estimate) < 0.01 * res.std)
    assert np.allclose(again.covariance, res.covariance * factors["bearing"] ** 2, rtol=1e-2)
    assert again.warnings(scaled) == []


def test_scale_sigma_on_the_command_line(tmp_path):
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=11)
    small = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                      meas.sigma_si / 1.5, meas.sensor_state)
    path = tmp_path / "small.csv"
    tk.write_measurements(small, path)
    plain = run("estimate", str(path), "--motion", "cv2d")
    assert plain.exit_code == 0 and "improbable" in plain.output
    out = run("estimate", str(path), "--motion", "cv2d", "--scale-sigma", "--json")
    data = json.loads(out.stdout)
    assert data["sigma_scale"]["bearing"] == pytest.approx(1.5, rel=0.1)
    assert data["chi2"] / data["dof"] == pytest.approx(1.0, abs=1e-3)
    assert data["warnings"] == []


def test_far_sensors_and_far_estimates_are_warned_about():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=1)
    far = meas.sensor_state.copy()
    far[:, 0] += 2 * FAR_FROM_ORIGIN
    moved = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                      meas.sigma_si, far)
    assert [w.code for w in measurement_warnings(moved)] == ["far-sensor"]
    assert measurement_warnings(meas) == []
    rad = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind,
                                    np.radians(meas.value_si), meas.sigma_si,
                                    meas.sensor_state)
    codes = [w.code for w in tk.estimate(rad, scn.motion).warnings(rad)]
    assert "radians" in codes and "far-estimate" in codes


def radian_bearings_file(tmp_path, seed):
    """bearings-only-2d's bearings written in radians where the file wants degrees."""
    meas = tk.load_scenario("bearings-only-2d").simulate(rng=seed)
    rad = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind,
                                    np.radians(meas.value_si), meas.sigma_si,
                                    meas.sensor_state)
    path = tmp_path / "radians.csv"
    tk.write_measurements(rad, path)
    return path


def test_a_track_that_cannot_start_from_bearings_in_radians_says_they_look_like_radians(
        tmp_path):
    path = radian_bearings_file(tmp_path, seed=1)
    out = run("track", str(path))
    assert out.exit_code == 2, out.output
    said = " ".join(out.output.split())
    assert "error: cannot start the filter" in said
    assert "were they written in radians? Multiply by 180/π" in said


def test_solution_picture_is_written_and_existing_files_are_refused_before_work(tmp_path):
    path = tmp_path / "bo.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=3), path)
    png = tmp_path / "solution.png"
    out = run("estimate", str(path), "--motion", "cv2d", "--plot", str(png))
    assert out.exit_code == 0, out.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50_000
    stamp = png.stat().st_mtime_ns
    again = run("estimate", str(path), "--motion", "cv2d", "--plot", str(png))
    assert again.exit_code == 2 and "--force" in again.output
    assert "estimate" not in again.stdout  # refused before any work
    assert png.stat().st_mtime_ns == stamp
    assert run("estimate", str(path), "--motion", "cv2d", "--plot", str(png),
               "--force").exit_code == 0
    bad = run("estimate", str(path), "--motion", "cv2d", "--plot", str(tmp_path / "x.txt"))
    assert bad.exit_code == 2 and ".png" in bad.output
    missing = run("estimate", str(path), "--motion", "cv2d", "--plot",
                  str(tmp_path / "no" / "x.png"))
    assert missing.exit_code == 2 and "does not exist" in missing.output


def test_solution_picture_in_lat_lon_with_residual_panels_per_kind(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    from tmakit.plot.solution import plot_solution

    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(rng=1)
    meas.metadata.update(origin_lat="48.0", origin_lon="11.0", origin_alt="500")
    res = tk.estimate(meas, scn.motion)
    shown = []
    real_savefig = plt.Figure.savefig

    def spy(fig, *args, **kwargs):
        shown.append([(ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) for ax in fig.axes])
        return real_savefig(fig, *args, **kwargs)

    plt.Figure.savefig = spy
    try:
        plot_solution(meas, res, tmp_path / "gu.png", residuals=normalised_residuals(res, meas),
                      answer=res.answer(meas))
    finally:
        plt.Figure.savefig = real_savefig
    labels = shown[0]
    assert labels[0][:2] == ("longitude (deg)", "latitude (deg)")
    titles = [t for _, _, t in labels[1:]]
    assert any(t.startswith("frequency residuals") for t in titles)
    assert any(t.startswith("power residuals") for t in titles)
    assert all(y == "residual (σ)" for _, y, _ in labels[1:])


def test_show_warns_about_radian_bearings(tmp_path):
    path = radian_bearings_file(tmp_path, seed=2)
    out = run("show", str(path))
    assert out.exit_code == 0 and "warning:" in out.output and "radians" in out.output
