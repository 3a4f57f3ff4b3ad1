"""The compiled piecewise-curvilinear kernels (optional numba) agree with the NumPy path."""

from __future__ import annotations

import numpy as np
import pytest
from kernel_paths import both_paths, hoerst_thetas

from tmakit.motion import PiecewiseCurvilinear
from tmakit.motion import curvilinear_compiled as compiled
from tmakit.motion.curvilinear_batch import ForwardPiecewise

pytest.importorskip("numba")


def _both(fn):
    """Run ``fn`` with the kernels, then on the NumPy path; give both results."""
    return both_paths(compiled, fn)


def _thetas(m: int, rng: np.random.Generator) -> np.ndarray:
    """Parameter vectors of ``m`` manoeuvres on hoerst2010, with the corner cases."""
    theta = hoerst_thetas(m, rng, 8)
    theta[1, 4:6 + 2 * m:2] = 0.0            # straight in speed: r = 0
    theta[2, 4:6 + 2 * m] = 0.0              # no acceleration at all: the held case
    theta[3, 4] = 1e-7                       # the series side of both closed forms
    theta[4, 4] = -1.0                       # the speed dies: NaN
    if m:
        theta[5, 6 + 2 * m] = -5.0           # a change-over time before the reference
        theta[6, -1] = 2000.0                # after the end time
    return theta


@pytest.mark.parametrize("m", [0, 1, 3])
def test_compiled_states_and_chain_equal_numpy_to_1e_12(m):
    rng = np.random.default_rng(7)
    theta = _thetas(m, rng)
    times = np.arange(0.0, 901.0, 3.0)
    times[50] = 200.0  # a sample on a change-over time: the earlier segment's
    t = np.concatenate([times, times[::2]])  # rows sharing unique times, not in order
    d = rng.normal(size=(theta.shape[0], t.size, 6))

    def run():
        model = ForwardPiecewise(m, 0.0, end_time=1000.0)
        return model.states(theta, t), model.chain(d, theta, t), model.segment_states(theta, t)

    (s_fast, c_fast, g_fast), (s_slow, c_slow, g_slow) = _both(run)
    assert np.isnan(s_slow[4, -1, 0]) and np.isfinite(s_slow[4, 0, 0])  # the speed dies
    if m:
        assert np.all(np.isnan(s_slow[5:7]))  # change-over times out of the domain
    np.testing.assert_array_equal(np.isnan(s_fast), np.isnan(s_slow))
    valid = np.isfinite(s_slow[..., 0])  # (B, n): derivatives where the state exists
    for fast, slow in ((s_fast, s_slow), (c_fast, c_slow), (g_fast, g_slow)):
        fast, slow = fast[valid], slow[valid]
        assert np.all(np.isfinite(fast) == np.isfinite(slow))
        scale = np.abs(np.where(np.isfinite(slow), slow, 0.0)).max()
        assert np.all(np.abs(np.where(np.isfinite(slow), fast - slow, 0.0)) <= 1e-12 * scale)


def test_compiled_chain_equals_the_general_model_jacobian():
    rng = np.random.default_rng(2)
    theta = _thetas(2, rng)[:4]
    t = np.arange(0.0, 901.0, 7.0)
    fast, general = ForwardPiecewise(2, 0.0), PiecewiseCurvilinear(2, 0.0)
    d = rng.normal(size=(theta.shape[0], t.size, 6))
    np.testing.assert_allclose(fast.states(theta, t), general.states(theta, t), rtol=0,
                               atol=1e-6)
    expected = np.einsum("bni,bnip->bnp", d, general.jacobian(theta, t))
    got = fast.chain(d, theta, t)
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(got / scale, expected / scale, rtol=0, atol=1e-9)


def test_unusable_numba_falls_back_to_numpy_with_a_warning(monkeypatch):
    def broken():
        raise RuntimeError("no cache dir")

    monkeypatch.setattr(compiled.KERNELS, "kernels", None)
    monkeypatch.setattr(compiled, "_compile", broken)
    with pytest.warns(RuntimeWarning, match="NumPy path"):
        assert not compiled.available()
    theta = _thetas(1, np.random.default_rng(0))[:1]
    assert np.all(np.isfinite(ForwardPiecewise(1, 0.0).states(theta, np.arange(10.0))))
    monkeypatch.setattr(compiled.KERNELS, "kernels", None)


