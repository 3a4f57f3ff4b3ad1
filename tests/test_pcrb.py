"""The posterior Cramér–Rao bound (Tichavský recursion, Hurtado & Nehorai (2008), eqs. 10-11)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import tmakit as tk
from tmakit.bounds import PosteriorInformation, crlb, deterministic_pcrb, posterior_crb
from tmakit.bounds.fim import fisher_information
from tmakit.bounds.pcrb_recursion import predict_information
from tmakit.filters import MeasurementGroup, process_noise, transition_matrix
from tmakit.montecarlo.geometries import final_position_rms
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.observation import group_times

P0_2D = np.diag([3000.0**2, 3000.0**2, 10.0**2, 10.0**2])
P0_3D = np.diag([2000.0**2] * 3 + [50.0**2] * 3)


def true_state(scn: tk.Scenario, t: float, dim: int) -> np.ndarray:
    state = scn.target_states([t])[0]
    return state[[0, 1, 3, 4]] if dim == 2 else state


def batch_information_with_prior(scn, meas, mean0, p0, t0, t_final):
    """Batch Fisher information of ``meas`` about the state at ``t_final`` (a constant-velocity
    model referenced there) plus the prior mapped to ``t_final``: Phi^-T P0^-1 Phi^-1."""
    dim = mean0.shape[0] // 2
    phi = transition_matrix(t_final - t0, dim)
    motion = tk.ConstantVelocity(dim, ref_time=t_final)
    obs = tk.ObservationModel(meas, motion, scn.measurement_options)
    info = fisher_information(obs, phi @ mean0, obs.nuisance_vector(scn.nuisance),
                              known_nuisance=True)
    phi_inv = np.linalg.inv(phi)
    return info + phi_inv.T @ np.linalg.inv(p0) @ phi_inv


def assert_same_bound(cov, expected, rtol):
    d = np.sqrt(np.diag(expected))
    assert np.max(np.abs(cov - expected) / np.outer(d, d)) < rtol


@pytest.mark.parametrize("name, p0", [("bearings-only-2d", P0_2D), ("chen-sun-1", P0_3D)])
def test_zero_process_noise_equals_batch_crlb_with_the_prior(name, p0):
    scn = tk.load_scenario(name)
    meas = scn.simulate(noise=False)
    dim = p0.shape[0] // 2
    t0 = float(meas.time.min())
    mean0 = true_state(scn, t0, dim)
    bound = deterministic_pcrb(scn, mean0, p0, t0)
    assert bound.mode == "deterministic" and len(bound) == np.unique(meas.time).size
    assert bound.state_names == (("x", "y", "vx", "vy") if dim == 2 else
                                 ("x", "y", "z", "vx", "vy", "vz"))
    if name == "chen-sun-1":
        assert set(meas.kinds) == {"bearing", "range_difference"}
    # At the final time and at a time half-way, against the batch bound of the data so far.
    for k in (len(bound) - 1, len(bound) // 2):
        t = float(bound.times[k])
        upto = meas.take(meas.time <= t + 1e-9)
        info = batch_information_with_prior(scn, upto, mean0, p0, t0, t)
        expected = np.linalg.inv(info)
        assert_same_bound(bound.covariance[k], expected, 1e-6)
        assert np.allclose(bound.information[k], info, rtol=1e-6,
                           atol=1e-9 * np.abs(info).max())
        assert bound.position_rms[k] == pytest.approx(
            np.sqrt(np.trace(expected[:dim, :dim])), rel=1e-6)


def test_a_very_weak_prior_gives_the_batch_crlb_alone():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(noise=False)
    t0, tf = float(meas.time.min()), float(meas.time.max())
    batch = crlb(meas, tk.ConstantVelocity(2, ref_time=tf), true_state(scn, tf, 2),
                 known_nuisance=True)
    assert batch.rank == 4
    rms = []
    for scale in (1.0, 30.0, 1000.0):
        bound = deterministic_pcrb(scn, None, P0_2D * scale**2, t0)
        rms.append(bound.position_rms[-1])
    weakest = deterministic_pcrb(scn, None, P0_2D * 1000.0**2, t0)
    assert np.allclose(weakest.std[-1], batch.std, rtol=1e-4)
    # The prior only ever adds information: the bound grows towards the batch bound.
    batch_rms = np.hypot(batch.std_of("x"), batch.std_of("y"))
    assert rms[0] < rms[1] < rms[2] <= batch_rms * (1 + 1e-9)
    assert rms[2] == pytest.approx(batch_rms, rel=1e-4)


def test_process_noise_prediction_matches_the_covariance_form():
    """Q > 0: the information-form step equals (Q + F J^-1 F^T)^-1, and the whole recursion
    equals the covariance recursion with Jacobians along the mean trajectory."""
    rng = np.random.default_rng(5)
    a = rng.standard_normal((4, 4))
    info = a @ a.T + 0.1 * np.eye(4)
    f, q_mat = transition_matrix(7.0, 2), process_noise(7.0, (0.3, 0.05), 2)
    evals, evecs = np.linalg.eigh(q_mat)
    g = evecs[:, evals > 1e-14 * evals.max()] * np.sqrt(evals[evals > 1e-14 * evals.max()])
    direct = np.linalg.inv(q_mat + f @ np.linalg.inv(info) @ f.T)
    assert np.allclose(predict_information(info, np.linalg.inv(f), g), direct, rtol=1e-9)

    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(noise=False)
    t0 = 0.0
    mean = true_state(scn, t0, 2)
    q = 0.02
    bound = deterministic_pcrb(meas, mean, P0_2D, t0, q=q)
    p, x, t = P0_2D.copy(), mean.copy(), t0
    for k, tk_ in enumerate(bound.times):
        f = transition_matrix(tk_ - t, 2)
        p, x, t = f @ p @ f.T + process_noise(tk_ - t, q, 2), f @ x, tk_
        group = MeasurementGroup(meas.take(np.flatnonzero(np.abs(meas.time - tk_) < 1e-9)),
                                 tk_, 2)
        h = group.jacobian(x)
        p = np.linalg.inv(np.linalg.inv(p) + h.T @ np.linalg.solve(group.covariance, h))
        if k in (0, 100, len(bound) - 1):
            assert_same_bound(bound.covariance[k], p, 1e-6)


def test_process_noise_increases_the_bound():
    scn = tk.load_scenario("bearings-only-2d")
    det = [deterministic_pcrb(scn, None, P0_2D, 0.0, q=q).position_rms[-1]
           for q in (0.0, 0.005, 0.05)]
    assert det[0] < det[1] < det[2]
    mc = [posterior_crb(scn, None, P0_2D, 0.0, q=q, trajectories=50, rng=3).position_rms[-1]
          for q in (0.0, 0.05)]
    assert mc[0] < mc[1]
    # Per-axis noise: noise on one axis only lies between none and both.
    one_axis = deterministic_pcrb(scn, None, P0_2D, 0.0, q=(0.05, 0.0)).position_rms[-1]
    assert det[0] < one_axis < det[2]


def test_monte_carlo_with_a_tight_prior_and_no_process_noise_is_the_deterministic_bound():
    scn = tk.load_scenario("chen-sun-1")
    tight = np.diag([1.0] * 3 + [0.01**2] * 3)
    det = deterministic_pcrb(scn, None, tight)
    mc = posterior_crb(scn, None, tight, trajectories=400, rng=11)
    assert mc.mode == "monte-carlo" and mc.trajectories == 400
    assert np.allclose(mc.std, det.std, rtol=1e-5)
    # With a wide prior the expectation over trajectories differs from the mean trajectory
    # (E[information] is not the information at E[x]): the two must not be confused.
    wide_det = deterministic_pcrb(scn, None, P0_3D)
    wide_mc = posterior_crb(scn, None, P0_3D, trajectories=100, rng=11)
    assert not np.allclose(wide_mc.position_rms[-1], wide_det.position_rms[-1], rtol=0.05)


def test_monte_carlo_error_is_estimated_and_domination_is_reported():
    # Azimuth + range differences from 70 km: every trajectory sees alike.
    scn = tk.load_scenario("chen-sun-1")
    runs = [posterior_crb(scn, None, P0_3D, trajectories=100, rng=s) for s in range(6)]
    spread = np.std([b.position_rms[-1] for b in runs], ddof=1)
    se = np.mean([b.position_rms_se[-1] for b in runs])
    assert spread / 3 < se < 3 * spread
    assert all(np.nanmax(b.max_share) < 0.2 and not b.notes for b in runs)
    # Bearings-only with a wide velocity prior: some trajectories pass the observer closely
    # and one of them carries almost all the expected information.
    wide = posterior_crb(tk.load_scenario("bearings-only-2d"), None, P0_2D, 0.0,
                         trajectories=100, rng=1)
    assert np.nanmax(wide.max_share) > 0.5
    assert any("heavy-tailed" in n for n in wide.notes)
    det = deterministic_pcrb(scn, None, P0_3D)
    assert det.position_rms_se is None and det.max_share is None


def test_batched_jacobians_equal_the_group_jacobian_at_each_state():
    scn = tk.load_scenario("chen-sun-1")
    meas = scn.simulate(noise=False)
    rows = meas.take(np.flatnonzero((meas.time >= 40) & (meas.time <= 42)))  # several times
    assert "range_difference" in rows.kinds
    group = MeasurementGroup(rows, 41.5, 3)
    rng = np.random.default_rng(2)
    states = true_state(scn, 41.5, 3) + rng.standard_normal((5, 6)) * np.array(
        [500.0, 500.0, 500.0, 20.0, 20.0, 20.0])
    batched = group.jacobian(states)
    assert batched.shape == (5, len(group), 6)
    info = group.information(states)
    for i in range(5):
        assert np.allclose(batched[i], group.jacobian(states[i]), rtol=1e-12, atol=0.0)
        w = group.noise.whiten(group.jacobian(states[i]), axis=-2)
        assert np.allclose(info[i], w.T @ w, rtol=1e-12, atol=0.0)


def test_running_the_recursion_by_hand_equals_deterministic_pcrb():
    scn = tk.load_scenario("chen-sun-1")  # bearings and correlated range differences
    meas = scn.simulate(noise=False)
    mean = true_state(scn, 0.0, 3)
    q = 0.05
    bound = deterministic_pcrb(meas, mean, P0_3D, 0.0, q=q)
    post = PosteriorInformation.from_prior(P0_3D, NearlyConstantVelocity(3, q), 0.0, mean)
    for k, idx in enumerate(group_times(meas)):
        t = float(meas.time[idx[-1]])
        post = post.predict(t - post.time)
        group = MeasurementGroup(meas.take(idx), t, 3)
        post = post.update(post.expected_information(group.sensor_state[None], group))
        if k in (0, 7, len(bound) - 1):
            assert post.time == pytest.approx(bound.times[k], abs=1e-9)
            assert np.allclose(post.information, bound.information[k], rtol=1e-10,
                               atol=1e-12 * np.abs(bound.information[k]).max())
    assert post.position_rms == pytest.approx(bound.position_rms[-1], rel=1e-9)


def test_expected_information_over_candidates_equals_a_loop_of_single_evaluations():
    scn = tk.load_scenario("bearings-only-2d")
    rng = np.random.default_rng(4)
    mean = true_state(scn, 0.0, 2)
    states = mean + rng.standard_normal((30, 4)) * np.array([800.0, 800.0, 3.0, 3.0])
    post = PosteriorInformation.from_prior(P0_2D, NearlyConstantVelocity(2, 0.01), 0.0,
                                           states).predict(20.0)
    group = MeasurementGroup.planned(["bearing", "range"], [np.radians(1.0), 50.0],
                                     post.time, 2)
    candidates = np.zeros((7, 6))
    candidates[:, :2] = rng.uniform(-5000.0, 5000.0, (7, 2))
    candidates[:, 3:5] = rng.uniform(-10.0, 10.0, (7, 2))
    gamma = post.expected_information(candidates, group)
    assert gamma.shape == (7, 4, 4)
    for c in range(7):
        sensor = np.broadcast_to(candidates[c], (len(group), 6))
        one = np.mean([group.information(x, sensor) for x in post.states], axis=0)
        assert np.allclose(gamma[c], one, rtol=1e-12, atol=0.0)
        h = group.jacobian(post.states, sensor)
        direct = np.einsum("nmi,m,nmj->ij", h, 1.0 / np.diag(group.covariance), h) / 30
        assert np.allclose(gamma[c], direct, rtol=1e-10, atol=0.0)
    # The planner's question: the bound after the update from each candidate.
    after = post.update(gamma)
    assert after.position_rms.shape == (7,)
    assert np.all(after.position_rms < post.position_rms)
    with pytest.raises(ValueError, match="candidate_sensor_states"):
        post.expected_information(np.zeros((7, 5)), group)
    with pytest.raises(ValueError, match="predict to the group's time"):
        post.predict(1.0).expected_information(candidates, group)


def test_same_seed_same_bound_and_different_seed_different_bound():
    scn = tk.load_scenario("bearings-only-2d")
    a = posterior_crb(scn, None, P0_2D, 0.0, q=0.01, trajectories=20, rng=7)
    b = posterior_crb(scn, None, P0_2D, 0.0, q=0.01, trajectories=20,
                      rng=np.random.default_rng(7))
    c = posterior_crb(scn, None, P0_2D, 0.0, q=0.01, trajectories=20, rng=8)
    assert np.array_equal(a.covariance, b.covariance)
    assert not np.allclose(a.covariance, c.covariance, rtol=1e-3)
    assert final_position_rms(prior_cov=P0_2D, time0=0.0, q=0.01, trajectories=20,
                              rng=7) == a.position_rms[-1]
    data = json.loads(a.to_json())
    assert data["mode"] == "monte-carlo" and data["trajectories"] == 20
    assert len(data["time"]) == len(a) and data["q"] == [0.01, 0.01]
    assert a.at(300.5)["time"] == 300.0
    assert "pos. RMS" in a.summary()


def test_overlapping_range_differences_across_updates_are_reported():
    scn = copy.deepcopy(tk.load_scenario("chen-sun-1"))
    scn.plans[1].lags = (1, 2)  # a lag-2 difference shares an interval with the previous lag-1
    with pytest.warns(UserWarning, match="correlated between groups"):
        bound = deterministic_pcrb(scn, None, P0_3D)
    assert bound.notes and "approximate" in bound.notes[0]
    assert not deterministic_pcrb(tk.load_scenario("chen-sun-1"), None, P0_3D).notes


def test_bad_input_is_refused_with_a_clear_message():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(noise=False)
    mean = true_state(scn, 0.0, 2)
    with pytest.raises(ValueError, match="prior_mean must be"):
        posterior_crb(meas, mean[:3], P0_2D)
    with pytest.raises(ValueError, match="prior_cov must be 4x4"):
        posterior_crb(meas, mean, P0_3D)
    with pytest.raises(ValueError, match="positive definite"):
        posterior_crb(meas, mean, np.diag([1.0, 1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="finite"):
        posterior_crb(meas, mean * np.nan, P0_2D)
    with pytest.raises(ValueError, match=r"time0=5\.0 s is after the first measurement"):
        posterior_crb(meas, mean, P0_2D, 5.0)
    with pytest.raises(ValueError, match="trajectories"):
        posterior_crb(meas, mean, P0_2D, trajectories=0)
    with pytest.raises(ValueError, match="process noise q must be finite and >= 0"):
        posterior_crb(meas, mean, P0_2D, q=-1.0)
    with pytest.raises(ValueError, match="q must be one value or 2 values"):
        deterministic_pcrb(meas, mean, P0_2D, q=(0.1, 0.1, 0.1))
    with pytest.raises(ValueError, match="prior_mean is required"):
        deterministic_pcrb(meas, None, P0_2D)
    with pytest.raises(TypeError, match="load a built-in scenario first"):
        deterministic_pcrb("bearings-only-2d", None, P0_2D)
    with pytest.raises(TypeError, match="Scenario"):
        deterministic_pcrb([1, 2, 3], mean, P0_2D)
    gu = tk.load_scenario("gu2007").simulate(noise=False)
    gu.metadata.pop("nuisance")
    with pytest.raises(ValueError, match="nuisance"):
        deterministic_pcrb(gu, np.array([3200.0, 3200.0, -21.65, -12.5]), P0_2D)
