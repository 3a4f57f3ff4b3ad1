"""The batched piecewise-curvilinear model (compiled) against the general model and its sums."""

from __future__ import annotations

import numpy as np
import pytest
from kernel_paths import hoerst_thetas

from tmakit.motion import PiecewiseCurvilinear
from tmakit.motion.curvilinear import ForwardPiecewise


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
def test_batched_states_and_chain_equal_the_general_model(m):
    """The compiled propagation against the general model (the vectorised NumPy closed form),
    on the corner cases of the closed form, rows sharing unique times out of order and a
    sample on a change-over time; NaN outside the batched model's domain."""
    rng = np.random.default_rng(7)
    theta = _thetas(m, rng)
    times = np.arange(0.0, 901.0, 3.0)
    times[50] = 200.0  # a sample on a change-over time: the earlier segment's
    t = np.concatenate([times, times[::2]])  # rows sharing unique times, not in order
    model, general = ForwardPiecewise(m, 0.0, end_time=1000.0), PiecewiseCurvilinear(m, 0.0)
    states = model.states(theta, t)
    assert np.isnan(states[4, -1, 0]) and np.isfinite(states[4, 0, 0])  # the speed dies
    np.testing.assert_array_equal(np.isnan(states[4, :, 0]),
                                  np.isnan(general.states(theta[4], t)[:, 0]))
    if m:
        assert np.all(np.isnan(states[5:7]))  # change-over times out of the domain
    ok = theta[:4]  # plain, straight in speed, held, series side
    np.testing.assert_allclose(states[:4], general.states(ok, t), rtol=0, atol=1e-6)
    d = rng.normal(size=(4, t.size, 6))
    expected = np.einsum("bni,bnip->bnp", d, general.jacobian(ok, t))
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(model.chain(d, ok, t) / scale, expected / scale, rtol=0,
                               atol=1e-9)
    speed_course = model.segment_states(ok, times)[..., 2:]
    velocity = general.states(ok, times)[..., 3:5]
    np.testing.assert_allclose(speed_course[..., 0] * np.sin(speed_course[..., 1]),
                               velocity[..., 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(speed_course[..., 0] * np.cos(speed_course[..., 1]),
                               velocity[..., 1], rtol=0, atol=1e-9)


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
    from tmakit.core import blas

    problem, theta, y, nu = _hoerst_problem(1, 8, 2)
    whole = problem.evaluate(theta, y, nu)
    monkeypatch.setattr(blas, "CHUNKED_ROWS", 500)
    monkeypatch.setattr(blas, "CHUNK_ROWS", 400)
    chunked = problem.evaluate(theta, y, nu)
    assert chunked.jacobian is None and chunked.normal is not None
    for got, want in zip(chunked.normal, whole.normal, strict=True):
        _assert_scaled_close(got, want, 1e-12)
