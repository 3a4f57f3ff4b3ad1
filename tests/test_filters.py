"""Recursive filters: EKF (and iterated EKF), UKF, particle filter; measurement groups;
closed-form kernels against the general path; consistency, wrap, numerical safety, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import tmakit as tk
from tmakit.data import MeasurementSet
from tmakit.filters import (
    FILTERS,
    ExtendedKalmanFilter,
    MeasurementGroup,
    ParticleFilter,
    UnscentedKalmanFilter,
    group_times,
    process_noise,
    transition_matrix,
)
from tmakit.filters.general import SCALAR_ROWS, PreparedMeasurements, plan_for
from tmakit.filters.particle import systematic_resample
from tmakit.motion.dynamics import NearlyConstantVelocity

NUISANCE = {"carrier": 9.4e9, "power_constant_db": -30.0}
KINDS8 = ("bearing", "elevation", "azimuth_rate", "range", "range_rate", "frequency", "power",
          "range_difference")


def general_path(filt, meas, lag: int = 0, by_kind: bool = True):
    """The group path: one MeasurementGroup per update (with the rows ``lag`` updates back)."""
    return filt.run_groups(
        (t, MeasurementGroup(rows, t, filt.dim, filt.options, filt.nuisance))
        for t, rows in update_rows(meas, lag, by_kind))


def update_rows(meas, lag: int = 0, by_kind: bool = True):
    """``(time, rows)`` per update time, with the rows of the update ``lag`` earlier too.

    The rows of an update are ordered by kind: the UKF's sigma-point sums are sensitive to the
    order at 1e-6 std (9.4 GHz carrier), and a step takes them grouped by kind.
    """
    idx = group_times(meas)
    out = []
    for k, i in enumerate(idx):
        rows = np.concatenate([idx[k - lag], i]) if lag and k >= lag else i
        out.append((float(meas.time[i[-1]]),
                    meas.take(rows[np.argsort(meas.kind_code[rows], kind="stable")] if by_kind
                              else rows)))
    return out


def all_kinds_rows(t: float, dim: int) -> MeasurementSet:
    """Every kind from two moving sensors (one climbing), at times around ``t`` (other
    times than the update's), two range differences of one sensor sharing an interval."""
    kinds, times, sensors, states, t_ref, ref_states = [], [], [], [], [], []
    sensor_a = np.array([100.0, -300.0, 50.0, 20.0, 5.0, 0.0])
    sensor_b = np.array([-2000.0, 800.0, 400.0, -3.0, 12.0, 2.0])
    for i, kind in enumerate(KINDS8):
        for j, (name, s) in enumerate((("a", sensor_a), ("b", sensor_b))):
            ti = t + (-2.0 + 0.5 * i - 1.5 * j)
            kinds.append(kind)
            times.append(ti)
            sensors.append(name)
            states.append(s + np.r_[s[3:] * (ti - t), 0, 0, 0])
            tr = ti - 1.0 - j if kind == "range_difference" else np.nan
            t_ref.append(tr)
            ref_states.append(s + np.r_[s[3:] * (tr - t), 0, 0, 0] if np.isfinite(tr)
                              else np.full(6, np.nan))
    # A second range difference of sensor a overlapping the first one's interval.
    kinds.append("range_difference")
    times.append(t + 2.5)
    sensors.append("a")
    states.append(sensor_a + np.r_[sensor_a[3:] * 2.5, 0, 0, 0])
    t_ref.append(t + 0.5)
    ref_states.append(sensor_a + np.r_[sensor_a[3:] * 0.5, 0, 0, 0])
    n = len(kinds)
    return MeasurementSet(np.array(times), np.array(sensors), np.array(kinds), np.zeros(n),
                          np.ones(n), np.array(states), np.array(t_ref), np.array(ref_states),
                          check=False)  # placeholder values: only the Jacobians are used


@pytest.mark.parametrize("dim", [2, 3])
def test_group_jacobian_equals_finite_differences_for_every_kind(dim):
    t = 50.0
    rows = all_kinds_rows(t, dim)
    assert set(rows.kinds) == set(KINDS8)
    group = MeasurementGroup(rows, t, dim, {"frequency": {"drift": True}}, NUISANCE)
    assert np.any(group.dt != 0) and np.any(np.isfinite(group.dt_ref))
    x = (np.array([3000.0, 4000.0, 900.0, -12.0, 7.0, 3.0]) if dim == 3
         else np.array([3000.0, 4000.0, -12.0, 7.0]))
    jac = group.jacobian(x)
    step = np.where(np.arange(2 * dim) < dim, 0.5, 1e-3)  # m, m/s
    fd = np.empty_like(jac)
    for i in range(2 * dim):
        e = np.zeros(2 * dim)
        e[i] = step[i]
        fd[:, i] = (group.predict(x + e) - group.predict(x - e)) / (2 * step[i])
    # Truncation (relative 1e-6) plus the rounding of values as large as a 9.4 GHz carrier.
    rounding = 8 * np.finfo(float).eps * np.abs(group.predict(x))[:, None] / step[None, :]
    scale = np.abs(jac).max(axis=1, keepdims=True)
    assert np.all(np.abs(jac - fd) <= 1e-6 * scale + rounding)
    # Range differences depend on the state at both samples: velocity columns are non-zero.
    rd = group.index["range_difference"]
    assert np.all(np.abs(jac[rd][:, dim:]).max(axis=1) > 0)
    # The prepared (view-based) group is the same group.
    cm = PreparedMeasurements(rows, dim, {"frequency": {"drift": True}}, NUISANCE)
    assert len(cm) == len(np.unique(rows.time))
    whole = MeasurementGroup(rows.take(cm.order), t, dim, {"frequency": {"drift": True}},
                             NUISANCE)
    k = len(cm) - 1
    fast = cm.group(k, t)
    a, b = cm.bounds[k], cm.bounds[k + 1]
    ref = MeasurementGroup(rows.take(cm.order[a:b]), t, dim, {"frequency": {"drift": True}},
                           NUISANCE)
    assert np.array_equal(fast.predict(x), ref.predict(x))
    assert np.array_equal(fast.jacobian(x), ref.jacobian(x))
    assert np.array_equal(fast.covariance, ref.covariance)
    assert fast.rows.equals(ref.rows)
    # Correlated range differences of one sensor: R has the shared interval off-diagonal.
    r = whole.covariance
    rd = whole.index["range_difference"]
    assert np.count_nonzero(r[np.ix_(rd, rd)] - np.diag(np.diag(r[np.ix_(rd, rd)]))) == 2


def linear_case(n_steps: int = 40, seed: int = 1):
    """A nearly linear problem: bearings from a sensor 200 km south and ranges from one
    200 km north of a target near the origin with a 20 m prior.  The measurement functions
    are linear to ~sigma^2 / 200 km over the prior, so every filter must reproduce the
    Kalman filter of the Jacobians at the truth."""
    rng = np.random.default_rng(seed)
    truth0 = np.array([0.0, 0.0, 3.0, -2.0])
    p0 = np.diag([20.0**2, 20.0**2, 1.0, 1.0])
    times = np.arange(1.0, n_steps + 1.0)
    south = np.array([0.0, -2e5, 0.0, 0.0, 0.0, 0.0])
    north = np.array([0.0, 2e5, 0.0, 0.0, 0.0, 0.0])
    sig_b, sig_r = 1e-4, 10.0  # rad (20 m across at 200 km), m
    kinds, tt, sensors, states, values, sigmas = [], [], [], [], [], []
    for t in times:
        x = transition_matrix(t, 2) @ truth0
        for kind, name, s, sig in (("bearing", "s", south, sig_b), ("range", "n", north, sig_r)):
            rel = np.r_[x[:2] - s[:2], 0.0]
            val = np.arctan2(rel[0], rel[1]) if kind == "bearing" else np.linalg.norm(rel)
            val += sig * rng.standard_normal()
            kinds.append(kind)
            tt.append(t)
            sensors.append(name)
            states.append(s)
            values.append(np.degrees(val) if kind == "bearing" else val)
            sigmas.append(np.degrees(sig) if kind == "bearing" else sig)
    meas = MeasurementSet(np.array(tt), np.array(sensors), np.array(kinds), np.array(values),
                          np.array(sigmas), np.array(states))
    mean0 = truth0 + np.linalg.cholesky(p0) @ rng.standard_normal(4)
    return meas, mean0, p0, truth0


def kalman_reference(meas, mean0, p0, truth0, q):
    """Plain Kalman filter on the measurements linearised about the true trajectory."""
    x, p, t = mean0.copy(), p0.copy(), 0.0
    out_x, out_p = [], []
    for idx in group_times(meas):
        tk_ = float(meas.time[idx[-1]])
        phi = transition_matrix(tk_ - t, 2)
        x, p, t = phi @ x, phi @ p @ phi.T + process_noise(tk_ - t, q, 2), tk_
        rows = meas.take(idx)
        group = MeasurementGroup(rows, t, 2)
        xt = transition_matrix(t, 2) @ truth0
        h = group.jacobian(xt)
        z = group.values - group.predict(xt) + h @ xt  # linearised at the truth
        s = h @ p @ h.T + group.covariance
        k = p @ h.T @ np.linalg.inv(s)
        x = x + k @ (z - h @ x)
        p = (np.eye(4) - k @ h) @ p
        out_x.append(x)
        out_p.append(0.5 * (p + p.T))
    return np.array(out_x), np.array(out_p)


def test_filters_agree_with_the_kalman_filter_on_a_nearly_linear_problem():
    meas, mean0, p0, truth0 = linear_case()
    q = 0.05
    ref_x, ref_p = kalman_reference(meas, mean0, p0, truth0, q)
    std = np.sqrt(np.einsum("kii->ki", ref_p))
    norm = std[:, :, None] * std[:, None, :]  # compare covariances as correlations
    for cls in (ExtendedKalmanFilter, UnscentedKalmanFilter):
        track = cls(mean0, p0, 0.0, q=q).run(meas)
        assert np.max(np.abs(track.states - ref_x) / std) < 1e-2, cls.name
        assert np.max(np.abs(track.covariances - ref_p) / norm) < 1e-2, cls.name
    # The particle filter to its Monte Carlo error.  (With almost no process noise a bootstrap
    # filter loses ancestors at every resampling; a 3-sigma outlier then lands where few
    # particles are and costs it ~0.4 std for a few steps: data with seed 3 do that.)
    pf = ParticleFilter(mean0, p0, 0.0, q=q, particles=20000, rng=5).run(meas)
    assert np.max(np.abs(pf.states - ref_x) / std) < 0.15
    ratio = np.einsum("kii->ki", pf.covariances) / np.einsum("kii->ki", ref_p)
    assert np.all((ratio > 0.8) & (ratio < 1.2))


def test_particle_bearing_likelihood_equals_the_general_one():
    # The particle filter weighs a single bearing in closed form (1.9x a whole track).
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(11))
    mean0 = scn.target_states([0.0])[0][[0, 1, 3, 4]] + np.array([700.0, -400.0, 3.0, -2.0])
    p0 = np.diag([1500.0**2, 1500.0**2, 5.0**2, 5.0**2])
    pf = ParticleFilter(mean0, p0, 0.0, q=0.02, particles=500, rng=1, resample_threshold=1e-9)
    pf.predict(float(meas.time[0]))
    group = pf.group(meas.take([0]))
    general, nu = pf._general_loglik(group)
    uniform = pf._w.copy()
    info = pf._update_bearing(group)
    expected = np.log(np.sum(uniform * np.exp(general)))
    assert info.log_likelihood == pytest.approx(expected, rel=1e-12)
    w = uniform * np.exp(general - general.max())
    assert np.allclose(pf.weights, w / w.sum(), rtol=1e-9, atol=1e-15)
    nu_bar = float(nu[:, 0] @ uniform)
    var = float(((nu[:, 0] - nu_bar) ** 2) @ uniform) + group.covariance[0, 0]
    assert info.nis == pytest.approx(nu_bar**2 / var, rel=1e-9)


