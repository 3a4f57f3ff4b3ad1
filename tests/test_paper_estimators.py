"""The papers' own estimators: Gu et al. (2007), §3 (direct iterative LS) and §4 (ratio
method), the Doppler-tracking lecture notes (Gauss–Newton on 7 parameters), and the registry."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch.methods import METHODS, estimate_with
from tmakit.batch.papers import (
    GuDirect,
    LectureGaussNewton,
    PlanarGeometry,
    RatioMethod,
    chain,
    doppler_bands,
    power_bands,
    tridiagonal,
)
from tmakit.bounds import crlb
from tmakit.core.units import SPEED_OF_LIGHT
from tmakit.measurements.range_rate import range_rate_and_gradient
from tmakit.scenario import MeasurementPlan

PAPER_START = (4900.0, 1200.0, 0.0, 0.0)           # Gu et al. (2007), §5, both measurements
PAPER_DOPPLER_START = (2200.0, 2700.0, -16.0, -8.0)  # Gu et al. (2007), §5, Doppler only


@pytest.fixture(scope="module")
def gu():
    return tk.load_scenario("gu2007")


@pytest.fixture(scope="module")
def gu_bound(gu):
    return crlb(gu)  # C and f_s unknown (the default)


def bands(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample variance, lag-1 covariance and lag-2 correlation of the columns (draws in rows),
    computed directly (a full np.cov is needlessly slow)."""
    x = samples - samples.mean(axis=0)
    var = np.mean(x * x, axis=0)
    lag1 = np.mean(x[:, :-1] * x[:, 1:], axis=0)
    lag2 = np.mean(x[:, :-2] * x[:, 2:], axis=0) / np.sqrt(var[:-2] * var[2:])
    return var, lag1, lag2


def three_receivers() -> tk.Scenario:
    """doppler-lecture heard by three fixed receivers, each with its own frequency plan."""
    scn = copy.deepcopy(tk.load_scenario("doppler-lecture"))
    base = scn.plans[0]
    for name, pos in {"rx2": (15_000.0, -5_000.0, 10.0),
                      "rx3": (-12_000.0, 9_000.0, 10.0)}.items():
        scn.sensors[name] = tk.FixedSensor(pos)
        scn.plans.append(MeasurementPlan("frequency", name, base.times.copy(), base.sigma))
    return scn


# -- the paper's algebra ---------------------------------------------------------------------------
def test_paper_matrices_reproduce_range_and_radial_velocity(gu):
    meas = gu.simulate(noise=False)
    geo = PlanarGeometry.from_rows(meas, gu.motion)
    rel = gu.motion.states(gu.theta, meas.time) - meas.sensor_state
    rdot, _ = range_rate_and_gradient(rel)
    assert np.sqrt(geo.range2(gu.theta)) == pytest.approx(np.linalg.norm(rel[:, :3], axis=1),
                                                          rel=1e-12)   # eq. 8
    assert geo.radial_velocity(gu.theta) == pytest.approx(rdot, rel=1e-9, abs=1e-9)  # eq. 12
    h = 1e-4
    numeric = np.stack([(geo.radial_velocity(gu.theta + h * e)
                         - geo.radial_velocity(gu.theta - h * e)) / (2 * h)
                        for e in np.eye(4)], axis=1)
    assert geo.grad_radial_velocity(gu.theta) == pytest.approx(numeric, abs=1e-8)  # eq. 16


