"""The grid's chord path for bearings under affine motion (sines and cosines from the relative
positions, no angles) chooses the starts the general path chooses, and its pieces agree with
the general formulas."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from bearing_sets import bearings

import tmakit as tk
from tmakit.batch import init, ml
from tmakit.batch.init import _median, grid_candidates_for
from tmakit.batch.solver import VarProProblem
from tmakit.measurements.bearing import Bearing
from tmakit.observation import ObservationModel
from tmakit.observation.affine_rows import AffineRows


def _scaled(name: str, n: int, seed: int) -> tuple[tk.Scenario, tk.MeasurementSet]:
    """The scenario ``name`` with ``n`` evenly spaced rows in all, one noisy set."""
    scn = tk.load_scenario(name)
    lo, hi = scn.time_span()
    per = max(1, n // len(scn.plans))
    scn = dataclasses.replace(scn, plans=[dataclasses.replace(p, times=np.linspace(lo, hi, per))
                                          for p in scn.plans])
    return scn, scn.simulate(np.random.default_rng(seed))


def _two_sensors() -> tk.MeasurementSet:
    """Bearings of two sensors, every other row (one track: enough for the grid)."""
    one = bearings(tk.Stationary(2), np.array([-6e3, 9e3]), 60, 8)
    return tk.MeasurementSet.from_si(one.time, np.arange(60) % 2, np.full(60, "bearing"),
                                     one.value_si, one.sigma_si, one.sensor_state)


def _cases():
    """(measurements, motion) of every built-in bearing-only scenario and a few more."""
    for name in ("bearings-only-2d", "plan-bearings-only"):
        for n in (7, 25, 400, 2000):
            for seed in (0, 1, 2):
                scn, meas = _scaled(name, n, seed)
                yield f"{name}-{n}-{seed}", meas, scn.motion
    cv2, cv3 = tk.ConstantVelocity(2, ref_time=900.0), tk.ConstantVelocity(3, ref_time=900.0)
    for seed in (3, 4):
        yield (f"weave-cv2d-{seed}", bearings(cv2, np.array([8e3, 12e3, -4.0, 2.0]), 300, seed,
                                              unequal_sigma=True), cv2)
        yield (f"weave-static-{seed}", bearings(tk.Stationary(2), np.array([-6e3, 9e3]), 120,
                                                seed), tk.Stationary(2))
        yield (f"weave-cv3d-{seed}", bearings(cv3, np.array([8e3, 12e3, 300.0, -4.0, 2.0, 0.0]),
                                              200, seed, dim=3), cv3)
    chen = tk.load_scenario("chen-sun-1")  # 3-D: its bearings alone
    yield "chen-sun-1-bearings", chen.simulate(5).select(kind="bearing"), chen.motion
    yield "two-sensors", _two_sensors(), tk.Stationary(2)


CASES = list(_cases())


@pytest.mark.parametrize(("meas", "motion"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_chord_path_chooses_the_starts_of_the_general_path(meas, motion, monkeypatch):
    problem = VarProProblem(ObservationModel(meas, motion))
    assert init.chord_units(problem) is not None
    ys = problem.obs.values[None]
    fast = init.best_starts_many(problem, ys)[0]
    with monkeypatch.context() as m:
        m.setattr(init, "chord_units", lambda *_: None)
        general = init.best_starts_many(problem, ys)[0]
    np.testing.assert_array_equal(fast.candidates, general.candidates)
    np.testing.assert_allclose(fast.left, general.left, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(fast.first(12), general.first(12))


def test_chord_path_chooses_the_starts_of_each_monte_carlo_run(monkeypatch):
    scn, meas = _scaled("bearings-only-2d", 500, 0)
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    rng = np.random.default_rng(9)
    ys = problem.obs.values + np.radians(1.0) * rng.normal(size=(4, len(meas)))
    fast = init.best_starts_many(problem, ys)
    monkeypatch.setattr(init, "chord_units", lambda *_: None)
    general = init.best_starts_many(problem, ys)
    for a, b in zip(fast, general, strict=True):
        np.testing.assert_array_equal(a.first(6), b.first(6))


def test_chord_scorer_costs_are_the_grid_scorers():
    scn, meas = _scaled("bearings-only-2d", 60, 1)
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    cand = init.grid_candidates(problem)
    on_sensor = np.concatenate([meas.sensor_state[3, :2], [0.0, 0.0]])
    cand = np.vstack([cand, on_sensor])  # a bearing at range 0 (atan2 gives 0: finite)
    y = problem.group(problem.obs.values)[None]
    general = init.GridScorer(problem, cand).score(y)
    for step in (64, 1000):  # blocks of candidates, or one
        chord = init.ChordScorer(init.chord_units(problem), problem.noise.inv_sigma ** 2, cand,
                                 step)
        assert len(chord.blocks) == (6 if step == 64 else 1)
        np.testing.assert_allclose(chord.score(y), general, rtol=1e-10, atol=1e-8)


def test_problems_not_of_one_planar_angle_under_affine_motion_keep_the_general_path():
    hoerst = tk.load_scenario("hoerst2010")  # curvilinear motion
    meas = hoerst.simulate(1).select(kind="bearing")
    assert init.chord_units(VarProProblem(ObservationModel(meas, hoerst.motion))) is None
    chen = tk.load_scenario("chen-sun-1")  # bearings and range differences
    both = VarProProblem(ObservationModel(chen.simulate(1), chen.motion))
    assert init.chord_units(both) is None


def test_planar_unit_is_the_sine_and_cosine_of_the_bearing():
    rng = np.random.default_rng(4)
    en = rng.normal(size=(5, 2, 40)) * 10.0 ** rng.uniform(-3, 6, size=(5, 1, 40))
    en[0, :, :4] = [[0.0, -0.0, 0.0, -0.0], [0.0, 0.0, -0.0, -0.0]]  # atan2's signed zeros
    en[1, :, :3] = [[np.inf, -np.inf, 3.0], [2.0, np.inf, np.nan]]
    en[2, :, :2] = [[1e200, 1e-200], [1e200, 2e-200]]  # squares over- and underflow
    h = Bearing().planar_value(en[:, 0], en[:, 1])
    dx, dy = en[:, 0].copy(), en[:, 1].copy()
    with np.errstate(over="ignore", invalid="ignore"):
        sin_h, cos_h = Bearing().planar_unit(dx, dy)
    assert sin_h is dx and cos_h is dy  # in place
    np.testing.assert_allclose(sin_h, np.sin(h), rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(cos_h, np.cos(h), rtol=1e-15, atol=1e-15)
    assert np.isnan(sin_h[1, 2]) and np.isnan(cos_h[1, 2])


def test_leading_components_of_many_parameter_vectors_are_the_relative_states():
    cv = tk.ConstantVelocity(3, ref_time=100.0)
    meas = bearings(cv, np.array([5e3, 7e3, 200.0, 3.0, -2.0, 0.5]), 50, 2, dim=3)
    obs = ObservationModel(meas, cv)
    theta = np.random.default_rng(1).normal(size=(9, 6)) * [1e4, 1e4, 1e3, 10, 10, 1]
    rel = np.stack([cv.states(th, obs._time) for th in theta]) - obs._sensor
    rows = np.array([0, 3, 17, 49])
    for n_c in (2, 3):
        want = rel[..., :n_c].transpose(2, 0, 1)
        many = obs._rel_map.leading_states(theta, obs._rel_map.leading_map(n_c))
        np.testing.assert_allclose(many, want, rtol=1e-12, atol=1e-9)
        for rel_map in (obs._rel_map, obs._rel_map.take(np.arange(50))):  # lazy and made
            head = rel_map.leading_map(n_c, rows)
            np.testing.assert_array_equal(head, rel_map.take(rows).leading_map(n_c))
            np.testing.assert_allclose(AffineRows.leading_states(theta, head), want[..., rows],
                                       rtol=1e-12, atol=1e-9)
        obs._rel_map.offset  # noqa: B018  (the offset made: the rows taken from it)
        np.testing.assert_array_equal(obs._rel_map.leading_map(n_c, rows),
                                      obs._rel_map.take(rows).leading_map(n_c))


@pytest.mark.parametrize("n", [1, 2, 7, 30, 31, 100])
def test_median_is_numpys(n):
    t = np.random.default_rng(n).uniform(-1e3, 1e3, n)
    assert _median(t) == np.median(t)
    assert _median(np.round(t)) == np.median(np.round(t))


@pytest.mark.parametrize("name", ["bearings-only-2d", "chen-sun-1", "gu2007", "two-sensors"])
def test_grid_of_some_rows_and_values_is_the_grid_of_those_rows_taken(name):
    if name == "two-sensors":
        scn, meas = tk.load_scenario("bearings-only-2d"), _two_sensors()
        assert len(meas.sensors) == 2
    else:
        scn = tk.load_scenario(name)
        meas = scn.simulate(2)
    rng = np.random.default_rng(6)
    rows = np.sort(rng.choice(len(meas), size=min(len(meas), 23), replace=False))
    values = meas.value_si[rows] + rng.normal(size=rows.size) * 0.01
    taken = meas.take(rows)
    got = grid_candidates_for(meas, scn.motion, None, rows)
    np.testing.assert_array_equal(got, grid_candidates_for(taken, scn.motion))
    taken.value_si = values
    got = grid_candidates_for(meas, scn.motion, None, rows, values)
    np.testing.assert_array_equal(got, grid_candidates_for(taken, scn.motion))


def test_chord_path_on_the_presolve_subset_chooses_the_general_paths_starts(monkeypatch):
    scn, meas = _scaled("bearings-only-2d", 30_000, 3)  # the grid runs on a taken subset
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    subset = ml.presolve_subset(problem)
    assert subset is not None and init.chord_units(subset[0]) is not None
    ys = problem.obs.values[None]
    fast = ml.grid_starts(problem, ys, init.GridSettings(), subset)[0]
    monkeypatch.setattr(init, "chord_units", lambda *_: None)
    general = ml.grid_starts(problem, ys, init.GridSettings(), subset)[0]
    np.testing.assert_array_equal(fast.first(12), general.first(12))
