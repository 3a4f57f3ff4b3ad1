"""Rows the solvers write in place, and relative states in one pass.

The bearing's and the azimuth rate's ``values_and_derivatives_into`` are the kinds' own
``predict`` and ``jacobian`` bit for bit (zero range and rows outside the model's domain
included), for any leading shape; :meth:`ForwardPiecewise.states_minus` is the states minus
the sensor's.
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_paths import hoerst_thetas

from tmakit.measurements.azimuth_rate import AzimuthRate
from tmakit.measurements.bearing import Bearing
from tmakit.motion.curvilinear import ForwardPiecewise


def _rows(rng: np.random.Generator, b: int, n: int) -> np.ndarray:
    """Relative states ``(b, n, 6)`` over four decades, a zero range and a NaN row among them."""
    rel = rng.normal(size=(b, n, 6)) * 10.0 ** rng.integers(0, 4, size=(b, n, 1))
    rel[0, 3, :2] = 0.0     # on the sensor
    rel[-1, 7, :] = np.nan  # outside the model's domain
    return rel


def _linearise(model, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Write one kind's rows as the solvers do: a slice of every row, derivatives by component."""
    *lead, n, _ = rel.shape
    whole = np.full((*lead, n + 5, 6), 7.0)
    whole[..., 2:n + 2, :] = rel
    values = np.empty((*lead, n + 5))
    d = np.zeros((*lead, 6, n + 5)).swapaxes(-1, -2)
    with np.errstate(invalid="ignore", divide="ignore"):
        model.values_and_derivatives_into(whole[..., 2:n + 2, :], None, values[..., 2:n + 2],
                                          d[..., 2:n + 2, :])
    return values[..., 2:n + 2], d[..., 2:n + 2, :]


@pytest.mark.parametrize("model", [Bearing(), AzimuthRate()], ids=["bearing", "azimuth_rate"])
@pytest.mark.parametrize("lead", [(), (3,), (2, 3)])
def test_rows_in_place_are_the_kinds_predictions_and_jacobians_bit_for_bit(model, lead):
    rel = _rows(np.random.default_rng(3), 6, 400).reshape(*lead, -1, 6)
    values, d = _linearise(model, rel)
    with np.errstate(invalid="ignore", divide="ignore"):
        np.testing.assert_array_equal(values, model.predict(rel))
        np.testing.assert_array_equal(d, model.jacobian(rel).rel)
    flat_values, flat_d = values.reshape(-1), d.reshape(-1, 6)
    assert np.isnan(flat_values[-400 + 7]) and not np.isfinite(flat_d[3, :2]).all()


@pytest.mark.parametrize("m", [0, 2])
def test_relative_states_in_one_pass_are_the_states_minus_the_sensor(m):
    rng = np.random.default_rng(5)
    theta = hoerst_thetas(m, rng, 4)
    theta[1, 2] = -1.0  # a negative speed: outside the domain, NaN states
    t = np.concatenate([np.arange(0.0, 900.0, 2.5), np.arange(0.0, 900.0, 5.0)])
    sensor = rng.normal(size=(t.size, 6)) * 1e3
    model = ForwardPiecewise(m, 0.0, end_time=1000.0)
    got = model.states_minus(theta, t, sensor)
    want = model.states(theta, t) - sensor
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got[1]).all()