def wrap_case(flip: bool, seed: int = 4):
    """A target due south of a zig-zagging sensor (bearing near ±180°, the measured values
    jump between +180 and -180), or with ``flip`` the same geometry turned by 180° (due
    north, bearings near 0): the tracks must be the same turned by 180°."""
    rng = np.random.default_rng(seed)
    times = np.arange(1.0, 301.0)
    sensor = np.zeros((times.size, 6))
    heading = np.where((times // 60) % 2 == 0, np.radians(100.0), np.radians(80.0))
    vel = 10.0 * np.c_[np.sin(heading), np.cos(heading)]
    sensor[:, :2] = np.cumsum(vel, axis=0)
    sensor[:, 3:5] = vel
    target0 = np.array([300.0, -8000.0, 4.0, 1.0])
    pos = target0[:2] + times[:, None] * target0[2:]
    noise = np.radians(1.0) * rng.standard_normal(times.size)
    rel = pos - sensor[:, :2]
    sign = -1.0 if flip else 1.0
    bearing = np.degrees(np.arctan2(sign * rel[:, 0], sign * rel[:, 1]) + noise)
    meas = MeasurementSet(times, np.full(times.size, "s"), np.full(times.size, "bearing"),
                          bearing, np.ones(times.size), sign * sensor)
    p0 = np.diag([600.0**2, 600.0**2, 3.0**2, 3.0**2])
    mean0 = target0 + np.array([400.0, -500.0, 1.0, -1.0])
    return meas, sign * mean0, p0, sign * np.c_[pos, np.tile(target0[2:], (times.size, 1))]


def test_bearings_through_180_degrees_are_wrapped():
    south, mean_s, p0, truth_s = wrap_case(False)
    north, mean_n, _, _ = wrap_case(True)
    values = np.radians(south.value)
    assert np.any(values > np.radians(179)) and np.any(values < np.radians(-179))
    for cls in (UnscentedKalmanFilter, ExtendedKalmanFilter):
        a = cls(mean_s, p0, 0.0).run(south)
        b = cls(mean_n, p0, 0.0).run(north)
        assert np.allclose(a.states, -b.states, rtol=0, atol=1e-6 * np.abs(a.states).max())
        assert np.allclose(a.covariances, b.covariances, rtol=1e-7,
                           atol=1e-9 * np.abs(a.covariances).max())
        assert np.all(a.nis < 30.0)  # no 360-degree innovations
        err = a.states[-1, :2] - truth_s[-1, :2]
        assert err @ np.linalg.solve(a.covariances[-1, :2, :2], err) < 20.0
        slow = general_path(cls(mean_s, p0, 0.0), south)
        assert np.allclose(slow.states, a.states, rtol=0, atol=1e-6 * np.abs(a.states).max())
    # The sigma points' predicted bearings straddle ±180°: their circular mean is not the
    # arithmetic one.
    ukf = UnscentedKalmanFilter(mean_s, np.diag([3000.0**2, 3000.0**2, 9.0, 9.0]), 0.0)
    ukf.predict(1.0)
    group = ukf.group(south.take([0]))
    z = group.predict(ukf.sigma_points())[:, 0]
    assert np.ptp(z) > np.pi  # both signs
    pf_a = ParticleFilter(mean_s, p0, 0.0, particles=3000, rng=2).run(south)
    err = pf_a.states[-1, :2] - truth_s[-1, :2]
    assert err @ np.linalg.solve(pf_a.covariances[-1, :2, :2], err) < 20.0


def assert_valid_covariances(covs):
    assert np.all(np.isfinite(covs))
    assert np.array_equal(covs, np.swapaxes(covs, -1, -2))
    evals = np.linalg.eigvalsh(covs)
    assert np.all(evals >= -1e-12 * np.abs(evals).max(axis=-1, keepdims=True))


@pytest.mark.parametrize("name", ["ekf", "ukf", "pf", "iekf"])
def test_covariances_stay_symmetric_psd_with_degenerate_inputs(name):
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(2))
    meas = meas.take(meas.time <= 150.0)
    tiny = MeasurementSet(meas.time, meas.sensor, meas.kind, meas.value,
                          np.full(len(meas), 1e-7), meas.sensor_state)  # 1e-7 deg noise
    mean0 = scn.target_states([0.0])[0][[0, 1, 3, 4]] + np.array([50.0, 80.0, 0.5, 0.2])
    huge = np.diag([1e12, 1e12, 1e8, 1e8])
    cls = FILTERS.get(name, ExtendedKalmanFilter)
    kw = {"particles": 500, "rng": 3} if name == "pf" else (
        {"iterations": 3} if name == "iekf" else {})
    for data, p0, q in ((tiny, huge, 0.0), (tiny, np.diag([1e-6, 1e-6, 1e-8, 1e-8]), 0.0),
                        (meas, huge, 1e-3)):
        fast = cls(mean0, p0, 0.0, q=q, **kw).run(data)
        assert_valid_covariances(fast.covariances)
        if name != "pf":
            slow = general_path(cls(mean0, p0, 0.0, q=q, **kw), data)
            assert_valid_covariances(slow.covariances)
    # A 3-D filter (general path only) with range differences and bearings.
    chen = tk.load_scenario("chen-sun-1")
    m3 = chen.simulate(np.random.default_rng(1))
    m3 = m3.take(m3.time <= 20.0)
    x3 = chen.target_states([0.0])[0] + np.array([100.0, -100.0, 50.0, 1.0, 1.0, 0.0])
    f3 = cls(x3, np.diag([1e12] * 3 + [1e8] * 3), 0.0, **kw).run(m3)
    assert_valid_covariances(f3.covariances)


@pytest.mark.parametrize("name", ["ekf", "ukf", "pf"])
def test_seeded_monte_carlo_nees_is_consistent(name):
    """30 runs of the first 300 s of bearings-only-2d, prior mean ~ N(truth, P0): the mean
    NEES over runs, averaged over the last 200 updates, must lie in the 99 % band of the mean
    of 30 chi-square(4) variables, [2.80, 5.45] (a filter whose covariance is off by a
    factor 1.5 either way fails)."""
    scn = tk.load_scenario("bearings-only-2d")
    p0 = np.diag([500.0**2, 500.0**2, 5.0**2, 5.0**2])
    rng = np.random.default_rng(100)
    chol = np.linalg.cholesky(p0)
    x0 = scn.target_states([0.0])[0][[0, 1, 3, 4]]
    runs = 30
    nees = []
    for r in range(runs):
        meas = scn.simulate(rng)
        meas = meas.take(meas.time <= 300.0)
        mean0 = x0 + chol @ rng.standard_normal(4)
        kw = {"particles": 2000, "rng": r} if name == "pf" else {}
        track = FILTERS[name](mean0, p0, 0.0, **kw).run(meas)
        truth = scn.target_states(track.times)[:, [0, 1, 3, 4]]
        nees.append(track.nees(truth))
    mean_nees = np.mean(nees, axis=0)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 4 * runs) / runs
    late = mean_nees[100:].mean()
    assert lo < late < hi