@pytest.mark.parametrize("m", [0, 1, 3])
def test_normal_equations_by_segments_equal_the_chained_jacobian(m):
    """J'J and J'r summed by segments (the Jacobian never formed) equal those of chain()."""
    rng = np.random.default_rng(12)
    theta = _thetas(m, rng)[:4]  # valid points, the held and series cases among them
    times = np.arange(0.0, 901.0, 3.0)
    times[50] = 200.0
    t = np.concatenate([times, times[::2]])
    model = ForwardPiecewise(m, 0.0, end_time=1000.0)
    model.states(theta, t)
    d = rng.normal(size=(theta.shape[0], t.size, 6))
    r = rng.normal(size=(theta.shape[0], t.size))
    w = rng.uniform(0.5, 2.0, t.size)
    jac = model.chain(d, theta, t) * w[None, :, None]
    jtj, jtr = model.normal_equations(d, r, w, theta, t)
    expected = jac.swapaxes(1, 2) @ jac
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(jtj / scale, expected / scale, rtol=0, atol=1e-12)
    np.testing.assert_allclose(jtr, np.einsum("bnp,bn->bp", jac, r), rtol=1e-10,
                               atol=1e-10 * np.abs(jtr).max())
    with model.derivatives_for(np.arange(model.n_params) != 4):  # every column still given
        assert model.normal_equations(d, r, w, theta, t)[0].shape == expected.shape
    before = compiled.use_compiled(False)
    try:
        assert model.normal_equations(d, r, w, theta, t) is None  # the NumPy path: no sums
    finally:
        compiled.use_compiled(before)


def _hoerst_problem(m, seed, batch):
    """A problem of ``m`` manoeuvres on seeded hoerst2010 data, points, data, reference."""
    import tmakit as tk
    from tmakit.batch.varpro import VarProProblem
    from tmakit.observation import ObservationModel

    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(np.random.default_rng(seed))
    model = ForwardPiecewise(m, float(meas.time.min()), end_time=float(meas.time.max()))
    problem = VarProProblem(ObservationModel(meas, model))
    theta = hoerst_thetas(m, np.random.default_rng(seed + 1), batch)
    y = np.broadcast_to(problem.group(meas.value_si), (batch, len(meas)))
    return problem, theta, y, problem.reference_nuisance(y)


def _assert_scaled_close(got, want, atol):
    scale = np.abs(want).max(axis=tuple(range(1, want.ndim)), keepdims=True)
    np.testing.assert_allclose(got / scale, want / scale, rtol=0, atol=atol)


def test_a_manoeuvre_fit_evaluates_alike_with_and_without_the_segment_sums(monkeypatch):
    from tmakit.batch import varpro

    problem, theta, y, nu = _hoerst_problem(2, 3, 5)
    summed = problem.evaluate(theta, y, nu)
    assert summed.jacobian is None and summed.normal is not None
    monkeypatch.setattr(varpro, "motion_normal", lambda *args: None)
    chained = problem.evaluate(theta, y, nu)
    jt = chained.jacobian.swapaxes(1, 2)
    np.testing.assert_array_equal(summed.residual, chained.residual)
    _assert_scaled_close(summed.normal[0], jt @ chained.jacobian, 1e-11)
    _assert_scaled_close(summed.normal[1], (jt @ chained.residual[:, :, None])[..., 0], 1e-11)


def test_chunks_of_rows_add_the_segment_sums(monkeypatch):
    """A problem of more than CHUNKED_ROWS rows sums each chunk's J'J, however the chunk
    gives it (the motion model's sums or the Jacobian's products)."""
    from tmakit import blas

    problem, theta, y, nu = _hoerst_problem(1, 8, 2)
    whole = problem.evaluate(theta, y, nu)
    monkeypatch.setattr(blas, "CHUNKED_ROWS", 500)
    monkeypatch.setattr(blas, "CHUNK_ROWS", 400)
    chunked = problem.evaluate(theta, y, nu)
    assert chunked.jacobian is None and chunked.normal is not None
    for got, want in zip(chunked.normal, whole.normal, strict=True):
        _assert_scaled_close(got, want, 1e-12)
