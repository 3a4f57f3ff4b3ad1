"""The multiple-model filters (``imm``, ``mmpf``): the manoeuvring target, their outputs, their
refusals."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.cli.track import nis_verdict
from tmakit.filters import InteractingMultipleModel, MultipleModelParticleFilter, smooth
from tmakit.filters.imm import START_RELATIVE_STD, TURN_RATES_DEG, MarkovChain, models_of
from tmakit.tracking import truth_states

runner = CliRunner()


def hoerst_bearings(seed: int) -> tk.MeasurementSet:
    """hoerst2010's azimuths only (the target turns from 400 to 600 s)."""
    sim = tk.load_scenario("hoerst2010").simulate(np.random.default_rng(seed))
    return sim.take(np.flatnonzero(sim.kind == "bearing"))


@functools.cache
def imm_track(seed: int) -> tk.Track:
    """``tk.track`` of run ``seed``'s bearings with the default IMM, run once a worker: three
    tests read the track of run 5 (none changes it)."""
    return tk.track(hoerst_bearings(seed), "imm")


def final_error_and_verdict(meas, name, seed=None):
    tr = imm_track(seed) if name == "imm" and seed is not None else tk.track(meas, name)
    truth = truth_states(meas, tr.times, 2)
    verdict = nis_verdict(tr)
    return float(np.linalg.norm(tr.states[-1, :2] - truth[-1, :2])), verdict, tr


@pytest.mark.parametrize("seed", [5, 11])
def test_imm_beats_the_cv_ekf_through_the_turn_and_does_not_diverge(seed):
    meas = hoerst_bearings(seed)
    e_ekf, v_ekf, _ = final_error_and_verdict(meas, "ekf")
    e_imm, v_imm, tr = final_error_and_verdict(meas, "imm", seed)
    assert v_ekf.startswith("the innovations are larger"), v_ekf  # the CV EKF diverges
    assert v_imm == "", v_imm
    assert e_imm < 0.3 * e_ekf, (e_imm, e_ekf)
    mu = np.asarray(tr.extra.model_probabilities)
    assert mu.shape == (len(tr), 1 + 2 * len(TURN_RATES_DEG))
    np.testing.assert_allclose(mu.sum(axis=1), 1.0)
    right = [j for j, m in enumerate(tr.extra.models) if m["turn_rate"] < 0]
    turning = (tr.times > 450) & (tr.times < 650)
    # the target turns right (-0.57 deg/s) from 400 to 600 s: the right turns win there
    assert mu[turning][:, right].sum(axis=1).mean() > 0.6
    before = (tr.times > 340) & (tr.times < 400)  # the last minute of the first leg
    assert mu[turning][:, right].sum(axis=1).mean() > 2 * mu[before][:, right].sum(
        axis=1).mean()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_imm_takes_the_straight_leg_back_after_the_turn(seed):
    """The turn ends at 600 s: from 700 s on the straight model holds the probability (it
    did not with the earlier 0.375 deg/s turns and 500-s stay: 0.60-0.68 on these runs, and
    the final-time error of issue 28 came from there; docs/tracking.md)."""
    tr = tk.track(hoerst_bearings(seed), "imm")
    mu = np.asarray(tr.extra.model_probabilities)
    assert mu[tr.times >= 700, 0].mean() > 0.8


def test_the_imm_waits_for_a_start_whose_range_is_known_to_a_tenth():
    """By the start's covariance widened to its profile likelihood: on this run the 139-s
    window meets 0.1 of the range only by its linearised covariance."""
    from tmakit.tracking import BatchInitiator

    tr = imm_track(5)
    assert tr.extra.start["max_relative_std"] == START_RELATIVE_STD
    assert tr.extra.start["relative_position_std"] < START_RELATIVE_STD
    assert [r["relative_position_std"] > START_RELATIVE_STD
            for r in tr.extra.start["rejected"]] == [True]
    linearised = tk.track(hoerst_bearings(5), "imm", initiator=BatchInitiator(
        max_relative_std=START_RELATIVE_STD))  # the start as it was
    assert linearised.times[0] == tr.extra.start["rejected"][0]["time"] < tr.times[0]