def test_particle_filter_is_reproducible_for_a_seed():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(3))
    meas = meas.take(meas.time <= 100.0)
    mean0 = scn.target_states([0.0])[0][[0, 1, 3, 4]]
    p0 = np.diag([800.0**2, 800.0**2, 4.0**2, 4.0**2])
    a = ParticleFilter(mean0, p0, 0.0, q=0.01, particles=800, rng=9).run(meas)
    b = ParticleFilter(mean0, p0, 0.0, q=0.01, particles=800,
                       rng=np.random.default_rng(9)).run(meas)
    c = ParticleFilter(mean0, p0, 0.0, q=0.01, particles=800, rng=10).run(meas)
    assert np.array_equal(a.states, b.states) and np.array_equal(a.covariances, b.covariances)
    assert np.array_equal(a.log_likelihood, b.log_likelihood)
    assert not np.allclose(a.states, c.states)


def test_particle_filter_with_a_noise_density_draws_numpys_normals():
    # Its move is compiled and numba draws the normals from the same Generator: the cloud
    # moves by exactly what rng.standard_normal((2, dim, N)) would have drawn.
    q_density, dt, n = 0.05, 2.0, 3000
    pf = ParticleFilter(np.array([1000.0, 2000.0, 3.0, -1.0]),
                        np.diag([100.0**2, 100.0**2, 2.0**2, 2.0**2]), 0.0, particles=n,
                        rng=4, dynamics=NearlyConstantVelocity(2, 0.0, q_density))
    before, rng = pf.particles, np.random.default_rng()
    rng.bit_generator.state = pf.rng.bit_generator.state
    pf.predict(dt)
    w = rng.standard_normal((2, 2, n))
    l11 = np.sqrt(q_density * dt**3 / 3)
    l21 = q_density * dt**2 / 2 / l11
    l22 = np.sqrt(q_density * dt - l21**2)
    expected = before.copy()
    expected[:, :2] += dt * before[:, 2:] + l11 * w[0].T
    expected[:, 2:] += l21 * w[0].T + l22 * w[1].T
    assert np.allclose(pf.particles, expected, rtol=1e-12, atol=1e-9)
    assert pf.rng.bit_generator.state == rng.bit_generator.state


