"""Stone Soup interoperability: detections both ways, analytic models, a tracker started by
tmakit's no-guess batch estimate."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.data import MeasurementSet

pytest.importorskip("stonesoup")

from stonesoup.dataassociator.neighbour import NearestNeighbour
from stonesoup.deleter.error import CovarianceBasedDeleter
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.measures import Mahalanobis
from stonesoup.models.measurement.nonlinear import (
    Cartesian2DToBearing,
    CartesianToBearingRange,
    CartesianToElevationBearingRange,
)
from stonesoup.models.transition.linear import (
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
)
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.tracker.simple import SingleTargetTracker
from stonesoup.types.detection import Detection
from stonesoup.types.state import State
from stonesoup.updater.kalman import ExtendedKalmanUpdater

from tmakit.interop.stonesoup import (
    EPOCH,
    BatchInitiator,
    BearingInitiator,
    TmakitMeasurementModel,
    detection_feed,
    from_detections,
    to_detections,
)


def wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a, dtype=float)))


def stone_soup_state(x, dim):
    """tmakit [x, y(, z), vx, vy(, vz)] -> Stone Soup [x, vx, y, vy(, z, vz)]."""
    sv = np.empty(2 * dim)
    sv[0::2], sv[1::2] = x[:dim], x[dim:]
    return State(sv[:, None])


def central_differences(model, state, step=0.5):
    """d function / d state by central differences (steps of 0.5 m and 0.5 m/s), angles wrapped."""
    x = np.asarray(state.state_vector, float)[:, 0]
    cols = []
    for i in range(x.size):
        e = np.zeros(x.size)
        e[i] = step
        up = np.asarray(model.function(State((x + e)[:, None])), float)[:, 0]
        down = np.asarray(model.function(State((x - e)[:, None])), float)[:, 0]
        d = up - down
        d[model.group.angle] = wrapped(d[model.group.angle])
        cols.append(d / (2 * step))
    return np.column_stack(cols)


def test_detections_round_trip_every_column():
    meas = tk.load_scenario("gu2007").simulate(rng=4)  # frequency + power, one UAV
    nuisance = {"carrier": 1.9e9, "power_constant_db": -38.0}
    dets = to_detections(meas, nuisance=nuisance)
    assert len(dets) == np.unique(meas.time).size
    assert all(len(d.state_vector) == 2 for d in dets)  # both kinds of one time together
    assert dets[0].timestamp == EPOCH + (dets[0].timestamp - EPOCH)
    back = from_detections(dets)
    for name in ("time", "sensor", "kind", "sigma_si", "sensor_state"):
        np.testing.assert_array_equal(getattr(back, name), getattr(meas, name))
    np.testing.assert_allclose(back.value_si, meas.value_si, rtol=1e-15)


def test_bearings_round_trip_modulo_a_turn_and_per_sensor_detections():
    meas = tk.load_scenario("chen-sun-1").simulate(rng=2)  # bearing + range differences, 3-D
    dets = to_detections(meas, per_sensor=True)
    back = from_detections(dets)
    np.testing.assert_array_equal(back.kind, meas.kind)
    np.testing.assert_allclose(back.time_ref, meas.time_ref, equal_nan=True)
    diff = back.value_si - meas.value_si
    angle = meas.kind == "bearing"
    np.testing.assert_allclose(wrapped(diff[angle]), 0.0, atol=1e-12)
    np.testing.assert_allclose(diff[~angle], 0.0, atol=1e-9)


@pytest.mark.parametrize("scenario, nuisance", [
    ("bearings-only-2d", None),
    ("gu2007", {"carrier": 1.9e9, "power_constant_db": -38.0}),
    ("hurtado2008", None),  # bearing, range, range rate
    ("doppler-lecture", {"carrier": 1.0e10}),  # frequency, 3-D
    ("chen-sun-1", None),  # bearing + range difference to an earlier pulse, 3-D
])
def test_model_predicts_like_tmakit_with_an_analytic_jacobian(scenario, nuisance, monkeypatch):
    scn = tk.load_scenario(scenario)
    meas = scn.simulate(rng=1)
    dim = scn.motion.dim  # the target's (chen-sun: 3-D, though its data alone say 2-D)
    rows = meas.take(np.flatnonzero(meas.time == meas.time[len(meas) // 2]))
    model = TmakitMeasurementModel.from_rows(rows, dim, nuisance=nuisance)
    x = scn.target_states(rows.time[:1])[0]
    x = np.concatenate([x[:dim], x[3:3 + dim]]) + np.linspace(50.0, 90.0, 2 * dim)
    state = stone_soup_state(x, dim)
    group = tk.observation.MeasurementGroup(rows, float(rows.time[0]), dim, None, nuisance)
    z = np.asarray(model.function(state), float)[:, 0]  # angles wrapped, the rest as is
    np.testing.assert_allclose(group.residual(group.predict(x), z), 0.0, atol=1e-9)
    np.testing.assert_array_equal(z[~group.angle], group.predict(x)[~group.angle])
    analytic = model.jacobian(state)
    fd = central_differences(model, state)
    np.testing.assert_allclose(analytic, fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())
    # analytic: the Jacobian never evaluates the function
    monkeypatch.setattr(TmakitMeasurementModel, "function",
                        lambda *a, **k: pytest.fail("Jacobian by finite differences"))
    np.testing.assert_array_equal(model.jacobian(state), analytic)


def test_stone_soup_native_detections_become_tmakit_rows():
    truth = np.array([3000.0, 4000.0, 120.0, -5.0, 8.0, 0.0])  # tmakit order, 3-D
    sensor = np.array([200.0, -100.0, 10.0])
    ss_truth = State(truth[[0, 3, 1, 4, 2, 5], None])
    models = [
        Cartesian2DToBearing(ndim_state=6, mapping=(0, 2), noise_covar=np.diag([1e-4]),
                             translation_offset=sensor[:2, None]),
        CartesianToBearingRange(ndim_state=6, mapping=(0, 2), noise_covar=np.diag([1e-4, 25.0]),
                                translation_offset=sensor[:2, None]),
        CartesianToElevationBearingRange(ndim_state=6, mapping=(0, 2, 4),
                                         noise_covar=np.diag([1e-4, 2e-4, 25.0]),
                                         translation_offset=sensor[:, None]),
    ]
    dets = [Detection(m.function(ss_truth), timestamp=EPOCH, measurement_model=m,
                      metadata={"sensor": "ship"}) for m in models]
    meas = from_detections(dets)
    assert sorted(meas.kinds) == ["bearing", "elevation", "range"] and meas.sensors == ["ship"]
    for k, d in enumerate(dets):
        rows = from_detections([d])
        flat = rows.sensor_state.copy()
        if k < 2:  # 2-D models: the sensor and the target in the plane
            flat[:, 2] = 0.0
        target = truth.copy()
        if k < 2:
            target[2] = 0.0
        group = tk.observation.MeasurementGroup(
            tk.MeasurementSet.from_si(rows.time, rows.sensor, rows.kind, rows.value_si,
                                      rows.sigma_si, flat), 0.0, 3)
        predicted = group.predict(np.concatenate([target[:3], target[3:]]))
        np.testing.assert_allclose(group.residual(predicted), 0.0, atol=1e-9)
        np.testing.assert_allclose(rows.sigma_si, np.sqrt(np.diag(d.measurement_model.covar())))


def test_native_detections_refused_when_tmakit_cannot_read_them():
    rotated = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([1e-4]),
                                   rotation_offset=np.array([[0.0], [0.0], [0.3]]))
    det = Detection(rotated.function(State(np.array([[1.0], [0.0], [1.0], [0.0]]))),
                    timestamp=EPOCH, measurement_model=rotated)
    with pytest.raises(ValueError, match=r"detection 0 \(t = 0 s\): a rotation_offset"):
        from_detections([det])
    correlated = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                         noise_covar=np.array([[1e-4, 1e-3], [1e-3, 25.0]]))
    det = Detection(correlated.function(State(np.array([[1.0], [0.0], [1.0], [0.0]]))),
                    timestamp=EPOCH, measurement_model=correlated)
    with pytest.raises(ValueError, match="correlated measurement noise"):
        from_detections([det])
    with pytest.raises(ValueError, match="one time"):
        meas = tk.load_scenario("bearings-only-2d").simulate(rng=1)
        TmakitMeasurementModel.from_rows(meas.take([0, 1, 2]), 2)


def test_stone_soup_ekf_tracker_started_by_the_batch_estimate():
    scn = tk.load_scenario("bearings-only-2d")  # 600 bearings, 1 Hz, 1 deg, zig-zag observer
    meas = scn.simulate(rng=1)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.0)] * 2)
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)  # each detection brings its model
    initiator = BatchInitiator(dim=2)
    tracker = SingleTargetTracker(
        initiator=initiator, deleter=CovarianceBasedDeleter(covar_trace_thresh=1e12),
        detector=detection_feed(to_detections(meas)),
        data_associator=NearestNeighbour(DistanceHypothesiser(predictor, updater, Mahalanobis(),
                                                              missed_distance=np.inf)),
        updater=updater)
    for _ in tracker:
        pass
    (track,) = tracker.tracks
    start = (track.states[0].timestamp - EPOCH).total_seconds()
    assert initiator.estimate.status == "converged" and 8 <= start < 599
    assert (track.state.timestamp - EPOCH).total_seconds() == 600.0
    assert len(track) == 600 - start + 1  # then one EKF update per bearing
    # consistent with the truth at the end
    truth = scn.target_states(np.array([600.0]))[0]
    err = np.asarray(track.state.state_vector, float)[:, 0] - [truth[0], truth[3], truth[1],
                                                               truth[4]]
    nees = err @ np.linalg.solve(np.asarray(track.state.covar, float), err)
    assert nees < 18.47  # chi-square(4) 99.9 % quantile
    # and where tmakit's own EKF (q = 0 too, its own batch start) ends: within 0.1 std (its
    # start covariance is widened to the window's profile likelihood, position x1.89 and
    # velocity x1.11 here, Stone Soup's is the fit's linearised one: 0.06 std apart at the end)
    own = tk.track(meas, "ekf", q=0.0)
    ss = np.asarray(track.state.state_vector, float)[[0, 2, 1, 3], 0]
    assert np.all(np.abs(ss - own.states[-1]) < 0.1 * own.std[-1])


def test_log_likelihood_of_many_states_is_the_wrapped_gaussian():
    from scipy.stats import multivariate_normal
    from stonesoup.types.array import StateVectors

    meas = tk.load_scenario("hurtado2008").simulate(rng=1)  # bearing, range, range rate
    det = to_detections(meas)[10]
    model = det.measurement_model
    states = np.array([[-2000.0, 25, 15000, 0], [-2100, 24, 15100, 1], [-1900, 26, 14900, -1]]).T
    got = model.logpdf(det, State(StateVectors(states)))
    z = np.asarray(det.state_vector, float)[:, 0]
    for k in range(3):
        r = z - np.asarray(model.function(State(states[:, k:k + 1])), float)[:, 0]
        r[model.group.angle] = wrapped(r[model.group.angle])
        assert got[k] == pytest.approx(multivariate_normal.logpdf(r, cov=model.covar()),
                                       rel=1e-12)
    assert model.pdf(det, State(states[:, :1])) == pytest.approx(np.exp(got[0]), rel=1e-12)
    draws = np.asarray(model.rvs(20000, random_state=3), float)
    cov = np.asarray(model.covar(), float)  # independent rows
    np.testing.assert_allclose(np.var(draws, axis=1), np.diag(cov), rtol=0.05)
    assert np.all(np.abs(np.corrcoef(draws)[np.triu_indices(3, 1)]) < 0.03)


def test_a_model_for_kinds_agrees_with_stone_soups_own_bearing_range_rate_model():
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRangeRate2D

    sensor = np.array([200.0, -100.0, 0.0, 3.0, 4.0, 0.0])
    sigmas = [np.radians(1.0), 10.0, 0.5]
    ours = TmakitMeasurementModel.for_kinds(["bearing", "range", "range_rate"], sigmas, sensor,
                                            sensor="ship")
    theirs = CartesianToBearingRangeRate2D(
        ndim_state=4, mapping=(0, 2), velocity_mapping=(1, 3), noise_covar=np.diag(sigmas) ** 2,
        translation_offset=sensor[:2, None], velocity=sensor[3:5, None])
    target = State(np.array([[3000.0], [-5.0], [4000.0], [8.0]]))
    b, r, rr = np.asarray(ours.function(target), float)[:, 0]
    phi, rho, rate = np.asarray(theirs.function(target), float)[:, 0]
    assert wrapped(0.5 * np.pi - b - phi) == pytest.approx(0.0, abs=1e-12)  # clockwise from N
    assert (r, rr) == pytest.approx((rho, rate), rel=1e-12)
    np.testing.assert_allclose(ours.covar(), theirs.covar())
    det = Detection(ours.function(target), timestamp=EPOCH, measurement_model=ours)
    assert from_detections([det]).sensors == ["ship"]


def _with_clutter(meas, seed=3):
    """The set with one uniform clutter bearing half a second after each true one."""
    n = len(meas)
    clutter = MeasurementSet.from_si(
        meas.time + 0.5, ["own ship"] * n, ["bearing"] * n,
        np.random.default_rng(seed).uniform(-np.pi, np.pi, n), meas.sigma_si, meas.sensor_state)
    both = MeasurementSet.concatenate([meas, clutter])
    return both.take(np.argsort(both.time, kind="stable"))


def _feed(initiator, meas):
    """Give the initiator the detections time by time; return its track, or None."""
    for time, dets in detection_feed(to_detections(meas)):
        tracks = initiator.initiate(dets, time)
        if tracks:
            return next(iter(tracks))
    return None


@pytest.mark.parametrize("min_window", [8, 1])
def test_batch_initiators_refuse_a_start_from_an_improbable_fit(min_window):
    # Before the chi-square test both started from fits with chi2 ~ 1.7e6 on ~340 dof, 8 km
    # off; every tmakit initiator now refuses, and says why.
    meas = _with_clutter(tk.load_scenario("bearings-only-2d").simulate(rng=1))
    initiator = BatchInitiator(dim=2, min_window=min_window)
    assert _feed(initiator, meas) is None
    assert "improbable fit" in initiator.problem and initiator.tries > 5
    with pytest.raises(tk.tracking.StartError, match=r"improbable fit.*clutter or a manoeuvre"):
        tk.track(meas, "ekf", initiator=tk.tracking.BatchInitiator(min_window=min_window))


def test_stone_soup_ekf_started_at_the_first_bearing_by_the_gaussian_sum():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=1)
    initiator = BearingInitiator(prior=tk.BearingPrior(1_000, 30_000, 15.0))
    track = _feed(initiator, meas)
    times = [(s.timestamp - EPOCH).total_seconds() for s in track.states]
    handover = initiator.track.times[-1]
    assert times[0] == meas.time[0] and times[-1] == handover < 300  # batch start: 184 s
    assert len(track.states) == np.sum(meas.time <= handover)
    # the truth inside each state's 99.9 % ellipse, from the first bearing to the handover
    truth = scn.target_states(np.asarray(times))
    for state, x in zip(track.states, truth, strict=True):
        err = np.asarray(state.state_vector, float)[:, 0] - x[[0, 3, 1, 4]]
        assert err @ np.linalg.solve(np.asarray(state.covar, float), err) < 18.47
    # a clutter bearing first: the innovations after it reject it, the next bearing starts
    bad = MeasurementSet.from_si(np.array([0.5]), ["own ship"], ["bearing"],
                                 meas.value_si[:1] + 1.5, meas.sigma_si[:1], meas.sensor_state[:1])
    other = BearingInitiator(prior=tk.BearingPrior(1_000, 30_000, 15.0))
    track = _feed(other, MeasurementSet.concatenate([bad, meas]))
    assert (track.states[0].timestamp - EPOCH).total_seconds() == meas.time[0]
    (rejected,) = other.track.extra.start["rejected"]
    assert rejected["time"] == 0.5 and rejected["p_value"] < 1e-3
    with pytest.raises(ValueError, match="BearingPrior"):
        BearingInitiator(prior=(1_000, 30_000))