def test_derived_tridiagonal_covariances_match_monte_carlo(gu):
    """The covariances of the noise terms of eqs. 21 and 27, against 20000 draws of the
    paper's noise (var(eta/P) = 1/SNR_p exactly; zeta with sigma_f).  The paper's power
    off-diagonal has the wrong sign."""
    rng = np.random.default_rng(7)
    meas = gu.simulate(noise=False)
    power = meas.select(kind="power")
    geo = PlanarGeometry.from_rows(power, gu.motion)
    r2 = geo.range2(gu.theta)
    snr = 10.0 ** (40.0 / 10.0)
    eps = rng.standard_normal((20000, r2.size)) / np.sqrt(snr)
    mu_true = r2[:-1] / r2[1:]
    mu_hat = mu_true * (1 + eps[:, 1:]) / (1 + eps[:, :-1])
    g = r2[:-1] - mu_hat * r2[1:]                                   # eq. 21, exact noise term
    var, lag1, lag2 = bands(g)
    s = np.full(r2.size, 1.0 / snr)
    linked = chain(mu_true.size)
    derived, paper = (tridiagonal(*power_bands(mu_true, r2[:-1], r2[1:], s[:-1], s[1:], linked,
                                               how)) for how in ("derived", "paper"))
    assert np.max(np.abs(var / np.diag(derived) - 1)) < 0.10
    assert np.max(np.abs(lag1 / np.diag(derived, 1) - 1)) < 0.10
    assert np.max(np.abs(lag2)) < 0.05                      # tri-diagonal indeed
    assert np.all(lag1 < 0) and np.all(np.diag(paper, 1) > 0)   # the printed sign is wrong
    assert np.median(lag1 / np.sqrt(var[:-1] * var[1:])) == pytest.approx(-0.5, abs=0.03)

    freq = meas.select(kind="frequency")
    f = freq.value_si
    sigma = 1.9
    zeta = rng.standard_normal((20000, f.size)) * sigma
    fh = f + zeta
    gf = PlanarGeometry.from_rows(freq, gu.motion)
    v = gf.radial_velocity(gu.theta)
    nu_hat = fh[:, 1:] / fh[:, :-1]
    ch = v[1:] - nu_hat * v[:-1] - (fh[:, :-1] - fh[:, 1:]) / fh[:, :-1] * SPEED_OF_LIGHT
    var, lag1, lag2 = bands(ch)
    sig = np.full(f.size, sigma)
    nu, linked = f[1:] / f[:-1], chain(f.size - 1)
    derived, paper = (tridiagonal(*doppler_bands(nu, sig[:-1], sig[1:], linked, 1.9e9, v[:-1],
                                                 v[1:], how)) for how in ("derived", "paper"))
    assert np.max(np.abs(var / np.diag(derived) - 1)) < 0.10
    assert np.max(np.abs(lag1 / np.diag(derived, 1) - 1)) < 0.10
    assert np.max(np.abs(lag2)) < 0.05
    # The paper's Doppler matrix differs from the derived one only by factors (1 - v/c)^2.
    assert paper == pytest.approx(derived, rel=1e-5)


# -- the ratio method (Gu et al. (2007), §4) -------------------------------------------------------
def test_ratio_method_from_the_papers_start_is_efficient(gu, gu_bound):
    """30 seeded runs from (4900, 1200, 0, 0): all converge, RMSE within 1.5x the CRLB with C
    and f_s unknown (measured 1.00, 1.14, 1.19, 1.03), reported std within 10 % of it."""
    names = gu.motion.param_names
    bound = np.array([gu_bound.std_of(n) for n in names])
    errors, stds = [], []
    for seed in range(30):
        res = RatioMethod().iterate(gu.simulate(rng=seed), gu.motion, PAPER_START)
        assert res.status == "converged", (seed, res.message)
        assert res.method == "ratio"
        errors.append(res.estimate - gu.theta)
        stds.append(res.std)
    rmse = np.sqrt(np.mean(np.square(errors), axis=0))
    assert np.all(rmse / bound < 1.5), rmse / bound
    assert np.mean(stds, axis=0) == pytest.approx(bound, rel=0.10)
    # The nuisance values, estimated afterwards given theta.
    carrier, carrier_std = res.nuisance["carrier"]
    c_db, c_db_std = res.nuisance["power_constant_db"]
    assert abs(carrier - gu.nuisance["carrier"]) < 5 * carrier_std
    assert abs(c_db - gu.nuisance["power_constant_db"]) < 5 * c_db_std
    assert carrier_std == pytest.approx(gu_bound.std_of("carrier"), rel=0.2)


def test_ratio_method_with_the_printed_covariance_fails(gu):
    """With the paper's printed power off-diagonal (+ sign) the iteration from the paper's
    start does not converge; the paper's own results must have used the correct sign."""
    statuses = [RatioMethod(covariance="paper").iterate(gu.simulate(rng=seed), gu.motion,
                                                       PAPER_START).status for seed in range(5)]
    assert statuses.count("converged") <= 1, statuses


