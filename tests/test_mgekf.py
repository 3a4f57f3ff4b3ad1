"""The modified-gain EKF and the multi-lag vectors of Chen & Sun,
and the chen-sun reproduction."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.filters import FILTERS, ExtendedKalmanFilter, MeasurementGroup
from tmakit.filters.mgekf import (
    ModifiedGainEKF,
    ReflectingEKF,
    modified_gain_rows,
)
from tmakit.filters.multilag import multilag_groups
from tmakit.reproduce import chen_sun


def test_gain_rows_are_the_papers_formula_in_tmakits_bearing_convention():
    # Hand case: state at t, a bearing row taken 5 s earlier (dt = -N T, N T = 5 s).
    x_hat = np.array([3000.0, 4000.0, 1000.0, 10.0, -20.0, 0.0])
    sensor = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    dt = -5.0
    rel = np.array([3000.0 - 50.0, 4000.0 + 100.0, 1000.0, 10.0, -20.0, 0.0]) - sensor
    b_hat = np.arctan2(rel[0], rel[1])               # clockwise from North
    b_m = b_hat + 0.01                                # measured bearing
    r = b_m - b_hat
    # Chen & Sun, §2.3 in tmakit's convention: H = [cos b, -sin b, 0, dt cos b, -dt sin b, 0],
    # g = -(b_m - h(X^)) / (H X^') H, U = 1 / (1 - mu).
    c, s = np.cos(b_m), np.sin(b_m)
    h_row = np.array([c, -s, 0.0, dt * c, -dt * s, 0.0])
    denom = c * rel[0] - s * rel[1]
    g_paper = -r / denom * h_row
    mod = modified_gain_rows([b_m], rel[None], [dt], 3, [r], mu=[0.25])
    assert mod.ok[0]
    assert mod.denominator[0] == pytest.approx(denom, rel=1e-12)
    np.testing.assert_allclose(mod.g[0], g_paper / 0.75, rtol=1e-10, atol=1e-18)
    assert mod.u[0] == pytest.approx(1 / 0.75)
    # A 2-D state [x, y, vx, vy]: the same row without the z and vz columns.
    mod2 = modified_gain_rows([b_m], rel[None], [dt], 2, [r], mu=[0.25])
    np.testing.assert_allclose(mod2.g[0], mod.g[0][[0, 1, 3, 4]], rtol=1e-12)
    # The paper's own convention (theta from the x-axis, theta = pi/2 - b, its printed
    # H = [sin th, -cos th, 0, -NT sin th, NT cos th, 0]) gives the same row with the
    # opposite sign, as the angle runs the other way: the same linear relation.
    th_m, th_hat = np.pi / 2 - b_m, np.pi / 2 - b_hat
    x_rel = x_hat - sensor  # the paper's X^' (state at k relative to the receiver)
    assert h_row @ x_rel == pytest.approx(denom, rel=1e-12)
    h_paper = np.array([np.sin(th_m), -np.cos(th_m), 0.0, -5 * np.sin(th_m),
                        5 * np.cos(th_m), 0.0])
    g_their = -(th_m - th_hat) / (h_paper @ x_rel) * h_paper
    np.testing.assert_allclose(-g_their, g_paper, rtol=1e-10, atol=1e-18)
    # With the noise-free bearing of a true state, g (X - X^) equals the residual exactly.
    x_true = x_hat + np.array([400.0, -900.0, 300.0, 5.0, 8.0, 1.0])
    rel_true = x_true[:3] + dt * x_true[3:]
    b_true = np.arctan2(rel_true[0], rel_true[1])
    exact = modified_gain_rows([b_true], rel[None], [dt], 3, [b_true - b_hat])
    assert exact.g[0] @ (x_true - x_hat) == pytest.approx(b_true - b_hat, rel=1e-10)


def test_gain_rows_fall_back_when_unsafe():
    rel = np.array([[0.0, 0.0, 1000.0, 0, 0, 0],       # target above the sensor: H X^' = 0
                    [1000.0, 1000.0, 0.0, 0, 0, 0],     # fine
                    [1000.0, 1000.0, 0.0, 0, 0, 0],     # measured 180 deg off the prediction
                    [1000.0, 1000.0, 0.0, 0, 0, 0]])    # 1 - mu ~ 0
    b_hat = np.arctan2(rel[:, 0], rel[:, 1])
    r = np.array([0.01, 0.01, 3.0, 0.01])
    mod = modified_gain_rows(b_hat + r, rel, np.zeros(4), 3, r, mu=[0, 0, 0, 1 - 1e-6])
    np.testing.assert_array_equal(mod.ok, [False, True, False, False])
    assert np.all(np.isfinite(mod.g)) and np.all(mod.u[~mod.ok] == 1.0)


def _chen_sun_group(k: int, lags=(3, 7, 12)):
    scn = tk.load_scenario("chen-sun-1")
    meas = scn.simulate(noise=False)
    t, rows = multilag_groups(meas, lags)[k]
    return scn, t, rows


def test_mgekf_equals_ekf_when_the_measurements_equal_their_predictions():
    scn, t, rows = _chen_sun_group(20)
    truth = scn.target_states([t])[0]
    cov = np.diag([3e6, 3e6, 3e6, 1e4, 1e4, 1e4])
    ekf = ExtendedKalmanFilter(truth, cov, t, q=(20.0, 20.0, 10.0))
    mg = ModifiedGainEKF(truth, cov, t, q=(20.0, 20.0, 10.0), gain="paper")
    i_e, i_m = ekf.update(rows), mg.update(rows)  # residuals 0: mu -> 0, g -> EKF rows
    np.testing.assert_allclose(mg.state, ekf.state, rtol=0, atol=1e-9)
    np.testing.assert_allclose(mg.covariance, ekf.covariance, rtol=1e-9, atol=1e-9)
    assert i_m.nis == pytest.approx(i_e.nis, abs=1e-12) and mg.fallbacks == 0
    # ...and differs once the bearings disagree with the prediction.
    off = truth + np.array([2000.0, -3000.0, 1000.0, 0, 0, 0])
    ekf = ExtendedKalmanFilter(off, cov, t, q=(20.0, 20.0, 10.0))
    mg = ModifiedGainEKF(off, cov, t, q=(20.0, 20.0, 10.0), gain="paper")
    ekf.update(rows)
    mg.update(rows)
    assert np.linalg.norm(mg.state[:3] - ekf.state[:3]) > 1.0


def test_multilag_vector_layout_and_noise_covariance():
    scn = tk.load_scenario("chen-sun-1")
    meas = scn.simulate(rng=np.random.default_rng(5))
    sub = meas.take(meas.time <= 12.0)
    lags = (2, 5, 9)
    groups = multilag_groups(sub, lags)
    assert [t for t, _ in groups] == [float(k) for k in range(13)]
    t, rows = groups[10]   # samples 10, 8, 5, 1
    bear = rows.select(kind="bearing")
    np.testing.assert_array_equal(np.sort(bear.time), [1.0, 5.0, 8.0, 10.0])
    rd = rows.select(kind="range_difference")
    order = np.argsort(rd.time)[::-1]
    np.testing.assert_array_equal(rd.time[order], [10.0, 8.0, 5.0])
    np.testing.assert_array_equal(rd.time_ref[order], [8.0, 5.0, 1.0])
    lag1 = sub.select(kind="range_difference")
    for a, b, value in zip(rd.time[order], rd.time_ref[order], rd.value[order], strict=True):
        spans = (lag1.time <= a) & (lag1.time_ref >= b)
        assert value == pytest.approx(np.sum(lag1.value[spans]), abs=1e-9)
    # R_k = diag[s_b^2 x 4, N s^2, I s^2, J s^2] with N, I, J = 2, 3, 4 intervals.
    group = MeasurementGroup(rows, t, 3)
    s_b, s_r = np.radians(0.11459155902616465), 5.0
    expected = np.where(rows.kind == "bearing", s_b**2, 0.0)
    expected[rows.kind == "range_difference"] = (
        (rows.time - rows.time_ref)[rows.kind == "range_difference"] * s_r**2)
    np.testing.assert_allclose(group.covariance, np.diag(expected), rtol=1e-12, atol=1e-20)
    # Before k - N3 exists: lags clipped to the first sample (k = 3: samples 3, 1, 0).
    assert sorted(groups[3][1].select(kind="bearing").time) == [0.0, 1.0, 3.0]
    rd3 = groups[3][1].select(kind="range_difference")
    spans = sorted(zip(rd3.time.tolist(), rd3.time_ref.tolist(), strict=True))
    assert spans == [(1.0, 0.0), (3.0, 1.0)]
    # Reuse inflation: an interior bearing is used by len(lags) + 1 vectors.
    infl = dict(multilag_groups(meas.take(meas.time <= 40.0), lags, reuse_inflation=True))
    b20 = infl[20.0].select(kind="bearing")
    assert b20.sigma[b20.time == 20.0][0] == pytest.approx(2.0 * 0.11459155902616465)
    for bad in ((3, 2), (0, 4), (1.5, 3)):
        with pytest.raises(ValueError, match="lags"):
            multilag_groups(sub, bad)


def test_mirror_reflection_only_while_the_data_cannot_tell_the_sides_apart():
    scn, t, rows = _chen_sun_group(30)
    truth = scn.target_states([t])[0]
    mirrored = truth * np.array([1, 1, -1, 1, 1, -1])
    group = MeasurementGroup(rows, t, 3)
    np.testing.assert_allclose(group.predict(mirrored), group.predict(truth), atol=1e-9)
    assert rows.mirror_plane() == 0.0
    cov = np.diag([1e6, 1e6, 1e6, 1e2, 1e2, 1e2])
    cov[2, 5] = cov[5, 2] = 50.0
    for reflect in (True, False):
        f = ModifiedGainEKF(mirrored, cov, t, q=(20.0, 20.0, 10.0), reflect=reflect)
        f.update(rows)
        assert (f.state[2] > 0) == reflect and f.reflections == int(reflect)
        assert np.min(np.linalg.eigvalsh(f.covariance)) > 0
    # An elevation breaks the symmetry: no reflection from then on.
    elev = tk.MeasurementSet([t], ["r-station"], ["elevation"], [-5.0], [1.0],
                             rows.sensor_state[:1])
    assert elev.mirror_plane() is None
    f = ReflectingEKF(mirrored, cov, t, q=(20.0, 20.0, 10.0))
    f.update(elev)
    f.update(rows)
    assert f.reflections == 0


def test_mgekf_tracks_chen_sun_path_1_from_the_papers_start():
    # Seeded: 4 runs of the modified-gain EKF (multi-lag vectors, reuse-inflated R) from the
    # initial guess of Chen & Sun, §2.5 (about 5 km off along the line of sight and in height).
    # Each ends within 1 km horizontally (the 30-run RMS is ~0.3 km, the start 5.1 km).
    res = chen_sun.monte_carlo_path(1, runs=4, seed=3, filters=("mgekf-inflated",))
    err = res["mgekf-inflated"]["errors"]
    start = np.hypot(err[:, 0, 0], err[:, 0, 1])
    final = np.hypot(err[:, -1, 0], err[:, -1, 1])
    assert np.all(start > 4000.0)
    assert np.all(final < 1000.0), final
    assert np.all(np.abs(err[:, -1, 2]) > np.maximum(np.abs(err[:, -1, 0]),
                                                     np.abs(err[:, -1, 1])))  # z worst
    assert np.all(res["mgekf-inflated"]["fallbacks"] == 0)


def test_chen_sun_reproduction_finds_path_2_poorly_observable():
    rep = chen_sun.run(runs=0)
    assert rep.figures["poorly_observable_paths"] == [2]
    z = rep.figures["crlb_z_std_end_m"]
    assert z["path 2"] > 5 * max(z["path 1"], z["path 3"])


def test_registered_and_bad_options_refused():
    assert FILTERS["mgekf"] is ModifiedGainEKF
    with pytest.raises(ValueError, match="gain"):
        ModifiedGainEKF(np.zeros(4), np.eye(4), gain="fast")
    meas = tk.load_scenario("chen-sun-1").simulate(noise=False)
    with pytest.raises(ValueError, match="range_guess"):
        chen_sun.initial_state(meas, range_guess=10e3, height_guess=15e3)


def test_song_speyer_gain_moves_the_state_as_the_ekf_and_updates_p_with_the_modified_rows():
    scn, t, rows = _chen_sun_group(25)
    truth = scn.target_states([t])[0]
    off = truth + np.array([2000.0, -3000.0, 1000.0, 20.0, 0.0, 0.0])
    cov = np.diag([3e6, 3e6, 3e6, 1e4, 1e4, 1e4])
    ekf = ExtendedKalmanFilter(off, cov, t)
    ss = ModifiedGainEKF(off, cov, t, gain="song-speyer")
    ekf.update(rows)
    ss.update(rows)
    np.testing.assert_allclose(ss.state, ekf.state, rtol=0, atol=1e-6)
    assert not np.allclose(ss.covariance, ekf.covariance, rtol=1e-6)
    assert np.min(np.linalg.eigvalsh(ss.covariance)) > 0


def test_cli_reproduce_chen_sun_observability_only():
    from typer.testing import CliRunner

    from tmakit.cli import app

    result = CliRunner().invoke(app, ["reproduce", "chen-sun", "--runs", "0"])
    assert result.exit_code == 0, result.output
    assert "POORLY" in result.output and "poorly observable paths: 2" in result.output
    assert "garbled" in result.output  # the initial-guess reading is stated