def test_the_markov_chain_is_in_continuous_time():
    chain = MarkovChain(5, None, sojourn=300.0)
    one, two = chain.matrix(1.0), chain.matrix(2.5)
    np.testing.assert_allclose(one.sum(axis=1), 1.0)
    np.testing.assert_allclose(chain.matrix(3.5), one @ two, atol=1e-12)  # P(a+b) = P(a)P(b)
    # the mean stay: leaving at rate 1/300 per second
    assert -1.0 / np.log(chain.matrix(1e-3)[0, 0]) * 1e-3 == pytest.approx(300.0, rel=1e-3)
    np.testing.assert_allclose(chain.matrix(1e6), 0.2, atol=1e-9)  # then every model alike
    with pytest.raises(ValueError, match="sojourn must be a mean stay > 0"):
        MarkovChain(5, None, sojourn=0.0)


def test_transition_and_model_q_refused_with_their_names():
    with pytest.raises(ValueError, match="transition must be a 2x2"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), model_q=[1.0], turn_rates=[],
                                 transition=[[0.9, 0.2], [0.1, 0.9]])
    for bad in ([-1.0], [1e300], [np.nan]):
        with pytest.raises(ValueError, match="model_q"):
            InteractingMultipleModel(np.zeros(4), np.eye(4), model_q=bad)
    with pytest.raises(ValueError, match="turn_rates must be != 0 and within"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), turn_rates=[7.0])
    with pytest.raises(ValueError, match="component"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), component="pf")
    with pytest.raises(ValueError, match="iterations apply to EKF"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), component="ckf", iterations=3)


def position_errors(tr, meas):
    truth = truth_states(meas, tr.times, 2)
    e = tr.states[:, :2] - truth[:, :2]
    d2 = np.einsum("ki,kij,kj->k", e, np.linalg.inv(tr.covariances[:, :2, :2]), e)
    return np.sum(e**2, axis=1), d2


@pytest.mark.long
def test_imm_smoother_beats_the_filter_and_holds_the_truth():
    """Three seeded hoerst2010 runs: the smoothed RMS below the filtered, and the truth inside
    the smoothed 95 % ellipse in >= 95 % of the (run, step) pairs."""
    filtered, smoothed, inside = [], [], []
    for seed in (1, 2, 3):
        meas = hoerst_bearings(seed)
        tr = tk.track(meas, "imm", settings={"history": True})
        sm = smooth(tr)
        assert sm.extra.options["smoother"] == "imm two-filter"
        mu = np.asarray(sm.extra.model_probabilities)
        np.testing.assert_allclose(mu.sum(axis=1), 1.0)
        filtered.append(position_errors(tr, meas)[0])
        e2, d2 = position_errors(sm, meas)
        smoothed.append(e2)
        inside.append(d2 < 5.991)  # chi-square 95 %, 2 dof
        np.testing.assert_allclose(sm.states[-1], tr.states[-1])  # the last: no data after
    rms_f = np.sqrt(np.mean(np.concatenate(filtered)))
    rms_s = np.sqrt(np.mean(np.concatenate(smoothed)))
    assert rms_s < 0.9 * rms_f, (rms_s, rms_f)
    assert np.mean(np.concatenate(inside)) >= 0.95


def test_imm_smoother_refuses_a_lag_and_a_track_without_history():
    meas = hoerst_bearings(5)
    with pytest.raises(ValueError, match="IMM smoother is fixed-interval"):
        smooth(tk.track(meas, "imm", settings={"history": True}), lag=5)
    with pytest.raises(ValueError, match="imm filter's track kept no history"):
        smooth(imm_track(5))