def test_systematic_resampling_and_regularisation():
    rng = np.random.default_rng(0)
    w = rng.random(1000) ** 4
    w /= w.sum()
    for u in (0.0, 0.3, 0.999999):
        idx = systematic_resample(w, u)
        expected = np.searchsorted(np.cumsum(w) / np.sum(w), (u + np.arange(1000)) / 1000)
        assert np.array_equal(idx, np.minimum(expected, 999))
    # Resampling + kernel shrinkage keeps the cloud's mean and covariance (Liu & West).
    pf = ParticleFilter(np.zeros(4), np.diag([100.0, 50.0, 4.0, 1.0]), particles=20000,
                        rng=1)
    pf._w = rng.random(20000) ** 2
    pf._w /= pf._w.sum()
    pf._logw = np.log(pf._w)
    pf._uniform = False
    pf._moments = None
    mean, cov = pf.state, pf.covariance
    pf._resample()
    assert pf.resamples == 1 and np.allclose(pf.weights, 1.0 / 20000)
    after = pf.particles
    std = np.sqrt(np.diag(cov))
    assert np.all(np.abs(after.mean(axis=0) - mean) < 0.05 * std)
    assert np.allclose(np.cov(after.T), cov, rtol=0.1, atol=0.05 * np.outer(std, std).max())
    assert len(np.unique(after[:, 0])) == 20000  # no duplicates left


