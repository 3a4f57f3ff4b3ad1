"""Shortcuts of issue 14 that must not change what the user gets.

* A no-guess estimate on many rows first converges on a subset (``batch.ml.presolve``): its
  optimum is the whole set's, as reached by the solver started at the truth.
* A filter run on a set already filtered reuses its prepared form (``prepared_for``): tracks
  are identical, and other settings get their own.
"""

from __future__ import annotations

import dataclasses

import numpy as np

import tmakit as tk
from tmakit.batch import ml
from tmakit.batch.varpro import VarProProblem
from tmakit.core.frames import wrap_angle
from tmakit.filters import ExtendedKalmanFilter
from tmakit.filters.general import prepared_for
from tmakit.observation import ObservationModel


def _many_rows(n: int) -> tuple[tk.Scenario, tk.MeasurementSet]:
    scn = tk.load_scenario("bearings-only-2d")
    lo, hi = scn.time_span()
    plans = [dataclasses.replace(p, times=np.linspace(lo, hi, n)) for p in scn.plans]
    scn = dataclasses.replace(scn, plans=plans)
    return scn, scn.simulate(np.random.default_rng(3))


def test_presolved_estimate_is_the_optimum_from_the_truth() -> None:
    scn, meas = _many_rows(ml.PRESOLVE_ROWS + 5_000)
    blind = tk.estimate(meas, scn.motion)
    assert blind.status == "converged"
    from_truth = tk.estimate(meas, scn.motion, init=scn.truth)
    # Both at the same minimum: well within the solver's tolerance of a standard deviation.
    assert np.all(np.abs(blind.estimate - from_truth.estimate) < 1e-3 * from_truth.std)
    assert abs(blind.chi2 - from_truth.chi2) < 1e-3


def test_presolve_leaves_small_problems_alone() -> None:
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(0))
    assert len(meas) <= ml.PRESOLVE_ROWS
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    theta = np.atleast_2d(scn.theta)
    out, near, _ = ml.presolve(problem, np.atleast_2d(meas.value_si), theta, 50, None)
    assert out is theta and not near


def test_a_set_filtered_again_is_compiled_once() -> None:
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(1))
    a = prepared_for(meas, 2)
    assert prepared_for(meas, 2) is a
    assert prepared_for(meas, 2, nuisance={"carrier": 1e9}) is not a
    assert prepared_for(meas, 3) is not a
    prior = np.array([3000.0, 8000.0, 0.0, 0.0])
    cov = np.diag([1e3, 1e3, 10.0, 10.0]) ** 2
    first = ExtendedKalmanFilter(prior, cov, 0.0, q=0.01).run(meas)
    again = ExtendedKalmanFilter(prior, cov, 0.0, q=0.01).run(meas)
    assert np.array_equal(first.states, again.states)
    assert np.array_equal(first.covariances, again.covariances)


def test_wrap_angle_keeps_angles_in_the_interval_and_shifts_by_exact_turns() -> None:
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-0.1, 0.1, 1000), rng.uniform(-40, 40, 1000),
                        [np.pi, -np.pi, 3 * np.pi, -3 * np.pi, 0.0, -0.0, 2 * np.pi,
                         np.nextafter(-np.pi, 0.0), np.nextafter(np.pi, 4.0), np.inf, np.nan,
                         1e-300, -1e-20]])
    with np.errstate(invalid="ignore"):
        mod = np.mod(x + np.pi, 2.0 * np.pi) - np.pi
        mod = np.where(mod == -np.pi, np.pi, mod)
        got = wrap_angle(x)
    inside = (x > -np.pi) & (x <= np.pi)
    assert np.array_equal(got[inside], x[inside])  # no rounding through x + pi
    assert np.array_equal(np.signbit(got[inside]), np.signbit(x[inside]))
    turn = ~inside & (x - 2.0 * np.pi <= np.pi) & (x + 2.0 * np.pi > -np.pi)  # one turn out
    assert turn.sum() > 100
    assert np.array_equal(got[turn], x[turn] - np.sign(x[turn]) * 2.0 * np.pi)  # exact
    finite = np.isfinite(x)
    assert np.all((got[finite] > -np.pi) & (got[finite] <= np.pi))
    gap = np.abs(got[finite] - mod[finite])  # on the circle: +-pi are one angle
    assert np.all(np.minimum(gap, np.abs(gap - 2.0 * np.pi)) <= 4 * np.spacing(np.pi))
    assert np.isnan(got[~finite]).all()
    assert float(wrap_angle(-np.pi)) == np.pi
    assert float(wrap_angle(3 * np.pi)) == float(wrap_angle(np.array([3 * np.pi]))[0])
    assert float(wrap_angle(1e-300)) == 1e-300


def test_wrap_angle_wraps_every_layout_of_a_stack() -> None:
    # A stack of residuals laid out column-major (as ObservationModel.residuals gives for
    # several parameter vectors) was returned unwrapped: the flat view was a copy.
    angles = np.array([[6.2, 0.1, -6.0], [3.5, -3.5, 7.0]])
    for layout in (angles, np.asfortranarray(angles), angles.T.copy().T, angles[:, ::-1]):
        np.testing.assert_array_equal(wrap_angle(layout), [wrap_angle(a) for a in layout])
        assert np.all(np.abs(wrap_angle(layout)) <= np.pi)
