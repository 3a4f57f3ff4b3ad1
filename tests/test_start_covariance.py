"""A batch start's covariance covers its profile likelihood (short bearings-only windows)."""

import numpy as np
from scipy.stats import chi2

import tmakit as tk
from tmakit.scenario.files import load_scenario
from tmakit.tracking.initiators import LIKELIHOOD_TOLERANCE, likelihood_covariance, search_window


def test_truth_inside_start_ellipse_on_hoerst2010() -> None:
    # With the linearised covariance of the shortest good window, 6 of these 20 seeded starts
    # (seeds 2, 9, 12, 16, 18, 19) had the truth outside their 95 % position ellipse, seed 2
    # at a position NEES of 1100 (12.6 km off at 253 m/s; the target does 50 m/s).
    scn = load_scenario("hoerst2010")
    inside = []
    for seed in range(20):
        tr = tk.track(scn.simulate(rng=seed), "ekf")
        x, p = tr.states[0], tr.covariances[0]
        e = x[:2] - scn.target_states([tr.times[0]])[0][:2]
        inside.append(e @ np.linalg.solve(p[:2, :2], e) <= chi2.ppf(0.95, 2))
    assert np.mean(inside) >= 0.85


def test_likelihood_covariance_only_widens_along_the_profile() -> None:
    scn = load_scenario("hoerst2010")
    meas = scn.simulate(rng=2)
    w = search_window(meas, 2).chosen
    rows = meas.take(meas.time <= w.time + 1e-9)
    cov = w.estimate.covariance
    wide = likelihood_covariance(w.estimate, rows, w.time, 2)
    assert np.all(np.linalg.eigvalsh(wide - cov) > -1e-9 * np.abs(cov).max())
    # widened (this short window's far side is flat in range), by a term of rank 2 at most
    major = [np.sqrt(np.linalg.eigvalsh(c[:2, :2])[-1]) for c in (cov, wide)]
    assert major[1] > LIKELIHOOD_TOLERANCE * major[0]
    assert np.linalg.matrix_rank(wide - cov, tol=1e-9 * np.abs(wide).max()) <= 2