def test_bad_inputs_are_refused_with_clear_messages():
    p0 = np.eye(4)
    with pytest.raises(ValueError, match="prior mean must be"):
        ExtendedKalmanFilter(np.zeros(5), np.eye(5))
    with pytest.raises(ValueError, match="prior covariance must be 4x4"):
        UnscentedKalmanFilter(np.zeros(4), np.eye(3))
    with pytest.raises(ValueError, match="positive definite"):
        ParticleFilter(np.zeros(4), -p0)
    with pytest.raises(ValueError, match="q must be finite and >= 0"):
        ExtendedKalmanFilter(np.zeros(4), p0, q=-1.0)
    with pytest.raises(ValueError, match="particles must be a whole number >= 2"):
        ParticleFilter(np.zeros(4), p0, particles=1)
    with pytest.raises(ValueError, match="resample_threshold"):
        ParticleFilter(np.zeros(4), p0, resample_threshold=0.0)
    with pytest.raises(ValueError, match="alpha"):
        UnscentedKalmanFilter(np.zeros(4), p0, alpha=0.0)
    with pytest.raises(ValueError, match="iterations"):
        ExtendedKalmanFilter(np.zeros(4), p0, iterations=0)
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(1))
    filt = ExtendedKalmanFilter(np.array([4000.0, 9000.0, 0.0, 0.0]), 1e6 * p0, 10.0)
    with pytest.raises(ValueError, match="before the filter's prior time"):
        filt.run(meas)
    filt.predict(20.0)
    with pytest.raises(ValueError, match="filters run forward"):
        filt.predict(5.0)
    with pytest.raises(TypeError, match="MeasurementSet"):
        filt.run(np.zeros(3))
    freq = tk.load_scenario("gu2007").simulate(np.random.default_rng(1))
    for cls in (ExtendedKalmanFilter, UnscentedKalmanFilter, ParticleFilter):
        with pytest.raises(ValueError, match="nuisance parameter"):
            cls(np.array([3000.0, 3000.0, -20.0, -10.0]), 1e6 * p0, 0.0).run(freq)


