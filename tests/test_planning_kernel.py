"""The compiled planning kernel (optional numba) gives the NumPy path's Gamma and decisions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from kernel_paths import both_paths

from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, Planner, SensorPlan, compiled
from tmakit.planning.planar_information import planar_information
from tmakit.sensors import PlatformState, platform_configuration

pytest.importorskip("numba")

TARGET = np.array([-2000.0, 15000.0, 25.0, 0.0])
SPREAD = np.array([500.0, 500.0, 10.0, 10.0])


@pytest.fixture
def numpy_path():
    """Run the body with the compiled kernel switched off, then switch it back."""
    before = compiled.use_compiled(False)
    yield
    compiled.use_compiled(before)


def _both(fn):
    """Run ``fn`` with the kernels, then on the NumPy path; give both results."""
    return both_paths(compiled, fn)


@pytest.mark.parametrize("kinds", [["bearing"], ["bearing", "range"],
                                   ["bearing", "range", "range_rate"], ["range_rate"],
                                   ["bearing", "range_rate"]])
def test_compiled_and_numpy_gamma_agree_to_1e_12(kinds):
    rng = np.random.default_rng(11)
    sig = rng.uniform(0.01, 2.0, len(kinds))
    plan = SensorPlan(kinds, sig)
    states = TARGET + rng.standard_normal((5000, 4)) * SPREAD
    w = rng.random(5000)
    w /= w.sum()
    sensors = np.zeros((15, 6))
    sensors[:, [0, 1, 3, 4]] = rng.normal(size=(15, 4)) * [50, 50, 30, 30]
    fast, slow = _both(lambda: planar_information(plan, states, w, sensors))
    scale = np.abs(slow).max(axis=(-1, -2), keepdims=True)
    assert np.all(np.abs(fast - slow) <= 1e-12 * scale)
    # and entry by entry, where an entry is not a cancellation to ~0
    big = np.abs(slow) > 1e-6 * scale
    np.testing.assert_allclose(fast[big], slow[big], rtol=1e-12)


@pytest.mark.parametrize("gamma", ["mean", "cloud"])
def test_compiled_and_numpy_decisions_agree(gamma):
    config = platform_configuration("hurtado_nehorai_2008")
    dyn = NearlyConstantVelocity(dim=2, q=0.1)
    rng = np.random.default_rng(2)
    b = Belief(PosteriorInformation.from_prior(np.diag(SPREAD**2), dyn),
               TARGET + rng.standard_normal((3000, 4)) * SPREAD)
    planner = Planner(config.kinematics, config.actions, config.interval,
                      SensorPlan(["bearing", "range"], [math.radians(1.0), 30.0]), gamma=gamma)
    start = PlatformState(position=(0.0, 0.0), heading=0.0, speed=50.0)
    fast, slow = _both(lambda: planner.recommend(start, b))
    assert fast.index == slow.index
    np.testing.assert_allclose(fast.cost, slow.cost, rtol=1e-12)
    np.testing.assert_allclose(fast.information, slow.information, rtol=1e-12, atol=1e-12 *
                               np.abs(slow.information).max())


def test_switch_off_by_hand(numpy_path):
    assert not compiled.available()
    with pytest.raises(RuntimeError, match="not available"):
        compiled.cloud_sums(["ir2"], np.zeros((4, 3)), np.ones(3) / 3, np.ones((2, 6)))


def test_compiled_and_numpy_bound_covariance_agree():
    from tmakit.planning.criteria import bound_covariance

    rng = np.random.default_rng(4)
    a = rng.normal(size=(200, 4, 4))
    scales = np.array([1e-6, 1e-6, 1e-2, 1e-2])   # SI units: position and velocity information
    info = (a @ np.swapaxes(a, -1, -2) + 0.01 * np.eye(4)) * np.sqrt(np.outer(scales, scales))
    info[:50] += np.diag(scales) * 1e4              # some well determined, some barely
    fast, slow = _both(lambda: bound_covariance(info))
    scale = np.abs(slow).max(axis=(-1, -2), keepdims=True)
    cond = np.linalg.cond(info / np.sqrt(np.einsum("kii,kjj->kij", info, info)))
    ok = cond < 1e6       # the two algorithms agree to cond * eps
    assert ok.sum() > 100
    assert np.all(np.abs(fast - slow)[ok] <= 1e-12 * scale[ok])
    # a matrix that is not positive definite takes the NumPy path (eigenvalues floored)
    bad = info[:3].copy()
    bad[1] = np.eye(4)
    bad[1, 0, 1] = bad[1, 1, 0] = 2.0             # indefinite, positive diagonal
    fast, slow = _both(lambda: bound_covariance(bad))
    np.testing.assert_array_equal(fast, slow)


@pytest.mark.parametrize("kinds", [["bearing", "range"], ["bearing", "range", "range_rate"]])
def test_compiled_assembly_is_numpys_to_the_bit(kinds):
    from tmakit.planning import numba_kernels
    from tmakit.planning.planar_information import (
        _assemble,
        _coefficients,
        _field_sums,
        numpy_sums,
    )

    rng = np.random.default_rng(8)
    plan = SensorPlan(kinds, rng.uniform(0.01, 2.0, len(kinds)))
    cols = (TARGET + rng.standard_normal((400, 4)) * SPREAD).T.copy()
    sensors = np.zeros((9, 6))
    sensors[:, [0, 1, 3, 4]] = rng.normal(size=(9, 4)) * [50, 50, 30, 30]
    k, basis, (_, coef, constants) = _coefficients(plan)
    sums = numpy_sums(basis, cols, np.full(400, 1 / 400), sensors)
    out = np.empty((9, 4, 4))
    numba_kernels.assemble_gamma(sums, coef, constants, out)
    np.testing.assert_array_equal(out, _assemble(k, _field_sums(basis, sums)))


def test_unusable_numba_falls_back_to_numpy_with_a_warning(monkeypatch):
    def broken():
        raise RuntimeError("no cache directory")

    monkeypatch.setattr(compiled, "_compile", broken)
    monkeypatch.setattr(compiled.KERNELS, "kernels", None)
    with pytest.warns(RuntimeWarning, match="NumPy path"):
        assert not compiled.available()
    assert compiled.spd_inverse(np.eye(4)[None]) is None     # the callers' NumPy path
