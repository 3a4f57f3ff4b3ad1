"""Row subsets of an observation model built from the parent's arrays (ObservationModel.take,
VarProProblem.take, NoiseModel.independent) equal the models built from scratch."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch.solver import VarProProblem
from tmakit.observation import ObservationModel
from tmakit.observation.affine_rows import AffineRows
from tmakit.observation.noise import NoiseModel
from tmakit.observation.rows import RowLayout, RowModel


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        numeric = a.dtype.kind in "fc" and b.dtype.kind in "fc"
        return np.array_equal(a, b, equal_nan=numeric)
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, tk.MeasurementSet):
        return a.equals(b)
    if isinstance(a, RowModel | RowLayout | AffineRows):  # the observation core: same rows
        return type(b) is type(a) and _same(vars(a), vars(b))
    if hasattr(a, "nuisance_names"):  # measurement models: same kind and options
        return type(a) is type(b) and vars(a) == vars(b)
    return a == b


def _subsets(meas: tk.MeasurementSet, rng: np.random.Generator) -> list[np.ndarray]:
    n = len(meas)
    first_kind = meas.kind == meas.kinds[0]
    return [np.sort(rng.choice(n, n // 3, replace=False)),  # sorted indices
            rng.choice(n, n // 4, replace=False),            # any order
            rng.random(n) < 0.5,                              # a boolean mask
            np.flatnonzero(first_kind)[::3]]                  # one kind left out


@pytest.mark.parametrize("name", ["gu2007", "chen-sun-1"])
def test_take_equals_the_model_built_from_the_rows(name):
    scn = tk.load_scenario(name)
    meas = scn.simulate(np.random.default_rng(5))
    obs = ObservationModel(meas, scn.motion, scn.measurement_options)
    obs.const_design  # noqa: B018  (made before the subsets, so that they inherit it)
    problem = VarProProblem(obs)
    rng = np.random.default_rng(7)
    theta = scn.theta + rng.normal(size=(3, scn.theta.size)) * 50.0
    for idx in _subsets(meas, rng):
        fresh = ObservationModel(meas.take(idx), scn.motion, scn.measurement_options)
        sub = obs.take(idx)
        fresh.const_design, sub.const_design  # noqa: B018  (made by the fallback too)
        assert vars(sub).keys() == vars(fresh).keys()
        for key in vars(fresh):
            assert _same(getattr(sub, key), getattr(fresh, key)), key
        nu = rng.normal(size=fresh.n_nuisance)
        np.testing.assert_array_equal(sub.predict(theta, nu), fresh.predict(theta, nu))
        lin_a, lin_b = sub.linearisation(theta), fresh.linearisation(theta)
        np.testing.assert_array_equal(lin_a.jacobian(nu), lin_b.jacobian(nu))
        # the problem on the rows: its noise model is the one made from the rows
        noise, made = problem.take(idx).noise, NoiseModel(fresh.grouped)
        np.testing.assert_array_equal(noise.inv_sigma, made.inv_sigma)
        assert (noise.n, noise.rank, noise.correlated) == (made.n, made.rank, made.correlated)


def test_independent_noise_model_equals_the_one_made_from_the_set():
    meas = tk.load_scenario("gu2007").simulate(np.random.default_rng(1))
    made, direct = NoiseModel(meas), NoiseModel.independent(meas.sigma_si)
    assert not made.correlated
    for key in vars(made):
        assert _same(getattr(direct, key), getattr(made, key)), key


def test_jacobians_of_many_fits_each_equal_the_fit_alone_bit_for_bit():
    """``each=True``: every row of a batch linearised as for it alone (fit_many's results)."""
    scn = tk.load_scenario("gu2007")
    obs = ObservationModel(scn.simulate(rng=1), scn.motion, scn.measurement_options)
    truth = scn.motion.theta(scn.truth)
    thetas = np.stack([truth, truth * 1.01, truth + 50.0])
    nus = np.stack([np.linspace(1.0, 2.0, obs.n_nuisance) * (i + 1) for i in range(3)])
    j_theta, j_nu = obs.jacobian_grouped(thetas, nus, each=True)
    for i in range(3):
        alone_theta, alone_nu = obs.jacobian_grouped(thetas[i], nus[i])
        assert np.array_equal(j_theta[i], alone_theta)
        assert np.array_equal(j_nu[i], alone_nu)
