"""Compiled bearing and azimuth-rate rows, and relative states in one pass: the same bits.

:mod:`tmakit.measurements.planar_compiled` and
:meth:`ForwardPiecewise.states_minus` are used or not by the size of a batch and by whether
``numba`` is loaded; a result must never depend on which, so every value is compared bit for
bit with the NumPy path (zero range and rows outside the model's domain included).
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_paths import hoerst_thetas

from tmakit.measurements import planar_compiled
from tmakit.measurements.azimuth_rate import AzimuthRate
from tmakit.measurements.bearing import Bearing
from tmakit.motion import curvilinear_compiled
from tmakit.motion.curvilinear_batch import ForwardPiecewise

pytestmark = pytest.mark.skipif(not planar_compiled.available(),
                                reason="numba not installed")


def _rows(rng: np.random.Generator, b: int, n: int) -> np.ndarray:
    """Relative states ``(b, n, 6)`` over four decades, a zero range and a NaN row among them."""
    rel = rng.normal(size=(b, n, 6)) * 10.0 ** rng.integers(0, 4, size=(b, n, 1))
    rel[0, 3, :2] = 0.0     # on the sensor
    rel[-1, 7, :] = np.nan  # outside the model's domain
    return rel


def _linearise(model, rel: np.ndarray, compiled: bool) -> tuple[np.ndarray, np.ndarray]:
    """Write one kind's rows as the solvers do: a slice of every row, derivatives by component."""
    b, n, _ = rel.shape
    whole = np.full((b, n + 5, 6), 7.0)
    whole[:, 2:n + 2] = rel
    values = np.empty((b, n + 5))
    d = np.zeros((b, 6, n + 5)).swapaxes(-1, -2)
    before = planar_compiled.use_compiled(compiled)
    try:
        with np.errstate(invalid="ignore", divide="ignore"):
            model.values_and_derivatives_into(whole[:, 2:n + 2], None, values[:, 2:n + 2],
                                              d[:, 2:n + 2])
    finally:
        planar_compiled.use_compiled(before)
    return values[:, 2:n + 2], d[:, 2:n + 2]


@pytest.mark.parametrize("model", [Bearing(), AzimuthRate()], ids=["bearing", "azimuth_rate"])
def test_compiled_rows_are_the_numpy_rows_bit_for_bit(model):
    rel = _rows(np.random.default_rng(3), 3, 400)
    assert planar_compiled.wanted(rel)  # (numba is loaded by the test session's kernels)
    fast = _linearise(model, rel, True)
    slow = _linearise(model, rel, False)
    for got, want in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(got, want)
    assert np.isnan(fast[0][-1, 7]) and not np.isfinite(fast[1][0, 3, :2]).all()
    with np.errstate(invalid="ignore", divide="ignore"):
        np.testing.assert_array_equal(fast[1], model.jacobian(rel).rel)


def test_few_rows_or_a_single_state_take_the_numpy_path():
    assert not planar_compiled.wanted(np.zeros((1, planar_compiled.KERNEL_ROWS - 1, 6)))
    assert not planar_compiled.wanted(np.zeros((planar_compiled.KERNEL_ROWS, 6)))
    assert planar_compiled.wanted(np.zeros((2, planar_compiled.KERNEL_ROWS // 2, 6)))


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
    before = curvilinear_compiled.use_compiled(False)  # (the NumPy closed form's own bits)
    try:
        np.testing.assert_array_equal(model.states_minus(theta, t, sensor),
                                      model.states(theta, t) - sensor)
    finally:
        curvilinear_compiled.use_compiled(before)