def test_power_only_and_doppler_only_ratio_methods(gu):
    meas = gu.simulate(rng=11)
    dop = RatioMethod(kinds="frequency").iterate(meas, gu.motion, PAPER_DOPPLER_START)
    assert dop.method == "ratio-doppler" and dop.status == "converged"
    assert np.all(np.isfinite(dop.estimate)) and np.all(np.isfinite(dop.std))
    assert np.all(np.abs(dop.estimate - gu.theta) < 4 * dop.std)
    assert set(dop.nuisance) == {"carrier"}

    pw = RatioMethod(kinds="power").iterate(meas, gu.motion, PAPER_START)
    assert pw.method == "ratio-power" and pw.status == "converged"
    assert np.all(np.isfinite(pw.estimate)) and np.all(np.isfinite(pw.std))
    # Measured, as the paper says of power only at SNR_p = 40 dB ("fails to compute meaningful
    # estimates"): the iteration settles about 1.1 km from the truth in x (the CRLB with C
    # unknown is 140 m), near the same point for every noise draw.  Without noise it is exact
    # from near the truth (from the paper's start it stops at a spurious fixed point).
    assert abs(pw.estimate[0] - gu.theta[0]) > 500.0
    near = gu.theta + np.array([200.0, 200.0, 2.0, 2.0])
    exact = RatioMethod(kinds="power").iterate(gu.simulate(noise=False), gu.motion, near)
    assert exact.estimate == pytest.approx(gu.theta, abs=1e-6)


def test_ratio_method_checks_its_input(gu):
    meas = gu.simulate(rng=1)
    with pytest.raises(ValueError, match="covariance"):
        RatioMethod(covariance="other").iterate(meas, gu.motion, PAPER_START)
    with pytest.raises(ValueError, match="2-D constant velocity"):
        RatioMethod().iterate(meas, tk.ConstantVelocity(3), (0, 0, 0, 0, 0, 0))
    with pytest.raises(ValueError, match="starting point"):
        RatioMethod().iterate(meas, gu.motion, None)


# -- the direct method (Gu et al. (2007), §3) ------------------------------------------------------
def test_gu_direct_shows_the_conditioning_problem(gu, gu_bound):
    res = GuDirect().iterate(gu.simulate(rng=3), gu.motion, PAPER_START)
    conds = res.extra["condition_numbers"]
    doppler = res.extra["condition_numbers_doppler"]
    assert len(conds) == res.iterations
    # Measured: ~5e11 for the whole weighted A, ~2.5e12 for the Doppler part, ~17 once the
    # columns are scaled to unit norm: the conditioning problem is one of column scales.
    assert doppler[-1] > 1e6 and conds[-1] > 1e6
    assert res.extra["condition_numbers_equilibrated"][-1] < 1e3
    assert f"{conds[-1]:.3g}" in res.message
    # Solved with equilibrated columns the direct method works and reaches the bound.
    assert res.status == "converged"
    assert np.all(np.abs(res.estimate - gu.theta) < 4 * res.std)
    assert res.std == pytest.approx(gu_bound.std[:4], rel=0.05)
    assert set(res.nuisance) == {"power_constant_db", "carrier"}


def test_gu_direct_variants(gu):
    meas = gu.simulate(rng=4)
    dop = GuDirect(kinds="frequency").iterate(meas, gu.motion, gu.theta)
    assert dop.extra["kinds"] == ["frequency"] and np.all(np.isfinite(dop.estimate))
    assert set(dop.nuisance) == {"carrier"}
    pw = GuDirect(kinds="power").iterate(meas, gu.motion, gu.theta)
    assert pw.extra["kinds"] == ["power"] and np.all(np.isfinite(pw.estimate))
    both = GuDirect().iterate(meas, gu.motion, PAPER_START)
    printed = GuDirect(normal_equations=True).iterate(meas, gu.motion, PAPER_START)
    # D_i^-1 N_i solved as printed: the same answer, but the update stalls at ~1e-4 m (the
    # conditioning), so it may not meet the tolerance.
    assert printed.estimate == pytest.approx(both.estimate, abs=0.01)
    far = GuDirect(kinds="frequency").iterate(meas, gu.motion, PAPER_START)
    assert far.status == "diverged"      # Doppler alone, from the paper's start
    with pytest.raises(ValueError, match="no power"):
        GuDirect(kinds="power").iterate(meas.select(kind="frequency"), gu.motion, PAPER_START)