def several_kinds_run(dim: int, seed: int = 5, scalar: bool = False
                      ) -> tuple[MeasurementSet, np.ndarray, np.ndarray]:
    """Two moving sensors, every kind without a reference sample (power and range rate from
    sensor a, the rest from both), 120 updates of 5 to 12 rows; noisy values around a
    constant-velocity target; a prior near it.  ``scalar``: only the kinds with a plain-float
    ``row_gradient`` (the general path's Python-float linearisation)."""
    from tmakit.measurements import model_for

    rng = np.random.default_rng(seed)
    kinds = ["bearing", "azimuth_rate", "range", "range_rate", "frequency", "power"]
    if dim == 3:
        kinds.append("elevation")
    if scalar:  # only kinds with a plain-float row_gradient
        kinds = [k for k in kinds if k not in ("azimuth_rate", "power")]
    sigma = {"bearing": 0.01, "elevation": 0.01, "azimuth_rate": 1e-4, "range": 30.0,
             "range_rate": 0.5, "frequency": 2.0, "power": 1.0}
    x0 = np.array([6000.0, 4000.0, 300.0 if dim == 3 else 0.0, -5.0, 2.0, 0.0])
    rows = []
    for t in np.arange(1.0, 121.0):
        target = np.r_[x0[:3] + t * x0[3:], x0[3:]]
        for name, start, vel in (("a", [0, 0, 100], [8, 3, 0]), ("b", [2000, -3000, 0],
                                                                  [-4, 9, 1])):
            sensor = np.r_[np.array(start, float) + t * np.array(vel, float), vel]
            for kind in kinds:
                if (name == "b" and kind in ("power", "range_rate")) or rng.random() < 0.2:
                    continue
                model = model_for(kind)
                nu = model.nuisance_vector(NUISANCE) if model.nuisance_names else None
                z = float(model.predict((target - sensor)[None], np.array([t]), nu)[0])
                rows.append((t, name, kind, z + sigma[kind] * rng.standard_normal(),
                             sigma[kind], sensor))
    t, s, k, v, sg, st = (np.array(c) for c in zip(*rows, strict=True))
    meas = MeasurementSet.from_si(t, s, k, v, sg, np.stack(st))
    keep = [0, 1, 3, 4] if dim == 2 else [0, 1, 2, 3, 4, 5]
    offset = rng.normal(0, 100.0, 2 * dim) * np.r_[np.ones(dim), np.full(dim, 0.02)]
    return meas, x0[keep] + offset, np.diag(np.r_[np.full(dim, 300.0**2), np.full(dim, 4.0**2)])


