"""A manoeuvre fit's ``J'J`` and ``J'r`` are summed when read, for the runs read.

The segment sums of :meth:`ForwardPiecewise.normal_equations_later` are held by a
:class:`~tmakit.batch.varpro.DeferredNormal`: a rejected trial point never has them
made, and of a batch only the accepted runs do.  Every run's sums are the same bits however
they are asked for, so the solver takes the same steps to the same points.
"""

from __future__ import annotations

import numpy as np
from kernel_paths import hoerst_thetas

import tmakit as tk
from tmakit.batch import varpro
from tmakit.batch.varpro import DeferredNormal, VarProProblem
from tmakit.motion.curvilinear import ForwardPiecewise
from tmakit.observation import ObservationModel


def _problem(m: int, seed: int, batch: int):
    meas = tk.load_scenario("hoerst2010").simulate(np.random.default_rng(seed))
    model = ForwardPiecewise(m, float(meas.time.min()), end_time=float(meas.time.max()))
    problem = VarProProblem(ObservationModel(meas, model))
    theta = hoerst_thetas(m, np.random.default_rng(seed + 1), batch)
    y = np.broadcast_to(problem.group(meas.value_si), (batch, len(meas)))
    nu = problem.reference_nuisance(y)
    return problem, theta, problem.data_part(y, nu), nu


def _eager(monkeypatch):
    """Make every evaluation sum its J'J and J'r at once (the solver as it was)."""
    deferred = varpro.motion_normal

    def at_once(*args):
        normal = deferred(*args)
        return None if normal is None else (normal[0], normal[1])
    monkeypatch.setattr(varpro, "motion_normal", at_once)


def test_the_sums_of_some_runs_are_those_runs_of_the_whole():
    problem, theta, u, nu = _problem(2, 4, 5)
    ev = problem.evaluate_part(theta, u, nu)
    whole = problem.evaluate_part(theta, u, nu)
    assert isinstance(ev.normal, DeferredNormal)
    jtj, jtr = whole.normal  # summed now, every run
    got = ev.normal.runs(np.array([3, 1]))
    np.testing.assert_array_equal(got[0], jtj[[3, 1]])
    np.testing.assert_array_equal(got[1], jtr[[3, 1]])
    keep = np.array([True, False, True, True, False])
    part = ev.take(keep)
    assert isinstance(part.normal, DeferredNormal)  # still not summed
    inner = part.take(np.array([2, 0]))  # runs 3 and 0 of the batch
    np.testing.assert_array_equal(inner.normal[0], jtj[[3, 0]])
    np.testing.assert_array_equal(part.normal[1], jtr[keep])
    assert len(part.normal) == 2
    taken = whole.take(keep)  # once summed, taking copies
    assert not isinstance(taken.normal, DeferredNormal)
    np.testing.assert_array_equal(taken.normal[0], jtj[keep])


def test_putting_accepted_runs_sums_those_runs_only():
    problem, theta, u, nu = _problem(1, 5, 4)
    current = problem.evaluate_part(theta, u, nu)
    before = [a.copy() for a in current.normal]
    trial_theta = theta + 1e-3 * np.random.default_rng(2).normal(size=theta.shape)
    trial = problem.evaluate_part(trial_theta, u, nu)
    want = problem.evaluate_part(trial_theta, u, nu).normal
    asked = []
    make = trial.normal._make
    trial.normal._make = lambda runs: asked.append(np.array(runs)) or make(runs)
    better = np.array([False, True, False, True])
    current.put(better, trial, better)
    assert len(asked) == 1 and list(asked[0]) == [1, 3]  # the rejected runs never summed
    for got, old, new in zip(current.normal, before, want, strict=True):
        np.testing.assert_array_equal(got[better], new[better])
        np.testing.assert_array_equal(got[~better], old[~better])
    np.testing.assert_array_equal(current.theta[better], trial_theta[better])


def test_fits_take_the_same_steps_and_skip_the_rejected_trials(monkeypatch):
    from tmakit.batch.manoeuvre import lm_fit

    problem, theta, _, _ = _problem(2, 6, 4)
    free = np.ones(problem.p, dtype=bool)
    free[7] = False  # a held acceleration, as in the selection's fits
    summed = []
    later = ForwardPiecewise.normal_equations_later

    def counting(self, *args):
        make = later(self, *args)
        return lambda runs: summed.append(args[0].shape[0] if runs is None
                                          else len(runs)) or make(runs)
    monkeypatch.setattr(ForwardPiecewise, "normal_equations_later", counting)
    evaluated = []
    evaluate = VarProProblem.evaluate_part

    def counting_evaluations(self, th, *args, **kw):
        evaluated.append(th.shape[0])
        return evaluate(self, th, *args, **kw)
    monkeypatch.setattr(VarProProblem, "evaluate_part", counting_evaluations)
    deferred = lm_fit(problem, theta, free, 30, rtol=0.0, atol=0.02, max_reject=8)
    assert sum(summed) < sum(evaluated)  # some trial points were rejected, never summed
    _eager(monkeypatch)
    eager = lm_fit(problem, theta, free, 30, rtol=0.0, atol=0.02, max_reject=8)
    np.testing.assert_array_equal(deferred.theta, eager.theta)
    np.testing.assert_array_equal(deferred.cost, eager.cost)
    np.testing.assert_array_equal(deferred.iterations, eager.iterations)


def test_evaluations_of_both_forms_are_merged_as_normal_equations(monkeypatch):
    """A batch's Jacobians and one run's J'J, J'r alone (summed by chunks of rows) are
    merged as normal equations, the run's own kept, either way round."""
    from bearing_sets import bearings

    from tmakit.batch.solver import normal_equations
    from tmakit.core import blas

    motion, theta = tk.ConstantVelocity(2), np.array([8000.0, 12000.0, -4.0, 2.5])
    meas = bearings(motion, theta, 3000, 9, 2, unequal_sigma=True)
    problem = VarProProblem(ObservationModel(meas, motion))
    u = problem.group(meas.value_si)[None]
    batch = np.stack([theta, theta * 1.01 + 20.0])
    both = problem.evaluate_part(batch, np.vstack([u, u]), np.zeros((2, 0)))  # Jacobians
    with monkeypatch.context() as chunked:
        chunked.setattr(blas, "CHUNKED_ROWS", 500)
        chunked.setattr(blas, "CHUNK_ROWS", 400)
        one = problem.evaluate_part(batch[1:] + 5.0, u, np.zeros((1, 0)))  # sums alone
    assert both.jacobian is not None and one.jacobian is None
    want = problem.evaluate_part(np.stack([batch[0], batch[1] + 5.0]), np.vstack([u, u]),
                                 np.zeros((2, 0)))
    merged = both.take(np.arange(2))
    merged.put(np.array([1]), one)
    jtj, grad = normal_equations(merged, None)
    jtj0, grad0 = normal_equations(want, None)
    np.testing.assert_allclose(jtj, jtj0, rtol=0, atol=1e-12 * np.abs(jtj0).max())
    np.testing.assert_allclose(grad, grad0, rtol=1e-9, atol=1e-9 * np.abs(grad0).max())
    np.testing.assert_allclose(merged.cost, want.cost, rtol=1e-12)
    back = one.take(np.arange(1))
    back.put(np.array([0]), both, np.array([0]))  # the other way round
    np.testing.assert_allclose(normal_equations(back, None)[0][0], jtj0[0], rtol=0,
                               atol=1e-12 * np.abs(jtj0).max())