def test_mmpf_smoother_draws_models_with_the_paths():
    meas = hoerst_bearings(4)
    tr = tk.track(meas, "mmpf", particles=1500, rng=4, settings={"history": True})
    assert all(step.labels is not None for step in tr.extra.history)
    sm = smooth(tr, trajectories=100, rng=1)
    assert sm.extra.options["smoother"] == "ffbsi 100"
    mu = np.asarray(sm.extra.model_probabilities)
    np.testing.assert_allclose(mu.sum(axis=1), 1.0)
    e_f, _ = position_errors(tr, meas)
    e_s, d2 = position_errors(sm, meas)
    assert np.sqrt(e_s.mean()) < np.sqrt(e_f.mean()), (np.sqrt(e_s.mean()), np.sqrt(e_f.mean()))
    assert np.mean(d2 < 5.991) >= 0.9
    with pytest.raises(ValueError, match="mmpf filter's track kept no history"):
        smooth(tk.track(meas, "mmpf", particles=300, rng=4))



def exhaustive_ffbsi_rms(track, meas, trajectories, seed):
    """The backward simulation written plainly (Godsill, Doucet & West 2004, Algorithm 1):
    every path's weights over every particle, normalised, drawn by inverse CDF; the RMS
    position error of the paths' mean."""
    history, models = track.extra.history, models_of(track)
    rng = np.random.default_rng(seed)
    n = history[0].particles.shape[0]
    last = history[-1]
    idx = np.searchsorted(np.cumsum(last.weights), rng.random(trajectories))
    state, model = last.particles[:, idx].T, last.labels[idx]
    means = [state.mean(axis=0)]
    for k in range(len(history) - 2, -1, -1):
        step = history[k]
        dt = history[k + 1].time - step.time
        x = step.particles
        if step.centre is not None:
            x = step.shrink * x + ((1.0 - step.shrink) * step.centre)[:, None]
        phi = np.array([m.transition(dt) for m in models])
        cov = np.array([m.noise(dt) for m in models]) + (
            0.0 if step.jitter is None else phi @ step.jitter @ phi.transpose(0, 2, 1))
        info = np.linalg.inv(0.5 * (cov + cov.transpose(0, 2, 1)) + 1e-6 * np.eye(n))
        e = state[:, :, None] - phi[model] @ x                    # (paths, n, particles)
        with np.errstate(divide="ignore"):
            switch = history[k + 1].transition[step.labels][:, model].T
            logw = (np.log(step.weights) + np.log(switch)
                    - 0.5 * np.einsum("mai,mab,mbi->mi", e, info[model], e))
        cdf = np.cumsum(np.exp(logw - logw.max(axis=1, keepdims=True)), axis=1)
        u = rng.random(trajectories) * cdf[:, -1]
        pick = np.array([np.searchsorted(c, v) for c, v in zip(cdf, u, strict=True)])
        state, model = step.particles[:, pick].T, step.labels[pick]
        means.append(state.mean(axis=0))
    truth = truth_states(meas, track.times, 2)
    return float(np.sqrt(np.mean(np.sum((np.array(means[::-1])[:, :2] - truth[:, :2]) ** 2, 1))))


def test_mmpf_smoother_matches_the_exhaustive_backward_simulation():
    """The compiled backward simulation draws as the plain one does: over three seeded
    smoothers of one seeded MM-PF track (hoerst2010 to 500 s, through the turn's start), the
    smoothed RMS within 5 % of the plain algorithm's, and below the filtered RMS each time
    (from the start judged by its linearised covariance, at 136 s: from the start by the
    likelihood, at 171 s, one draw of three smoothed these 600 particles to above the filtered)."""
    from tmakit.tracking import BatchInitiator

    meas = hoerst_bearings(4)
    meas = meas.take(np.flatnonzero(meas.time <= 500.0))
    tr = tk.track(meas, "mmpf", particles=600, rng=4, settings={"history": True},
                  initiator=BatchInitiator(max_relative_std=START_RELATIVE_STD))
    filtered = np.sqrt(position_errors(tr, meas)[0].mean())
    fast = [np.sqrt(position_errors(smooth(tr, trajectories=50, rng=s), meas)[0].mean())
            for s in range(3)]
    plain = [exhaustive_ffbsi_rms(tr, meas, 50, s) for s in range(3)]
    assert abs(np.mean(fast) - np.mean(plain)) <= 0.05 * np.mean(plain), (fast, plain)
    assert max(fast) < filtered, (fast, filtered)