def test_updated_covariance_is_the_short_form_unless_that_is_not_positive_definite():
    from scipy.linalg.lapack import dpotrf

    from tmakit.filters.general import innovation_solve, joseph, updated_covariance

    rng = np.random.default_rng(0)
    forms = set()
    for r in (1.0, 1e-12):  # ordinary noise; noise so small that rounding breaks P - KHP
        for _ in range(5):
            a = rng.standard_normal((4, 4))
            cov = 1e6 * a @ a.T + np.eye(4)
            h = rng.standard_normal((2, 4))
            hp = h @ cov
            gain = innovation_solve(hp @ h.T + r * np.eye(2), hp, np.zeros(2))[0]
            got = updated_covariance(cov, gain, hp, h, r * np.eye(2))
            short = cov - gain @ hp
            short = 0.5 * (short + short.T)
            if dpotrf(short, lower=1, clean=0)[1] == 0:
                forms.add("short")
                assert np.array_equal(got, short)
            else:
                forms.add("joseph")
                assert np.array_equal(got, joseph(cov, gain, h, r * np.eye(2)))
            assert np.array_equal(got, got.T) and np.all(np.linalg.eigvalsh(got) > 0)
    assert forms == {"short", "joseph"}


@pytest.mark.parametrize(("dim", "scalar"), [(2, False), (3, False), (2, True), (3, True)])
def test_general_plan_equals_the_group_path(dim, scalar):
    meas, mean0, p0 = several_kinds_run(dim, scalar=scalar)
    prepared = PreparedMeasurements(meas, dim, None, NUISANCE)
    plan = plan_for(prepared)
    assert plan.ok and not prepared.single_bearing
    # Plain-float rows for updates of at most SCALAR_ROWS rows of such kinds, arrays otherwise.
    assert [step[9] is not None for step in plan.steps] == \
        [scalar and step[1].size <= SCALAR_ROWS for step in plan.steps]
    # The plan takes each update's rows grouped by kind; the UKF's sigma-point sums are
    # sensitive to that order at 1e-6 std here (9.4 GHz carrier), so the group path is given
    # the rows in the same order.
    rank = {kind: i for i, kind in enumerate(prepared.models)}
    meas = meas.take(np.lexsort(([rank[k] for k in meas.kind], meas.time)))
    for cls, kw in ((ExtendedKalmanFilter, {}), (ExtendedKalmanFilter, {"iterations": 3}),
                    (UnscentedKalmanFilter, {})):
        fast_filter = cls(mean0, p0, 0.0, q=0.05, nuisance=NUISANCE, **kw)
        fast = fast_filter.run(meas)
        slow = general_path(cls(mean0, p0, 0.0, q=0.05, nuisance=NUISANCE, **kw), meas)
        assert np.array_equal(fast.times, slow.times) and np.array_equal(fast.dof, slow.dof)
        assert np.min(fast.dof) >= 1 and np.max(fast.dof) >= 5
        std = np.sqrt(np.einsum("kii->ki", slow.covariances))
        assert np.max(np.abs(fast.states - slow.states) / std) < 1e-7, (cls.name, kw)
        scale = np.abs(slow.covariances).max(axis=(1, 2))[:, None, None]
        assert np.max(np.abs(fast.covariances - slow.covariances) / scale) < 1e-9
        assert np.allclose(fast.nis, slow.nis, rtol=1e-7, atol=1e-9)
        assert np.allclose(fast.log_likelihood, slow.log_likelihood, rtol=1e-9, atol=1e-6)