# -- the lecture's Gauss–Newton (the Doppler-tracking lecture notes) -------------------------------
def test_lecture_gauss_newton_with_one_receiver_is_unobservable():
    scn = tk.load_scenario("doppler-lecture")
    start = scn.theta + np.array([500.0, -500.0, 300.0, 10.0, -10.0, 5.0])
    res = LectureGaussNewton().iterate(scn.simulate(rng=1), scn.motion, start)
    assert res.status == "unobservable"
    assert res.bound is not None and res.bound.rank == 4
    assert "rank 4 of 7" in res.message
    assert len(res.bound.observability.directions) == 3


def test_lecture_gauss_newton_with_three_receivers_reaches_the_bound():
    scn = three_receivers()
    bound = crlb(scn)
    start = scn.theta + np.array([500.0, -500.0, 300.0, 10.0, -10.0, 5.0])
    exact = LectureGaussNewton().iterate(scn.simulate(noise=False), scn.motion, start)
    assert exact.status == "converged"
    # noise-free data: within the solver's tolerance (an update below 1e-4 std) of the truth
    assert np.all(np.abs(exact.estimate - scn.theta) <= 1e-4 * bound.std[:6])
    assert exact.std == pytest.approx(bound.std[:6], rel=0.10)
    assert exact.nuisance["carrier"][1] == pytest.approx(bound.std_of("carrier"), rel=0.10)
    # Noisy data: the same answer as tmakit's ML.  The std is the inverse information at the
    # estimate, not at the truth; over ten seeds it was 0.65-1.12 x the CRLB for vy and within
    # ~12 % for the other entries (the information about vy depends strongly on the estimated
    # geometry), hence the looser tolerance here.
    for seed in (0, 2):
        meas = scn.simulate(rng=seed)
        res = LectureGaussNewton().iterate(meas, scn.motion, start)
        ml = tk.batch.estimate(meas, scn.motion, init=start)
        assert res.status == "converged"
        # the same optimum, to within the solvers' stopping tolerances (~0.005 std)
        assert np.all(np.abs(res.estimate - ml.estimate) < 0.01 * ml.std)
        assert np.all(np.abs(res.estimate - scn.theta) < 4 * bound.std[:6])
        assert res.std == pytest.approx(bound.std[:6], rel=0.35)
        assert res.std == pytest.approx(ml.std, rel=1e-3)


def test_lecture_gauss_newton_checks_the_motion_model():
    scn = tk.load_scenario("doppler-lecture")
    meas = scn.simulate(rng=1)
    with pytest.raises(ValueError, match="ref_time=120"):
        LectureGaussNewton().iterate(meas, tk.ConstantVelocity(3, ref_time=0.0), scn.theta)
    with pytest.raises(ValueError, match="ConstantVelocity"):
        LectureGaussNewton().iterate(meas, tk.ConstantVelocity(2, ref_time=120.0), scn.theta[:4])


# -- the registry ----------------------------------------------------------------------------------
def test_estimate_with_dispatches_by_name(gu):
    assert set(METHODS) == {"ml", "gu-direct", "ratio-power", "ratio-doppler", "ratio",
                            "lecture-gn", "chan-ho", "ho-xu"}
    meas = gu.simulate(rng=5)
    ml = estimate_with("ml", meas, gu.motion)
    assert ml.method == "ml" and ml.status == "converged"
    started = estimate_with("ratio", meas, gu.motion, init=dict(zip(
        gu.motion.param_names, PAPER_START, strict=True)))
    assert started.method == "ratio" and "start" not in started.extra
    blind = estimate_with("ratio", meas, gu.motion)
    assert blind.extra["start"] == "grid" and "grid" in blind.message
    assert blind.estimate == pytest.approx(started.estimate, abs=1e-3)
    assert estimate_with("ratio-doppler", meas, gu.motion,
                         init=PAPER_DOPPLER_START).method == "ratio-doppler"


def test_estimate_with_rejects_unknown_methods_and_models(gu):
    meas = gu.simulate(rng=6)
    with pytest.raises(ValueError, match="ml, gu-direct, ratio-power, ratio-doppler, ratio, "
                                         "lecture-gn"):
        estimate_with("kalman", meas, gu.motion)
    with pytest.raises(ValueError, match="drift"):
        estimate_with("ratio", meas, gu.motion, init=PAPER_START,
                      options={"frequency": {"drift": True}})
