"""The CRLB's fast paths give what the set-order formulas give, on rows of mixed kinds."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.bounds.fim import fisher_information
from tmakit.observation.noise import NoiseModel


@pytest.fixture(scope="module")
def shuffled():
    """gu2007's noise-free set (frequency and power rows) in a random row order."""
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(noise=False)
    meas = meas.take(np.random.default_rng(0).permutation(len(meas)))
    return scn, meas


def test_fisher_in_grouped_order_equals_the_set_order(shuffled):
    scn, meas = shuffled
    obs = tk.ObservationModel(meas, scn.motion, scn.measurement_options)
    assert not obs.in_set_order  # the kinds interleave: grouped order differs
    theta = scn.theta
    nu = obs.nuisance_vector({"carrier": 1.0e9, "power_constant_db": 0.0})
    for known in (None, True):
        fast = fisher_information(obs, theta, nu, known)
        j_theta, j_nu = obs.jacobian(theta, nu)  # set order: J' R^-1 J as written
        w = NoiseModel(meas).whiten(j_theta if known else np.hstack([j_theta, j_nu]), axis=-2)
        np.testing.assert_allclose(fast, w.T @ w, rtol=1e-12, atol=1e-12 * np.abs(fast).max())


def test_target_on_a_sensor_names_that_row(shuffled):
    scn, meas = shuffled
    j = 137  # a row of the shuffled set; the truth puts the target on its sensor then
    vx, vy = scn.truth["vx"], scn.truth["vy"]
    dt = meas.time[j] - scn.motion.ref_time
    sx, sy = meas.sensor_state[j, :2]
    truth = {"x": sx - vx * dt, "y": sy - vy * dt, "vx": vx, "vy": vy}
    with pytest.raises(ValueError, match="on sensor") as err:
        tk.crlb(meas, scn.motion, truth, options=scn.measurement_options)
    assert repr(str(meas.sensor[j])) in str(err.value)
    assert f"t = {meas.time[j]:g} s" in str(err.value)


def test_squared_ranges_are_the_distances_to_the_sensors(shuffled):
    scn, meas = shuffled
    obs = tk.ObservationModel(meas, scn.motion, scn.measurement_options)
    d2 = obs.squared_ranges(scn.theta)  # grouped order
    pos = scn.motion.states(scn.theta, meas.time)[:, :3] - meas.sensor_state[:, :3]
    np.testing.assert_allclose(d2[obs.inverse], (pos**2).sum(axis=1), rtol=1e-12)
