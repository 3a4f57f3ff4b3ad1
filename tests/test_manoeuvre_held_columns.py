"""Fits that hold parameters do not form their derivatives, with the same results.

Inside :meth:`ForwardPiecewise.derivatives_for` the chain rule gives the free parameters'
columns only, bit for bit those of the whole Jacobian; the search's held fits
(:func:`tmakit.batch.manoeuvre.lm_fit`) take the same steps to the same points as the
solver given the whole Jacobian.
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_paths import hoerst_thetas

import tmakit as tk
from tmakit.batch.manoeuvre import ManoeuvreSearch, ManoeuvreSettings, lm_fit
from tmakit.batch.solver import levenberg_marquardt
from tmakit.motion.curvilinear import ForwardPiecewise


def _theta(m: int, rng: np.random.Generator) -> np.ndarray:
    """Four parameter vectors of ``m`` manoeuvres on hoerst2010, some accelerations zero."""
    theta = hoerst_thetas(m, rng, 4)
    theta[1, 4:6] = 0.0  # a straight first segment
    theta[2, 4:6 + 2 * m:2] = 0.0  # constant speed throughout
    return theta


@pytest.mark.parametrize("m", [0, 1, 3])
def test_held_columns_are_the_columns_of_the_whole_jacobian(m):
    rng = np.random.default_rng(11)
    theta = _theta(m, rng)
    times = np.arange(0.0, 901.0, 4.0)
    t = np.concatenate([times, times[::3]])  # rows sharing unique times, not in order
    d = rng.normal(size=(theta.shape[0], t.size, 6))
    p = theta.shape[1]
    masks = [np.arange(p) < 6 + 2 * m,  # change-over times held (the profile)
             np.arange(p) != 4,  # one acceleration held (the selection)
             np.isin(np.arange(p), [0, 1, 2, 3, 5, p - 1])]  # the first and the last kept
    model = ForwardPiecewise(m, 0.0, end_time=1000.0)
    whole = model.chain(d, theta, t)
    for free in masks:
        with model.derivatives_for(free):
            part = model.chain(d, theta, t)
        np.testing.assert_array_equal(part, whole[..., free])
        assert model.chain(d, theta, t).shape == whole.shape  # back to every column
        np.testing.assert_array_equal(model.jacobian(theta[:1], t[:5]).shape, (1, 5, 6, p))


@pytest.mark.parametrize("sums", [True, False])
def test_held_fits_take_the_same_steps_as_with_the_whole_jacobian(sums, monkeypatch):
    """With the Jacobian chained (its held columns not formed) or ``J'J`` summed by segments
    (every column's sums, the solver taking the free ones)."""
    if not sums:
        from tmakit.batch import varpro

        monkeypatch.setattr(varpro, "motion_normal", lambda *args: None)
    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=np.random.default_rng(5))
    search = ManoeuvreSearch(meas, None, None, ManoeuvreSettings(max_manoeuvres=2))
    pr = search.problem(2)
    start = np.array(scn.theta, dtype=float)  # curvilinear:2
    starts = np.tile(start, (3, 1))
    starts[1, -2] += 25.0
    starts[2, -1] -= 30.0
    free = np.ones(pr.p, dtype=bool)
    free[[4, 9, pr.p - 2]] = False  # an acceleration of each end and the first time held
    starts[:, [4, 9]] = 0.0
    fast = lm_fit(pr, starts, free, 25, rtol=0.0, atol=0.02, max_reject=8, stall=1e-2)
    plain = levenberg_marquardt(pr, pr.obs.values, starts, 25, ftol=0.0, xtol=0.0, gtol=0.0,
                                dtol=0.02, free=free, damping="factors", max_reject=8,
                                stall=1e-2, dominance=(2.0, 0.0))
    if sums:  # J'J of every parameter, no Jacobian
        assert fast.evaluation.jacobian is None and plain.evaluation.jacobian is None
        assert fast.evaluation.normal[0].shape[-1] == pr.p
    else:
        assert fast.evaluation.jacobian.shape[-1] == free.sum()  # held columns not formed
        assert plain.evaluation.jacobian.shape[-1] == pr.p
    np.testing.assert_array_equal(fast.theta, plain.theta)
    np.testing.assert_array_equal(fast.cost, plain.cost)
    np.testing.assert_array_equal(fast.iterations, plain.iterations)
    assert np.all(fast.iterations > 1)  # the fits moved
