"""The radar of Hurtado & Nehorai (2008): signal-model FIM, measurement CRB, state information.

The closed-form Fisher information is checked against a brute-force FIM of the sampled array
signal (finite differences, the complex amplitude eliminated numerically); the chained state
information against tmakit's MeasurementGroup and against an independent chain through the
paper's own parameters; the full (range, range-rate) covariance through filters and bounds.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tmakit.bounds import PosteriorInformation
from tmakit.filters import ExtendedKalmanFilter, ParticleFilter
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.observation import MeasurementGroup, NoiseModel, radar_group, radar_rows
from tmakit.sensors import HURTADO_NEHORAI_2008_RADAR, RadarModel

RADAR = HURTADO_NEHORAI_2008_RADAR
C = 299_792_458.0


def brute_force_fim(radar: RadarModel, phi: float, psi: float, doppler: float) -> np.ndarray:
    """FIM about [phi, psi, tau, omega_D] of the sampled signal, amplitude eliminated.

    ``2 Re(D^H D) / sigma^2`` (sigma = 1) over samples and elements with ``D`` the central
    differences of the sampled signal with respect to [phi, psi, tau, omega_D, Re b, Im b];
    the Schur complement removes the unknown complex amplitude.
    """
    tau = 2.0 * 12_000.0 / C
    times = tau + radar.sample_offsets
    # |b| as the model's SNR defines it (noise variance 1), an arbitrary phase
    b0 = math.sqrt(radar.snr / np.sum(np.abs(radar.pulse(radar.sample_offsets)) ** 2))
    eta = np.array([phi, psi, tau, doppler, 0.6 * b0, 0.8 * b0])
    steps = np.array([1e-6, 1e-6, 1e-6 * radar.rms_duration, 1e-6 / radar.rms_duration,
                      1e-5 * b0, 1e-5 * b0])

    def h(e: np.ndarray) -> np.ndarray:
        return radar.signal(e[0], e[1], e[2], e[3], complex(e[4], e[5]), times).ravel()

    d = np.stack([(h(eta + s * np.eye(6)[i]) - h(eta - s * np.eye(6)[i])) / (2 * s)
                  for i, s in enumerate(steps)], axis=1)
    f = 2.0 * np.real(d.conj().T @ d)
    return f[:4, :4] - f[:4, 4:] @ np.linalg.solve(f[4:, 4:], f[4:, :4])


def relative_error(a: np.ndarray, b: np.ndarray) -> float:
    """Largest entry error scaled by sqrt(b_ii b_jj) (entries that are zero included)."""
    d = np.sqrt(np.abs(np.diagonal(b)))
    return float(np.max(np.abs(a - b) / np.outer(d, d)))


@pytest.mark.parametrize(("phi", "psi", "doppler", "kw"), [
    (0.7, 0.3, 2e4, {}),
    (-2.4, -0.9, -5e3, {"chirp": "down", "pulse_length": 3e-6}),
    (1.9, 0.05, 0.0, {"elements": 7, "spacing": 0.4, "snr_per": "sample"}),
])
def test_closed_form_fim_equals_brute_force(phi, psi, doppler, kw):
    radar = RadarModel(**kw)
    closed = radar.signal_information(psi, dim=3)
    numeric = brute_force_fim(radar, phi, psi, doppler)
    assert relative_error(numeric, closed) < 1e-6


def test_closed_form_properties():
    radar = RADAR
    assert radar.array_radius == pytest.approx(radar.wavelength / 2.0, rel=1e-12)
    assert radar.samples_per_pulse == 273
    j = radar.signal_information(0.0)
    m_s = radar.elements * radar.snr
    assert np.linalg.det(j[2:, 2:]) == pytest.approx(m_s**2, rel=1e-9)  # chirp-independent
    assert j[1, 1] == 0.0  # a horizontal array sees no elevation at elevation 0
    assert j[2, 3] < 0.0  # up-chirp: delay and Doppler information of opposite sign
    # the chirp rate reproduces the stated (half-power) bandwidth of the sampled pulse
    fs = 64e6
    t = np.arange(-8 * radar.rms_duration, 8 * radar.rms_duration, 1 / fs)
    spec = np.abs(np.fft.fftshift(np.fft.fft(radar.pulse(t), 1 << 16))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(1 << 16, 1 / fs))
    rms = math.sqrt(np.sum(f * f * spec) / np.sum(spec))
    assert rms == pytest.approx(radar.bandwidth / (2 * math.sqrt(2 * math.log(2))), rel=1e-4)


def test_two_d_reduction_and_covariance():
    radar = RADAR
    j3 = radar.signal_information(0.2, dim=3)
    j2 = radar.signal_information(0.2, dim=2)
    np.testing.assert_allclose(j2, j3[np.ix_([0, 2, 3], [0, 2, 3])])
    cov = radar.measurement_covariance()
    scale = np.array([-1.0, C / 2.0, -radar.wavelength / (4 * math.pi)])
    expected = np.linalg.inv(radar.signal_information(0.0, dim=2)) * np.outer(scale, scale)
    np.testing.assert_allclose(cov, expected, rtol=1e-12)
    rho = cov[1, 2] / math.sqrt(cov[1, 1] * cov[2, 2])
    assert -1.0 < rho < -0.99
    # a subset is the marginal; the order follows kinds
    np.testing.assert_allclose(radar.measurement_covariance(("range_rate", "range")),
                               cov[np.ix_([2, 1], [2, 1])])
    c3 = radar.measurement_covariance(("bearing", "elevation", "range", "range_rate"), 0.3)
    assert c3[0, 1] == 0.0 and c3.shape == (4, 4)


def test_resolution_variant():
    derived = RADAR.measurement_covariance()
    res = dataclasses.replace(RADAR, range_accuracy="resolution").measurement_covariance()
    assert math.sqrt(res[1, 1]) == pytest.approx(C / 2e6)  # 149.9 m
    assert math.sqrt(res[1, 1]) == pytest.approx(150.0, abs=0.2)
    assert res[1, 2] == 0.0 and res[0, 1] == 0.0
    assert res[0, 0] == pytest.approx(derived[0, 0])
    assert res[2, 2] == pytest.approx(derived[2, 2])  # the derived marginal


@pytest.mark.parametrize(("kw", "word"), [
    ({"bandwidth": -1e6}, "bandwidth"), ({"elements": 2}, "elements"),
    ({"elements": True}, "elements"), ({"elements": 6.0}, "elements"),
    ({"carrier_frequency": float("nan")}, "carrier_frequency"), ({"chirp": "flat"}, "chirp"),
    ({"snr_per": "element"}, "snr_per"), ({"range_accuracy": "cell"}, "range_accuracy"),
    ({"pulse_length": 1e-7}, "pulse_length"), ({"sampling_rate": 1e6}, "sampling_rate"),
    ({"snr_db": float("inf")}, "snr_db"), ({"bandwidth": 2e9, "pulse_length": 1e-6,
                                           "sampling_rate": 5e9}, "narrow band"),
])
def test_bad_parameters_refused(kw, word):
    with pytest.raises(ValueError, match=word):
        RadarModel(**kw)


def test_bad_requests_refused():
    with pytest.raises(ValueError, match="kinds"):
        RADAR.measurement_covariance(("bearing", "frequency"))
    with pytest.raises(ValueError, match="kinds"):
        RADAR.measurement_covariance(("range", "range"))
    with pytest.raises(ValueError, match="elevation information"):
        RADAR.measurement_covariance(("bearing", "elevation"), 0.0)
    with pytest.raises(ValueError, match="components"):
        RADAR.state_information(np.zeros((3, 5)), np.zeros(6))
    with pytest.raises(ValueError, match="elevation information"):
        RADAR.simulate(np.array([1e4, 0, 0, 0, 0, 0.0]), np.zeros(6), rng=1)


def states_2d():
    targets = np.array([[8e3, 3e3, 25.0, 0.0], [-2e3, 9e3, 10.0, -5.0], [4e3, -6e3, 0.0, 30.0]])
    sensors = np.array([[0.0, 0, 0, 0, 50, 0], [500.0, 200, 0, 30, 40, 0]])
    return targets, sensors


@pytest.mark.parametrize("variant", ["derived", "resolution"])
def test_state_information_equals_group_information(variant):
    radar = dataclasses.replace(RADAR, range_accuracy=variant)
    targets, sensors = states_2d()
    xi = radar.state_information(targets, sensors)
    assert xi.shape == (2, 3, 4, 4)
    group = MeasurementGroup.planned(radar.kinds(2), None, 0.0, 2,
                                     covariance=radar.measurement_covariance())
    ref = group.information(targets[None, :, :], sensors[:, None, None, :])
    np.testing.assert_allclose(xi, ref, rtol=1e-9, atol=0)
    np.testing.assert_allclose(radar_group(radar, 0.0).information(
        targets[None], sensors[:, None, None, :]), ref, rtol=1e-12)


def test_state_information_3d_equals_group_information():
    psi = 0.25
    rng = np.random.default_rng(3)
    az = rng.uniform(-math.pi, math.pi, 4)
    r = rng.uniform(2e3, 2e4, 4)
    sensor = np.array([100.0, -50.0, 300.0, 20.0, 40.0, 1.0])
    pos = sensor[:3] + np.stack([r * np.cos(psi) * np.sin(az), r * np.cos(psi) * np.cos(az),
                                 r * np.sin(psi)], axis=1)
    targets = np.concatenate([pos, rng.normal(0, 20, (4, 3))], axis=1)
    xi = RADAR.state_information(targets, sensor)
    group = radar_group(RADAR, 0.0, 3, elevation=psi)
    np.testing.assert_allclose(xi, group.information(targets, sensor[None, :]), rtol=1e-9)


def test_group_information_equals_chained_signal_fim():
    """Xi from the group (the bound's route) = H^T J H through the paper's own parameters."""
    targets, sensors = states_2d()
    lam = RADAR.wavelength

    def paper_parameters(x: np.ndarray, s: np.ndarray) -> np.ndarray:
        dx, dy = x[0] - s[0], x[1] - s[1]
        vx, vy = x[2] - s[3], x[3] - s[4]
        r = math.hypot(dx, dy)
        rdot = (dx * vx + dy * vy) / r
        return np.array([math.atan2(dy, dx), 2 * r / C, -4 * math.pi * rdot / lam])

    j = RADAR.signal_information(0.0, dim=2)
    post = PosteriorInformation.from_prior(np.diag([1e8, 1e8, 1e4, 1e4]),
                                           NearlyConstantVelocity(2, 0.1), 0.0, targets)
    for s in sensors:
        group = radar_group(RADAR, 0.0, 2, values=np.zeros(3) + 1.0, sensor_state=s)
        got = post.state_information(group)
        for x, xi in zip(targets, got, strict=True):
            h = np.empty((3, 4))
            for i in range(4):
                e = np.zeros(4)
                e[i] = 1e-3 * (1.0 if i < 2 else 0.1)
                h[:, i] = (paper_parameters(x + e, s) - paper_parameters(x - e, s)) / (2 * e[i])
            np.testing.assert_allclose(xi, h.T @ j @ h, rtol=1e-6, atol=1e-12 * np.abs(xi).max())


def test_group_full_covariance_noise_and_validation():
    cov = RADAR.measurement_covariance()
    group = radar_group(RADAR, 0.0)
    np.testing.assert_allclose(group.covariance, cov)
    np.testing.assert_allclose(group.sigmas, np.sqrt(np.diagonal(cov)))
    w = group.noise.whiten(np.eye(3), axis=0)
    np.testing.assert_allclose(w.T @ w, np.linalg.inv(cov), rtol=1e-8)
    np.testing.assert_allclose(NoiseModel.from_covariance(cov).covariance(), cov, rtol=1e-8)
    for bad, word in [(np.eye(2), "shape"), (np.array([[1.0, 2.0, 0], [0, 1, 0], [0, 0, 1]]),
                                            "symmetric"), (-np.eye(3), "positive definite")]:
        with pytest.raises(ValueError, match=word):
            MeasurementGroup.planned(RADAR.kinds(2), None, 0.0, 2, covariance=bad)
    with pytest.raises(ValueError, match="sigmas or a covariance"):
        MeasurementGroup.planned(RADAR.kinds(2), None, 0.0, 2)
    # without a covariance the group is what it was
    plain = MeasurementGroup.planned(RADAR.kinds(2), [0.01, 100.0, 5.0], 0.0, 2)
    assert plain.full_covariance is None
    np.testing.assert_allclose(plain.covariance, np.diag([1e-4, 1e4, 25.0]))


def test_simulate_matches_the_covariance():
    """20,000 seeded draws: variances within 4 % (4 standard errors of a variance, sqrt(2/n)
    = 1 %), the correlation within 0.005, the mean within 4 standard errors."""
    n = 20_000
    target = np.array([6e3, 8e3, 25.0, 0.0])
    sensor = np.array([0.0, 0, 0, 0, 50, 0])
    z = RADAR.simulate(np.broadcast_to(target, (n, 4)), sensor, rng=np.random.default_rng(7))
    truth = RADAR.measure(target, sensor)
    cov = RADAR.measurement_covariance()
    sample = np.cov(z.T)
    sig = np.sqrt(np.diagonal(cov))
    np.testing.assert_allclose(np.diagonal(sample), np.diagonal(cov), rtol=0.04)
    rho = sample[1, 2] / math.sqrt(sample[1, 1] * sample[2, 2])
    assert rho == pytest.approx(cov[1, 2] / (sig[1] * sig[2]), abs=0.005)
    assert np.all(np.abs(z.mean(axis=0) - truth) < 4 * sig / math.sqrt(n))
    again = RADAR.simulate(target, sensor, rng=5)
    assert np.array_equal(again, RADAR.simulate(target, sensor, rng=5)) and again.shape == (3,)


def test_ekf_updates_with_the_full_covariance():
    target = np.array([6e3, 8e3, 25.0, 0.0])
    sensor = np.array([0.0, 0, 0, 0, 50, 0])
    z = RADAR.simulate(target, sensor, rng=2)
    prior = np.diag([500.0, 500.0, 20.0, 20.0]) ** 2
    mean0 = target + np.array([200.0, -300.0, 5.0, -5.0])
    ekf = ExtendedKalmanFilter(mean0, prior, 0.0, q=0.1)
    group = radar_group(RADAR, 0.0, values=z, sensor_state=sensor)
    ekf.update(group)
    h = group.jacobian(mean0)
    r = RADAR.measurement_covariance()
    k = prior @ h.T @ np.linalg.inv(h @ prior @ h.T + r)
    np.testing.assert_allclose(ekf.covariance, (np.eye(4) - k @ h) @ prior, rtol=1e-6)
    np.testing.assert_allclose(ekf.state, mean0 + k @ group.residual(group.predict(mean0)),
                               rtol=1e-9)
    # the rows alone (marginal sigmas, independent) give another answer
    plain = ExtendedKalmanFilter(mean0, prior, 0.0, q=0.1)
    plain.update(radar_rows(RADAR, 0.0, z, sensor))
    assert not np.allclose(plain.covariance, ekf.covariance, rtol=1e-2)
    with pytest.raises(ValueError, match="predict the filter first"):
        ekf.update(radar_group(RADAR, 1.0, values=z, sensor_state=sensor))


def test_particle_filter_updates_with_the_full_covariance():
    target = np.array([6e3, 8e3, 25.0, 0.0])
    sensor = np.array([0.0, 0, 0, 0, 50, 0])
    z = RADAR.simulate(target, sensor, rng=4)
    prior = np.diag([300.0, 300.0, 30.0, 30.0]) ** 2
    pf = ParticleFilter(target, prior, 0.0, particles=4000, rng=1, q=0.1)
    particles = pf.particles
    group = radar_group(RADAR, 0.0, values=z, sensor_state=sensor)
    info = pf.update(group)
    nu = group.residual(group.predict(particles))
    r = RADAR.measurement_covariance()
    quad = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(r), nu)
    loglik = -0.5 * quad - 0.5 * math.log(np.linalg.det(2 * math.pi * r))
    top = loglik.max()
    assert info.log_likelihood == pytest.approx(top + math.log(np.mean(np.exp(loglik - top))),
                                                rel=1e-9)
    assert np.all(np.isfinite(pf.state))


@pytest.mark.parametrize("variant", ["derived", "resolution"])
def test_planner_sensor_plan_with_the_radar_covariance(variant):
    """The planner's SensorPlan carrying the radar's covariance gives the radar's Xi."""
    from tmakit.planning.measurement_plan import SensorPlan

    radar = dataclasses.replace(RADAR, range_accuracy=variant)
    targets, sensors = states_2d()
    plan = SensorPlan(radar.kinds(2), radar.measurement_sigmas(), 2,
                      covariance=radar.measurement_covariance())
    np.testing.assert_allclose(plan.information(targets, sensors),
                               radar.state_information(targets, sensors), rtol=1e-9)