@pytest.fixture(scope="module")
def obs(tmp_path_factory):
    path = tmp_path_factory.mktemp("imm") / "obs.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=7), path)
    return path


def test_tma_track_imm_json_and_picture(obs, tmp_path):
    png = tmp_path / "imm.png"
    result = runner.invoke(app, ["track", str(obs), "--filter", "imm", "--component", "ckf",
                                 "--model-q", "0.5", "--turn-rate", "none", "--transition",
                                 "0.98,0.02;0.05,0.95", "--json", "--plot", str(png)])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert len(data["model_probabilities"]) == len(data["time"])
    assert data["transition"] == [[0.98, 0.02], [0.05, 0.95]]
    assert [m["q"][0] for m in data["models"]] == [0.0, 0.5]
    assert png.stat().st_size > 0


@pytest.mark.parametrize("args, words", [
    (["--transition", "0.9,0.2;0.1,0.9"], "--transition: must be"),
    # taken, or an internal error (OverflowError) for the rate's noise
    (["--model-q", "1e300"], "--model-q: must be accelerations within [0, 10000] m/s^2"),
    (["--turn-rate", "1e300"], "--turn-rate: must be != 0 and within +-6.283 rad/s (360 deg/s"),
    (["--turn-rate-noise", "1e300"], "--turn-rate-noise: must be a turn rate's random walk "
                                     "within [0, 6.283 rad/s (360 deg/s"),
    (["--transition", "a,b"], "--transition"),
    (["--model-q", "x"], "--model-q"),
    (["--lag", "3"], "--lag: --filter imm's smoother is fixed-interval"),
    (["--turn-rate", "left"], "--turn-rate 'left'"),
])
def test_tma_track_imm_refusals(obs, args, words):
    result = runner.invoke(app, ["track", str(obs), "--filter", "imm", *args])
    assert result.exit_code == 2, result.output
    assert words in result.output
    assert "Traceback" not in result.output


def test_model_q_only_with_imm(obs):
    result = runner.invoke(app, ["track", str(obs), "--model-q", "0.5"])
    assert result.exit_code == 2 and "only to --filter imm and mmpf" in result.output


def test_coordinated_turn_moves_along_the_circle():
    from tmakit.motion.dynamics import CoordinatedTurn

    w, speed = -0.01, 50.0  # a right turn: 0.5 m/s^2 at 50 m/s, as hoerst2010's target
    x0 = np.array([0.0, 0.0, speed, 0.0])
    x = CoordinatedTurn(2, 0.0, turn_rate=w).transition(100.0) @ x0
    centre = np.array([0.0, speed / w])  # to the right of an eastward course
    assert np.hypot(*x[2:]) == pytest.approx(speed)
    assert np.hypot(*(x[:2] - centre)) == pytest.approx(abs(speed / w))
    assert np.degrees(np.arctan2(x[3], x[2])) == pytest.approx(np.degrees(w * 100.0))
    with pytest.raises(ValueError, match="turn rate"):
        CoordinatedTurn(2, 0.0, turn_rate=0.0)


