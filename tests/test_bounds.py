"""Cramér-Rao bounds and observability."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.bounds import NoiseModel, crlb
from tmakit.bounds.fim import fisher_information
from tmakit.reproduce.doppler_lecture import with_receivers
from tmakit.reproduce.gu2007 import PAPER_TABLES, crlb_tables


def test_tables_1_to_3_of_gu2007_all_36_entries_within_1e_3():
    ours = crlb_tables()
    for setting, paper in PAPER_TABLES.items():
        for name, values in paper.items():
            rel = np.abs(ours[setting][name] - np.array(values)) / np.array(values)
            assert np.all(rel < 1e-3), (setting, name, ours[setting][name])


def test_unknown_nuisance_never_gives_a_smaller_bound_than_known():
    scn = tk.load_scenario("gu2007")
    known, unknown = crlb(scn, known_nuisance=True), crlb(scn)
    assert unknown.parameters == ("x", "y", "vx", "vy", "carrier", "power_constant_db")
    assert known.parameters == ("x", "y", "vx", "vy")
    for p in known.parameters:
        assert unknown.std_of(p) >= known.std_of(p)
    # And the paper's own Monte Carlo RMS (C and f_s unknown to its estimator) is close to the
    # unknown-nuisance bound, well above the known one.
    paper_mc = dict(zip(("x", "y", "vx", "vy"), (6.2987, 7.6909, 0.1192, 0.1304), strict=True))
    for p, v in paper_mc.items():
        assert unknown.std_of(p) == pytest.approx(v, rel=0.15)
        assert known.std_of(p) < 0.8 * v


def test_fisher_information_equals_finite_difference_of_predictions():
    scn = tk.load_scenario("chen-sun-1")
    meas = scn.simulate(noise=False)
    obs = tk.ObservationModel(meas, scn.motion)
    noise = NoiseModel(meas)
    info = fisher_information(obs, scn.theta, np.zeros(0), known_nuisance=True)
    cols = []
    for j in range(6):
        h = 1e-5 * max(1.0, abs(scn.theta[j]))
        up, down = scn.theta.copy(), scn.theta.copy()
        up[j] += h
        down[j] -= h
        cols.append((obs.predict(up) - obs.predict(down)) / (2 * h))
    jac = np.column_stack(cols)
    dense = noise.covariance()
    expected = jac.T @ np.linalg.solve(dense, jac)
    assert np.allclose(info, expected, rtol=1e-5, atol=1e-7 * np.abs(expected).max())


def test_range_difference_noise_is_correlated_and_whitened_exactly():
    from tmakit.scenario.files import scenario_from_dict

    base = {"name": "rd", "target": {"motion": "cv3d", "truth": {
        "x": 5e4, "y": 6e4, "z": 1e4, "vx": -300.0, "vy": -300.0, "vz": 0.0}},
        "sensors": [{"type": "fixed", "id": "r", "position": [3e4, 0.0, 0.0]}],
        "measurements": [{"kind": "range_difference", "sensor": "r", "pri": 1.0, "sigma": 5.0,
                          "times": {"start": 0, "stop": 20, "step": 1}, "lags": [2]}]}
    meas = scenario_from_dict(base).simulate(noise=False)
    noise = NoiseModel(meas)
    assert noise.correlated
    cov = noise.covariance()
    # Direct construction: each difference is a sum of independent per-interval terms.
    intervals = [set(range(int(a), int(b))) for a, b in zip(meas.time_ref, meas.time,
                                                            strict=True)]
    expected = np.array([[25.0 * len(i & j) for j in intervals] for i in intervals])
    assert np.allclose(cov, expected)
    # Whitening by it gives unit covariance.
    w = noise.whiten(np.eye(len(meas)), axis=0)
    assert np.allclose(w @ expected @ w.T, np.eye(len(meas)), atol=1e-9)
    # Lag-1 differences only share no interval: then the noise is diagonal.
    assert not NoiseModel(tk.load_scenario("chen-sun-1").simulate(noise=False)).correlated
    # Lag-1 and lag-2 differences from the same pulses repeat information: a lag-2 difference
    # is the sum of two lag-1 differences.  The covariance is singular; the independent rows
    # are the 20 pulse intervals.
    base["measurements"][0]["lags"] = [1, 2]
    both = NoiseModel(scenario_from_dict(base).simulate(noise=False))
    assert both.n == 39 and both.rank == 20


@pytest.mark.parametrize("receivers, rank", [(1, 4), (2, 6), (3, 7)])
def test_doppler_lecture_rank_by_number_of_receivers(receivers, rank):
    bound = crlb(with_receivers(receivers))
    assert bound.rank == rank
    assert len(bound.observability.directions) == 7 - rank
    if rank < 7:
        # Never a finite standard deviation for what cannot be observed; a finite one for what
        # no unobservable direction touches.
        touched = set().union(*(d.weights for d in bound.observability.directions))
        for p in bound.parameters:
            assert (bound.std_of(p) == np.inf) == (p in touched), p
        assert {"x", "y", "z"} <= touched
        assert all("rotation" in d.sentence for d in bound.observability.directions)
        assert np.isinf(bound.ellipse(60.0)["major"])
    else:
        assert np.all(np.isfinite(bound.std))


def test_one_receiver_names_three_rotations_about_the_receiver():
    bound = crlb(with_receivers(1))
    sentences = [d.sentence for d in bound.observability.directions]
    assert sorted(s.split(" axis")[0].split()[-1] for s in sentences) == ["East", "North", "Up"]
    assert all("through sensor rx1" in s for s in sentences)
    data = bound.as_dict()
    assert set(data) >= {"parameters", "std", "covariance", "rank", "unobservable"}
    assert data["std"][:6] == [None] * 6 and data["std"][6] is not None
    assert data["unobservable"][0]["weights"]


def test_two_receivers_leave_the_rotation_about_their_baseline():
    bound = crlb(with_receivers(2))
    (direction,) = bound.observability.directions
    assert "line through sensors rx1 and rx2" in direction.sentence


def test_bearings_only_from_a_straight_observer_is_unobservable_in_range():
    scn = tk.Scenario(
        name="bo", motion=tk.ConstantVelocity(2), truth={"x": 5e3, "y": 8e3, "vx": -3.0,
                                                        "vy": 1.0},
        sensors={"s": tk.FixedSensor([0.0, 0.0])},
        plans=[tk.MeasurementPlan("bearing", "s", np.arange(0.0, 300.0, 5.0),
                                  sigma=np.radians(1.0))])
    bound = crlb(scn)
    assert bound.rank == 3
    sentence = bound.observability.directions[0].sentence
    assert sentence.startswith("range is not observable: sensor s did not move")


def test_ellipse_and_derived_quantities_follow_the_delta_method():
    scn = tk.load_scenario("gu2007")
    bound = crlb(scn)
    state, cov = bound.state_covariance(60.0)
    e90 = bound.ellipse(60.0, 0.9)
    e50 = bound.ellipse(60.0, 0.5)
    evals = np.linalg.eigvalsh(cov[:2, :2])
    assert e90["major"] == pytest.approx(np.sqrt(4.605170186 * evals[1]), rel=1e-6)
    assert e50["major"] < e90["major"]
    assert (e90["east"], e90["north"]) == pytest.approx(tuple(state[:2]))
    d = bound.derived(0.0)
    assert d["x"][1] == pytest.approx(bound.std_of("x"))
    speed, speed_std = d["speed"]
    assert speed == pytest.approx(np.hypot(21.65, 12.5))
    # Numerical delta method for the speed.
    c = bound.covariance[2:4, 2:4]
    g = np.array([-21.65, -12.5]) / speed
    assert speed_std == pytest.approx(np.sqrt(g @ c @ g), rel=1e-9)


def test_derived_std_where_only_the_position_is_undetermined(monkeypatch):
    """Speed and course keep their std when the velocity is known and the position is not.

    The full product ``g' C g`` made them NaN (``0 * inf``) where an unobservable state lies off
    the gradient's support; the std is the one of the velocity block.
    """
    bound = crlb(tk.load_scenario("bearings-only-2d"))
    state = np.array([1000.0, 2000.0, 0.0, 3.0, 4.0, 0.0])
    cov = np.diag([1.0, 1.0, 0.0, 0.04, 0.09, 0.0])
    cov[3, 4] = cov[4, 3] = 0.01
    cov[0, :] = cov[:, 0] = np.inf  # east unobservable
    monkeypatch.setattr(bound, "state_covariance", lambda t: (state, cov))
    d = bound.derived(0.0)
    g = np.array([3.0, 4.0]) / 5.0
    assert d["x"][1] == np.inf
    assert d["speed"] == (5.0, pytest.approx(np.sqrt(g @ cov[3:5, 3:5] @ g)))
    h = np.array([4.0, -3.0]) / 25.0
    assert d["course"][1] == pytest.approx(np.sqrt(h @ cov[3:5, 3:5] @ h))