@pytest.mark.parametrize("dim", [2, 3])
def test_step_by_step_rows_equal_the_group_path(dim):
    # Rows handed to update() one time at a time take a step made per pattern of rows, not a
    # group; with rows of an earlier time in the update too (multi-lag vectors).
    meas, mean0, p0 = several_kinds_run(dim)
    for cls, kw in ((ExtendedKalmanFilter, {}), (ExtendedKalmanFilter, {"iterations": 3}),
                    (UnscentedKalmanFilter, {})):
        # The EKF is not sensitive to the rows' order: given in file order, the step sorts them.
        for lag, by_kind in ((0, True), (3, True), (3, cls is UnscentedKalmanFilter)):
            steps_filter = cls(mean0, p0, 0.0, q=0.05, nuisance=NUISANCE, **kw)
            steps = steps_filter.run_groups(update_rows(meas, lag, by_kind))
            assert steps_filter._steps._patterns  # the rows' steps were used
            slow = general_path(cls(mean0, p0, 0.0, q=0.05, nuisance=NUISANCE, **kw), meas,
                                lag, by_kind)
            assert np.array_equal(steps.dof, slow.dof) and np.max(steps.dof) >= 5 + 5 * lag // 3
            std = np.sqrt(np.einsum("kii->ki", slow.covariances))
            assert np.max(np.abs(steps.states - slow.states) / std) < 1e-7, (cls.name, kw, lag)
            scale = np.abs(slow.covariances).max(axis=(1, 2))[:, None, None]
            assert np.max(np.abs(steps.covariances - slow.covariances) / scale) < 1e-9
            assert np.allclose(steps.nis, slow.nis, rtol=1e-7, atol=1e-9)
    # A kind whose nuisance value is missing is refused by name, as the group is.
    filt = ExtendedKalmanFilter(mean0, p0, 0.0, q=0.05)
    filt.predict(1.0)
    with pytest.raises(ValueError, match="carrier"):
        filt.update(meas.take(meas.kind == "frequency"))


def test_general_plan_skips_an_update_at_a_sensor_as_the_group_path_does():
    meas, mean0, p0 = several_kinds_run(2)
    meas = meas.take(meas.kind == "bearing")
    # The tenth update's sensor positions are not finite: its predictions are not either.
    states = meas.sensor_state.copy()
    tenth = meas.time == np.unique(meas.time)[9]
    states[tenth, :2] = np.nan
    bad = MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                 meas.sigma_si, states, check=False)  # a broken sensor on purpose
    fast_filter = ExtendedKalmanFilter(mean0, p0, 0.0, q=0.05)
    fast = fast_filter.run(bad)
    slow_filter = ExtendedKalmanFilter(mean0, p0, 0.0, q=0.05)
    slow = general_path(slow_filter, bad)
    assert fast_filter.skipped_updates == slow_filter.skipped_updates == 1
    assert np.isnan(fast.nis[9]) and fast.dof[9] == 0
    assert np.allclose(fast.states, slow.states, rtol=1e-9, atol=1e-6)


def test_particle_filter_limits_blas_threads_and_results_do_not_depend_on_them():
    from threadpoolctl import threadpool_info, threadpool_limits

    from tmakit.core.blas import one_thread

    with one_thread():
        inside = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    assert inside and all(n == 1 for n in inside)
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(4))
    meas = meas.take(meas.time <= 20.0)
    mean0 = scn.target_states([0.0])[0][[0, 1, 3, 4]] + np.array([300.0, -200.0, 1.0, 0.0])
    p0 = np.diag([800.0**2, 800.0**2, 4.0**2, 4.0**2])
    assert ParticleFilter.single_blas_thread and not ExtendedKalmanFilter.single_blas_thread

    def run():
        return ParticleFilter(mean0, p0, 0.0, particles=20000, rng=5).run(meas)

    default = run()
    with threadpool_limits(2, user_api="blas"):
        two = run()
    with threadpool_limits(1, user_api="blas"):
        one = run()
    assert np.array_equal(default.states, one.states)
    assert np.array_equal(two.covariances, one.covariances)