def test_tma_track_imm_turn_models(obs):
    result = runner.invoke(app, ["track", str(obs), "--filter", "imm", "--model-q", "1",
                                 "--turn-rate", "-0.5,0.5", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [round(np.degrees(m["turn_rate"]), 6) for m in data["models"]] == [0, 0, -0.5, 0.5]
    assert len(data["model_probabilities"][0]) == 4


@pytest.mark.parametrize("seed", [5, 11])
def test_mmpf_turn_model_gains_weight_in_the_turn(seed):
    meas = hoerst_bearings(seed)
    tr = tk.track(meas, "mmpf", particles=3000, rng=seed,
                  settings={"model_q": [], "turn_rates": [np.radians(-0.57)]})
    mu = np.asarray(tr.extra.model_probabilities)
    assert mu.shape == (len(tr), 2)
    np.testing.assert_allclose(mu.sum(axis=1), 1.0)
    turning = (tr.times > 450) & (tr.times < 650)
    assert mu[turning, 1].mean() > mu[tr.times < 350, 1].mean() + 0.05, mu
    assert tr.extra.models[1]["turn_rate"] == pytest.approx(np.radians(-0.57))


def test_mmpf_particles_keep_their_models_through_resampling():
    f = MultipleModelParticleFilter(np.zeros(4), np.eye(4), particles=500, rng=2,
                                    model_q=[1.0], turn_rates=[],
                                    transition=[[1.0, 0.0], [0.0, 1.0]], probabilities=[0.3, 0.7])
    assert f.probabilities.sum() == pytest.approx(1.0)
    f._w = np.where(f.labels == 1, 0.0, 1.0 / np.sum(f.labels == 0))
    f._resample()
    assert np.all(f.labels == 0)  # only model-0 particles had weight; no switching allowed
    with pytest.raises(ValueError, match="transition must be a 2x2"):
        MultipleModelParticleFilter(np.zeros(4), np.eye(4), model_q=[1.0], turn_rates=[],
                                    transition=[[0.9, 0.2], [0.1, 0.9]])


def test_tma_track_mmpf_json_and_refusals(obs):
    result = runner.invoke(app, ["track", str(obs), "--filter", "mmpf", "--particles", "2000",
                                 "--seed", "3", "--model-q", "0.5", "--turn-rate", "none",
                                 "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert len(data["model_probabilities"]) == len(data["time"])
    np.testing.assert_allclose(np.sum(data["model_probabilities"], axis=1), 1.0)
    assert [m["q"][0] for m in data["models"]] == [0.0, 0.5]
    for args, words in ((["--transition", "0.9,0.2;0.1,0.9"], "--transition: must be"),
                        (["--component", "ukf"], "--component applies only"),
                        (["--lag", "2"], "--lag: --filter mmpf's smoother is fixed-interval")):
        result = runner.invoke(app, ["track", str(obs), "--filter", "mmpf", *args])
        assert result.exit_code == 2 and words in result.output, result.output
        assert "Traceback" not in result.output


def test_tma_track_mmpf_starts_at_the_first_bearing(obs):
    result = runner.invoke(app, ["track", str(obs), "--filter", "mmpf", "--particles", "2000",
                                 "--seed", "1", "--model-q", "0.02", "--range-prior",
                                 "2000:30000", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["start"]["method"] == "first-bearing" and data["time"][0] == 1.0
    assert len(data["model_probabilities"]) == len(data["time"])
    assert data["model_probabilities"][0] == [m["prior"] for m in data["models"]]


def test_tma_track_smooths_imm_and_mmpf(obs, tmp_path):
    for name, extra in (("imm", []), ("mmpf", ["--particles", "500", "--seed", "2"])):
        png = tmp_path / f"{name}.png"
        result = runner.invoke(app, ["track", str(obs), "--filter", name, *extra, "--smooth",
                                     "--json", "--plot", str(png)])
        assert result.exit_code == 0, result.output
        data = json.loads(result.stdout)
        assert len(data["smoothed"]) == len(data["time"]) == len(data["smoothed_covariance"])
        assert data["smoother"] == ("imm two-filter" if name == "imm" else "ffbsi 200")
        np.testing.assert_allclose(np.sum(data["smoothed_model_probabilities"], axis=1), 1.0)
        assert png.stat().st_size > 0


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("w", [0.0, 2e-7, -0.01, 0.3])
@pytest.mark.parametrize("dt", [1.0, -7.0, 60.0])
def test_unknown_rate_turn_jacobian_equals_finite_differences(dim, w, dt):
    from tmakit.motion.dynamics import CoordinatedTurn, UnknownRateTurn, transition_matrix

    model = UnknownRateTurn(dim, 0.05, rate_noise=1e-4)
    x = np.r_[np.linspace(-3e3, 5e3, dim), np.linspace(-20.0, 40.0, dim), w]
    moved, jac = model.propagate(x, dt)
    numeric = np.empty_like(jac)
    for k in range(x.shape[0]):
        h = 1e-6 * max(1.0, abs(x[k]))
        e = np.zeros_like(x)
        e[k] = h
        numeric[:, k] = (model.propagate(x + e, dt)[0] - model.propagate(x - e, dt)[0]) / (2 * h)
    np.testing.assert_allclose(jac, numeric, rtol=1e-6, atol=1e-6)
    assert moved[-1] == w  # the rate is held; only its noise moves it
    expected = (CoordinatedTurn(dim, 0.0, turn_rate=w).transition(dt) if w
                else transition_matrix(dt, dim)) @ x[:-1]
    np.testing.assert_allclose(moved[:-1], expected, rtol=1e-10)


def test_unknown_rate_turn_noise_and_refusals():
    from tmakit.motion.dynamics import UnknownRateTurn, process_noise

    model = UnknownRateTurn(2, 0.05, rate_noise=2e-4)
    q = model.noise(-9.0)
    np.testing.assert_allclose(q[:4, :4], process_noise(9.0, 0.05, 2))
    assert q[4, 4] == pytest.approx(9.0 * 4e-8) and not q[4, :4].any()
    for bad in (-1.0, np.nan, 1e300):
        with pytest.raises(ValueError, match="turn rate's noise"):
            UnknownRateTurn(2, 0.05, rate_noise=bad)
    with pytest.raises(TypeError, match="depends on the turn rate"):
        model.transition(1.0)
    with pytest.raises(ValueError, match="rate_noise must be"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), rate_noise=float("nan"))
    with pytest.raises(ValueError, match="rate_std must be"):
        InteractingMultipleModel(np.zeros(4), np.eye(4), rate_noise=1e-4, rate_std=0.0)


def test_the_turn_rate_is_updated_as_by_the_augmented_ekf():
    """The rows see position and velocity; the turn rate's update through its correlation with
    them equals the extended Kalman update of the whole state [x, y, vx, vy, w] by hand."""
    from tmakit.filters.imm import update_models

    meas = hoerst_bearings(5)
    t = float(meas.time[300])
    rows = meas.take(np.flatnonzero(meas.time == t))
    f = InteractingMultipleModel(np.array([8e3, 2e4, -30.0, 40.0]), np.eye(4), t,
                                 turn_rates=[], rate_noise=1e-4)
    group = f.group(rows)
    mean = np.array([8e3, 2e4, -30.0, 40.0, 0.004])
    a = np.random.default_rng(3).standard_normal((5, 5))
    cov = np.diag([4e6, 9e6, 25.0, 36.0, 1e-5]) + 1e-3 * np.diag([4e6, 9e6, 25.0, 36.0, 1e-5]
                                                                ) ** 0.5 @ a @ a.T
    cov = 0.5 * (cov + cov.T)
    cov[:4, 4] = cov[4, :4] = 0.3 * np.sqrt(np.diag(cov)[:4] * cov[4, 4])
    means, covs = np.array([mean, mean]), np.array([cov, cov])
    update_models(f._unit, group, f.models, means, covs, np.array([0.5, 0.5]))
    h = np.hstack([group.jacobian(mean[:4]), np.zeros((len(rows), 1))])
    nu = np.angle(np.exp(1j * (group.values - group.predict(mean[:4]))))
    s_cov = h @ cov @ h.T + group.covariance
    gain = cov @ h.T @ np.linalg.inv(s_cov)
    np.testing.assert_allclose(means[1], mean + gain @ nu, rtol=1e-9)
    np.testing.assert_allclose(covs[1], cov - gain @ s_cov @ gain.T, rtol=1e-7, atol=1e-12)


@pytest.mark.long
def test_the_imm_start_is_judged_by_its_profile_likelihood():
    """Run 63 of the benchmark's seed 1: the 59-s window meets the IMM's 0.1 of the range by
    its linearised covariance (NEES 227 at the start) but its profile likelihood spans twice
    the range; judged by the likelihood, the IMM starts later and stays within a few km where
    the old start (still available) wandered 24 km off."""
    from tmakit.tracking import BatchInitiator

    ss = np.random.SeedSequence(1).spawn(64)[63]
    sim = tk.load_scenario("hoerst2010").simulate(np.random.default_rng(ss))
    meas = sim.take(np.flatnonzero(sim.kind == "bearing"))
    tr = tk.track(meas, "imm")
    start = tr.extra.start
    assert start["rejected"] and "nis" not in start["rejected"][0]
    assert start["rejected"][0]["relative_position_std"] > 1.0  # wider than the range
    assert start["time"] > start["rejected"][-1]["time"]
    old = tk.track(meas, "imm", initiator=BatchInitiator(max_relative_std=START_RELATIVE_STD))
    assert old.extra.start["time"] == start["rejected"][0]["time"]
    assert not old.extra.start["rejected"]
    keep = old.times >= tr.times[0]
    e_new = np.sqrt(position_errors(tr, meas)[0])
    e_old = np.sqrt(position_errors(old, meas)[0][keep])
    assert np.sqrt(np.mean(e_new**2)) < 2000.0 < 5000.0 < np.sqrt(np.mean(e_old**2))


def test_tma_track_imm_estimated_turn_rate(obs):
    result = runner.invoke(app, ["track", str(obs), "--filter", "imm", "--turn-rate", "none",
                                 "--turn-rate-noise", "0.02", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [m["turn_rate"] for m in data["models"]] == [0.0, None]
    assert data["models"][1]["rate_noise"] == pytest.approx(np.radians(0.02))
    assert "rate_noise" not in data["models"][0]
    mu = np.asarray(data["model_probabilities"])
    assert mu.shape == (len(data["time"]), 2)
    np.testing.assert_allclose(mu.sum(axis=1), 1.0)
    for args, words in ((["--filter", "imm", "--turn-rate-noise", "fast"],
                         "--turn-rate-noise 'fast'"),
                        (["--filter", "imm", "--turn-rate-noise", "-1"], "random walk >= 0"),
                        (["--filter", "mmpf", "--turn-rate-noise", "0.02"],
                         "only to --filter imm")):
        result = runner.invoke(app, ["track", str(obs), *args])
        assert result.exit_code == 2 and words in result.output, result.output
        assert "Traceback" not in result.output


@pytest.mark.long
def test_imm_with_an_estimated_turn_rate_is_consistent_through_the_turn():
    """Three seeded hoerst2010 runs with the turn-rate model beside the default bank: no
    divergence, the truth inside the 95 % ellipse in >= 90 % of the (run, step) pairs, the
    estimated rate turns right in the turn (the target's -0.57 deg/s) and is near 0 on the
    first leg, and the smoother carries it."""
    inside, filtered, smoothed = [], [], []
    for seed in (1, 2, 3):
        meas = hoerst_bearings(seed)
        tr = tk.track(meas, "imm", settings={"rate_noise": 3e-4, "history": True})
        assert nis_verdict(tr) == ""
        j = [m["turn_rate"] for m in tr.extra.models].index(None)
        rates = np.degrees([s.means[j, -1] for s in tr.extra.history.steps])
        times = np.array([s.time for s in tr.extra.history.steps])
        turn, first_leg = (np.mean(rates[(times > a) & (times < b)])
                           for a, b in ((500, 600), (300, 380)))
        assert turn < -0.1 and turn < first_leg, (turn, first_leg)
        e2, d2 = position_errors(tr, meas)
        inside.append(d2 < 5.991)
        filtered.append(e2)
        smoothed.append(position_errors(smooth(tr), meas)[0])
    assert np.mean(np.concatenate(inside)) >= 0.90
    assert np.mean(np.concatenate(smoothed)) < np.mean(np.concatenate(filtered))
