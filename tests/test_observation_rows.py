"""The observation core (tmakit.observation.rows): one way rows become predictions, Jacobians,
noise covariance and nuisance structure, vectorised over states and sensor poses; the kinds'
hooks (value range, correlated noise)."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.measurements import KINDS, RangeDifference, range_difference_covariance
from tmakit.observation import MeasurementGroup, NoiseModel, ObservationModel


def test_value_ranges_are_hooks_on_the_kinds():
    # What the file checker reports (tmakit.io) comes from the kinds.
    assert KINDS["bearing"].describe_values() == "a bearing within [-360, 360] deg"
    assert KINDS["elevation"].describe_values() == "an elevation within [-90, 90] deg"
    assert KINDS["frequency"].describe_values() == "a frequency within (0, 1e+15] Hz"
    assert KINDS["range"].describe_values() == "a range within [0, 1000000000] m"
    v = np.array([-400.0, -360.0, -90.0, 0.0, 1.0, 360.0, 361.0])
    assert KINDS["bearing"].check_values(v).tolist() == [0, 1, 1, 1, 1, 1, 0]
    assert KINDS["elevation"].check_values(v).tolist() == [0, 0, 1, 1, 1, 0, 0]
    assert KINDS["frequency"].check_values(v).tolist() == [0, 0, 0, 0, 1, 1, 1]
    assert KINDS["range"].check_values(v).tolist() == [0, 0, 0, 1, 1, 1, 1]
    assert KINDS["range_rate"].describe_values() == (
        "a range rate within [-299792458, 299792458] m/s")  # the speed of light
    assert KINDS["power"].check_values(np.array([-400.0, 400.0, 401.0])).tolist() == [1, 1, 0]
    assert not KINDS["range_difference"].check_values(np.array([1e300])).any()
    assert KINDS["azimuth_rate"].describe_values() is None
    assert KINDS["azimuth_rate"].check_values(v).all()


def test_correlated_noise_is_a_hook_on_the_kind():
    meas = tk.load_scenario("chen-sun-1").simulate(noise=False)
    rows = meas.take(np.flatnonzero(meas.time <= 3.0))
    group = MeasurementGroup(rows, 3.0, 3)
    rd = group.index["range_difference"]
    expected = np.diag(rows.sigma_si**2)
    expected[np.ix_(rd, rd)] = range_difference_covariance(
        rows.time[rd], rows.time_ref[rd], rows.sigma_si[rd], rows.sensor[rd])
    assert np.array_equal(group.covariance, expected)
    assert RangeDifference.correlated_noise and not KINDS["bearing"].correlated_noise
    # The group's whitening equals the set's.
    eye = np.eye(len(rows))
    assert np.array_equal(group.noise.whiten(eye, axis=0), NoiseModel(rows).whiten(eye, axis=0))


@pytest.mark.parametrize("name", ["gu2007", "chen-sun-1"])
def test_sensor_poses_vectorise_like_a_loop(name):
    scn = tk.load_scenario(name)
    meas = scn.simulate(noise=False)
    dim = 3 if name == "chen-sun-1" else 2
    t = float(meas.time[5])
    group = MeasurementGroup(meas.take(np.flatnonzero(np.abs(meas.time - t) < 1.5)), t, dim,
                             scn.measurement_options, scn.nuisance)
    x = scn.target_states([t])[0][[0, 1, 2, 3, 4, 5] if dim == 3 else [0, 1, 3, 4]]
    rng = np.random.default_rng(3)
    states = x + rng.standard_normal((4, 2 * dim)) * 100.0
    poses = group.sensor_state + rng.standard_normal((5, 1, 1, 6)) * 300.0  # (C, 1, m, 6)
    pred = group.predict(states, poses)
    jac = group.jacobian(states, poses)
    info = group.information(states, poses)
    assert pred.shape == (5, 4, len(group)) and jac.shape == (5, 4, len(group), 2 * dim)
    for c in range(5):
        for i in range(4):
            assert np.array_equal(pred[c, i], group.predict(states[i], poses[c, 0]))
            assert np.allclose(jac[c, i], group.jacobian(states[i], poses[c, 0]),
                               rtol=1e-13, atol=0.0)
            w = group.noise.whiten(group.jacobian(states[i], poses[c, 0]), axis=-2)
            assert np.allclose(info[c, i], w.T @ w, rtol=1e-12, atol=0.0)
    # No pose given: the recorded ones.
    assert np.array_equal(group.predict(states), group.predict(states, group.sensor_state))


def test_the_batch_and_filter_views_agree():
    """ObservationModel (motion parameters) and MeasurementGroup (filter state) predict the
    same rows alike: both go through the one row core."""
    scn = tk.load_scenario("chen-sun-1")
    meas = scn.simulate(noise=False)
    t = float(meas.time.max())
    motion = tk.ConstantVelocity(3, ref_time=t)
    x = scn.target_states([t])[0]
    obs = ObservationModel(meas, motion)
    group = MeasurementGroup(meas, t, 3)
    assert np.allclose(obs.predict(x), group.predict(x), rtol=1e-12, atol=1e-9)
    j_theta, _ = obs.jacobian(x)
    assert np.allclose(j_theta, group.jacobian(x), rtol=1e-9, atol=1e-15)
    assert obs.row_model.nuisance_names == group.row_model.nuisance_names == ()


def test_a_planned_group_needs_no_rows():
    group = MeasurementGroup.planned(["bearing", "frequency"], [0.01, 1.0], 10.0, 2,
                                     nuisance={"carrier": 1e9})
    assert len(group) == 2 and group.time == 10.0 and np.isnan(group.values).all()
    pose = np.array([1000.0, 0.0, 0.0, 0.0, 10.0, 0.0])
    h = group.jacobian(np.array([0.0, 5000.0, 5.0, 0.0]), pose)
    assert h.shape == (2, 4) and np.isfinite(h).all()
    with pytest.raises(ValueError, match="planned group has no measurement rows"):
        group.rows  # noqa: B018


@pytest.mark.parametrize("dim", [2, 3])
def test_affine_rows_single_equals_the_dense_product_and_the_motion_model(dim):
    from tmakit.motion import ConstantVelocity, Stationary
    from tmakit.observation.affine_rows import AffineRows

    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0, 300, 50))
    sensor = rng.normal(0, 1000, (50, 6))
    for motion in (ConstantVelocity(dim, ref_time=40.0), Stationary(dim)):
        terms, offset = motion.component_terms(t)
        matrix = motion.jacobian(np.zeros(motion.n_params), t).transpose(2, 1, 0)
        dense = np.zeros_like(matrix)
        for i, c, coef in terms:
            dense[i, c] = 1.0 if coef is None else coef
        assert np.array_equal(dense, matrix)
        assert np.array_equal(offset, motion.states(np.zeros(motion.n_params), t).T)
        rows = AffineRows(terms, offset - sensor.T, motion.n_params)
        theta = rng.normal(0, 500, motion.n_params)
        want = motion.states(theta, t) - sensor
        one = rows.single(theta)
        batch = (theta[None] @ rows.matrix + rows.flat_offset).reshape(6, -1).T
        assert one.shape == (50, 6) and rows.single(theta[None]).shape == (1, 50, 6)
        assert np.allclose(one, want, rtol=1e-13, atol=1e-9)
        assert np.allclose(batch, want, rtol=1e-13, atol=1e-9)
        sub = rows.take(np.array([3, 7, 7, 20]))
        assert np.array_equal(sub.single(theta), one[[3, 7, 7, 20]])
        # east and north alone (constant velocity: both rows by one product and one sum) are
        # the same bits as term by term
        assert np.array_equal(rows.single(theta, components=2), one.T[:2])
        assert np.array_equal(sub.single(theta, components=2), one[[3, 7, 7, 20]].T[:2])
