"""The fast paths of the batch solver give what the plain definitions give.

- the observation model's linearisation (predictions affine in the nuisance, derivatives with
  respect to the relative state, chained to theta) against ``predict`` and finite differences,
  for every kind, affine and non-affine motion, small and large batches (memory layouts);
- the constant-velocity model's affine map against its states;
- the multi-start Levenberg-Marquardt with early stops of dominated starts against each start
  solved alone;
- the grid: shared nuisance projection against the exact reduced cost, lazy selection of
  distinct starts;
- ``Scenario.simulate_many`` against ``simulate``; the blocked matrix product against ``@``;
- held parameters (``free``) against the model without them, and the manoeuvre search's
  schedule (``damping="factors"``, ``max_reject``, ``stall``, pruning by ``dominance``)
  against the search's former private solver, kept here as the reference.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch import VarProProblem, levenberg_marquardt
from tmakit.batch.init import GridScorer, Starts, best_starts_many, grid_candidates
from tmakit.core.blas import matmul
from tmakit.data import MeasurementSet
from tmakit.motion import PiecewiseCurvilinear, Stationary


def _with_elevation(meas: MeasurementSet) -> MeasurementSet:
    """``meas`` plus elevation rows at the times of its bearings (values do not matter)."""
    rows = meas.take(meas.kind == "bearing")
    rows.kind = np.full(len(rows), "elevation")
    return MeasurementSet.concatenate([meas, rows])


def _cases():
    gu = tk.load_scenario("gu2007")
    cases = [("gu2007", gu.simulate(1), gu.motion, gu.measurement_options, gu.theta),
             ("gu2007 drift, free exponent", gu.simulate(1), gu.motion,
              {"frequency": {"drift": True}, "power": {"exponent": None}}, gu.theta)]
    for name in ("chen-sun-1", "hoerst2010", "hurtado2008"):
        scn = tk.load_scenario(name)
        cases.append((name, scn.simulate(1), scn.motion, scn.measurement_options, scn.theta))
    hur = tk.load_scenario("hurtado2008")
    meas3 = _with_elevation(hur.simulate(1))
    cv3 = tk.ConstantVelocity(3, hur.motion.ref_time)
    theta3 = np.insert(hur.theta, [2, 4], [150.0, 1.5])
    cases.append(("cv3d with elevation", meas3, cv3, hur.measurement_options, theta3))
    cases.append(("stationary", gu.simulate(1), Stationary(2), gu.measurement_options,
                  gu.theta[:2]))
    curv = PiecewiseCurvilinear(0, gu.motion.ref_time)
    speed = float(np.hypot(gu.theta[2], gu.theta[3]))
    course = float(np.arctan2(gu.theta[2], gu.theta[3]))
    cases.append(("curvilinear (not affine)", gu.simulate(1), curv, gu.measurement_options,
                  np.array([gu.theta[0], gu.theta[1], speed, course, 0.3, -0.2])))
    return cases


CASES = _cases()


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_linearisation_matches_predictions_and_finite_differences(case):
    _, meas, motion, options, theta = case
    obs = tk.ObservationModel(meas, motion, options)
    rng = np.random.default_rng(0)
    nu = obs.nuisance_vector({"carrier": 1.9e9, "carrier_drift": 0.3,
                              "power_constant_db": -40.0, "path_loss_exponent": 2.2})
    thetas = theta + rng.normal(size=(5, theta.size)) * np.maximum(np.abs(theta), 1.0) * 0.05
    lin = obs.linearisation(thetas)
    pred = lin.h0 + np.einsum("bnk,k->bn", obs.const_design + lin.a_var, nu)
    np.testing.assert_allclose(pred, obs.predict_grouped(thetas, nu), rtol=1e-12, atol=1e-9)
    jac = lin.jacobian(nu)
    reference = _chained_model_jacobians(obs, thetas, nu)
    np.testing.assert_allclose(jac, reference, rtol=1e-10,
                               atol=1e-12 * np.abs(reference).max())
    # and, away from the GHz carrier's rounding, finite differences of the predictions
    fd_rows = ~np.isin(obs.grouped.kind, ["frequency"])
    for j in range(theta.size):
        h = 1e-6 * max(1.0, abs(theta[j]))
        up, down = thetas.copy(), thetas.copy()
        up[:, j] += h
        down[:, j] -= h
        fd = (obs.predict_grouped(up, nu) - obs.predict_grouped(down, nu)) / (2 * h)
        scale = np.abs(fd).max() + 1e-300
        assert np.abs(jac[..., fd_rows, j] - fd[..., fd_rows]).max() <= 1e-4 * scale
    # one vector, a small batch and a batch larger than the rows (values only): same numbers
    one = obs.linearisation(thetas[0])
    np.testing.assert_allclose(one.h0, lin.h0[0], rtol=1e-14, atol=1e-9)
    np.testing.assert_allclose(one.jacobian(nu), jac[0], rtol=1e-12, atol=1e-12)
    many = np.repeat(thetas, len(meas) // 5 + 2, axis=0)
    big = obs.linearisation(many, derivatives=False)
    np.testing.assert_allclose(big.h0[::len(meas) // 5 + 2], lin.h0, rtol=1e-14, atol=1e-9)
    np.testing.assert_allclose(big.a_var[::len(meas) // 5 + 2], lin.a_var, rtol=1e-14,
                               atol=1e-18)


def _chained_model_jacobians(obs, thetas, nu):
    """``d predictions / d theta`` the plain way: each model's own ``jacobian`` at the states
    of ``motion.states``, chained with ``motion.jacobian`` (grouped order)."""
    g, motion = obs.grouped, obs.motion
    out = np.zeros((thetas.shape[0], len(g), motion.n_params))
    for kind, model in obs.models.items():
        sl, ns = obs.slices[kind], obs.nuisance_slices[kind]
        t = g.time[sl]
        rel = motion.states(thetas, t) - g.sensor_state[sl]
        ref = None
        if kind == "range_difference":
            ref = motion.states(thetas, g.time_ref[sl]) - g.ref_sensor_state[sl]
        d = model.jacobian(rel, t, nu[ns], ref)
        out[:, sl] = np.einsum("bni,bnip->bnp", d.rel, motion.jacobian(thetas, t))
        if d.rel_ref is not None:
            out[:, sl] += np.einsum("bni,bnip->bnp", d.rel_ref,
                                    motion.jacobian(thetas, g.time_ref[sl]))
    return out


def test_constant_velocity_component_terms_give_the_states():
    cv = tk.ConstantVelocity(3, ref_time=10.0)
    t = np.linspace(0.0, 100.0, 7)
    terms, offset = cv.component_terms(t)
    theta = np.array([100.0, -2000.0, 300.0, 12.0, -7.0, 0.5])
    states = np.array(offset, dtype=float)
    for i, c, coef in terms:
        states[c] += theta[i] * (1.0 if coef is None else coef)
    np.testing.assert_allclose(states.T, cv.states(theta, t), rtol=1e-14)
    assert PiecewiseCurvilinear(0).component_terms(t) is None


@pytest.fixture(scope="module")
def gu_problem():
    gu = tk.load_scenario("gu2007")
    meas = gu.simulate(7)
    obs = tk.ObservationModel(meas, gu.motion, gu.measurement_options)
    return VarProProblem(obs), obs.values


def test_dominated_starts_stop_early_without_changing_the_best_fit(gu_problem):
    problem, y = gu_problem
    starts = best_starts_many(problem, y[None])[0].first(8)
    alone = levenberg_marquardt(problem, y, starts)
    together = levenberg_marquardt(problem, y, starts, groups=np.zeros(len(starts), int))
    assert together.cost.min() == pytest.approx(alone.cost.min(), rel=1e-9)
    best = int(np.argmin(together.cost))
    assert together.converged[best]
    np.testing.assert_allclose(together.theta[best], alone.theta[np.argmin(alone.cost)],
                               rtol=1e-6)
    # the stopped starts really were bound for worse minima, and cost fewer iterations
    stopped = together.dominated
    assert stopped.any()
    assert np.all(alone.cost[stopped] > together.cost.min() + 1.0)
    assert together.iterations.sum() < alone.iterations.sum()
    assert not np.any(together.converged & together.dominated)


def test_grid_cost_with_a_shared_projection_is_the_reduced_cost(gu_problem):
    problem, y = gu_problem
    truth = tk.load_scenario("gu2007").theta
    near_truth = truth + np.random.default_rng(2).normal(size=(10, 4)) * [30, 30, 0.5, 0.5]
    cand = np.vstack([grid_candidates(problem)[::37], near_truth])
    scorer = GridScorer(problem, cand)
    assert scorer.shared is not None  # the carrier's design is the same for every candidate
    grid = scorer.score(problem.group(y)[None])[0]
    yb = np.broadcast_to(problem.group(y), (cand.shape[0], y.size))
    exact = problem.evaluate(cand, yb, problem.reference_nuisance(yb), False).cost
    ok = np.isfinite(exact)
    # The shared projection takes the Doppler factor 1 - rdot/c of the carrier's column as 1:
    # off by ~1e-6 relative for candidates millions of chi2 units away, and by less than 0.01
    # of a chi2 unit near the data: far below the grid's spacing.
    assert np.all(np.abs(grid[ok] - exact[ok]) <= 1e-5 * exact[ok])
    near = ok & (exact < 1e4)
    assert near.sum() >= 10
    assert np.all(np.abs(grid[near] - exact[near]) < 1e-2)


def test_starts_are_distinct_best_first_and_extend_lazily(gu_problem):
    problem, y = gu_problem
    cand = grid_candidates(problem)
    cost = GridScorer(problem, cand).score(problem.group(y)[None])[0]
    lazy = Starts(cand, cost)
    first = lazy.first(3)
    more = lazy.first(10)
    np.testing.assert_array_equal(more[:3], first)
    np.testing.assert_array_equal(Starts(cand, cost).first(10), more)
    spread = np.maximum(np.abs(cand).max(axis=0), 1.0)
    for i in range(10):
        for j in range(i):
            assert np.max(np.abs(more[i] - more[j]) / spread) > 0.05
    assert np.array_equal(more[0], cand[np.argmin(cost)])


@pytest.mark.parametrize("name", ["gu2007", "chen-sun-1"])
def test_simulate_many_is_simulate_run_by_run(name):
    scn = tk.load_scenario(name)
    many = scn.simulate_many([np.random.default_rng(s) for s in (3, 4)])
    for s, meas in zip((3, 4), many, strict=True):
        one = scn.simulate(np.random.default_rng(s))
        np.testing.assert_array_equal(meas.value, one.value)
        np.testing.assert_array_equal(meas.time, one.time)
        np.testing.assert_array_equal(meas.kind, one.kind)
        assert meas.metadata == one.metadata


@pytest.mark.parametrize("split", [False, True])
def test_blocked_matmul_is_the_matrix_product_split_or_not(split):
    """Splitting is opt-in (a process-wide setting) and changes no product."""
    from tmakit.core import blas

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(3000, 40)), rng.normal(size=(40, 70))
    a3 = rng.normal(size=(2, 3000, 40))
    assert blas._SPLIT is False  # off unless asked
    blas.split_products(split)
    try:
        np.testing.assert_allclose(matmul(a, b), a @ b, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(matmul(a3, b), a3 @ b, rtol=1e-12, atol=1e-12)
    finally:
        blas.split_products(False)


def test_normal_equations_by_dots_are_the_products_and_ignore_the_thread_count():
    from threadpoolctl import threadpool_limits

    from tmakit.batch.solver import gram, normal_equations
    from tmakit.core.blas import DOT_ROWS, by_dots, normal_rows

    rng = np.random.default_rng(2)
    n = 3 * DOT_ROWS + 17  # (a last block shorter than the others)
    rows = rng.normal(size=(4, n)) * np.exp(rng.normal(size=n) * 3)  # sums that round
    r = rng.normal(size=n)
    jtj, jtr = normal_rows(rows, r)
    want = rows @ rows.T
    np.testing.assert_allclose(jtj, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    np.testing.assert_allclose(jtr, rows @ r, rtol=1e-11, atol=1e-12 * np.abs(rows @ r).max())
    assert np.array_equal(jtj, jtj.T)
    with threadpool_limits(2, user_api="blas"):
        two = normal_rows(rows, r)
    with threadpool_limits(1, user_api="blas"):
        one = normal_rows(rows, r)
    assert np.array_equal(two[0], one[0]) and np.array_equal(two[1], one[1])
    # Which Jacobians go by dots: many rows, few columns, each column contiguous.
    assert by_dots(rows.T) and not by_dots(np.ascontiguousarray(rows.T))
    assert not by_dots(rows[:, :DOT_ROWS - 1].T) and not by_dots(rng.normal(size=(7, n)).T)
    # The solver's normal equations and gram take that path for one run.
    ev = SimpleNamespace(normal=None, jacobian=rows.T[None], residual=r[None])
    got_jtj, got_jtr = normal_equations(ev, None)
    assert np.array_equal(got_jtj[0], jtj) and np.array_equal(got_jtr[0], jtr)
    assert np.array_equal(gram(rows.T), jtj)


# -- held parameters and the manoeuvre search's schedule --------------------------------------


def _former_search_lm(problem, y, theta0, free, max_iter, rtol=1e-3, atol=0.02, prune=None,
                      best=np.inf, max_reject=40, stall=0.0):
    """The manoeuvre search's own Levenberg–Marquardt before issue 10 (then the private
    ``tmakit.batch.curvilinear._lm``), verbatim but for its Gram helper: the reference that
    ``levenberg_marquardt(..., free=, damping="factors", max_reject=, stall=, dominance=)``
    must reproduce."""
    from tmakit.core.blas import SINGLE_THREAD_WORK

    def gram(j):
        n, p = j.shape[-2:]
        jt = np.swapaxes(j, -1, -2)
        block = max(1, SINGLE_THREAD_WORK // max(1, p * p))
        if n <= block:
            return jt @ j
        out = np.zeros((*j.shape[:-2], p, p))
        for lo in range(0, n, block):
            out += jt[..., lo:lo + block] @ j[..., lo:lo + block, :]
        return out

    theta = np.array(theta0, dtype=float)
    b = theta.shape[0]
    yb = np.broadcast_to(y, (b, y.shape[-1]))
    nu_star = problem.reference_nuisance(yb)
    cur = problem.evaluate(theta, yb, nu_star)
    lam = np.full(b, 1e-3)
    active = np.isfinite(cur.cost)
    converged = np.zeros(b, dtype=bool)
    iterations = np.zeros(b, dtype=np.int64)
    rejected = np.zeros(b, dtype=np.int64)
    history = [cur.cost.copy()]
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        jr = cur.jacobian[idx][:, :, free]
        r = cur.residual[idx]
        jtj = gram(jr)
        grad = (np.swapaxes(jr, 1, 2) @ r[..., None])[..., 0]
        scale = np.sqrt(np.maximum(np.diagonal(jtj, axis1=1, axis2=2), 1e-300))
        w, v = np.linalg.eigh(jtj / (scale[:, :, None] * scale[:, None, :]))
        w = np.maximum(w, 1e-12 * w[:, -1:])
        vg = np.einsum("bpq,bp->bq", v, grad / scale)
        lam_i = lam[idx]
        step = np.einsum("bpq,bq->bp", v, vg / (w + lam_i[:, None])) / scale
        decrement = 0.5 * np.sum(vg * vg / w, axis=1)
        done = decrement <= rtol * cur.cost[idx] + atol
        converged[idx[done]] = True
        active[idx[done]] = False
        keep = ~done
        if prune is not None:
            top = min(best, float(np.min(cur.cost)))
            hopeless = cur.cost[idx] - 2.0 * decrement > top + prune
            active[idx[hopeless & keep]] = False
            keep &= ~hopeless
        idx, step, lam_i = idx[keep], step[keep], lam_i[keep]
        if idx.size == 0:
            break
        full = np.zeros((idx.size, theta.shape[1]))
        full[:, free] = step
        trial = problem.evaluate(cur.theta[idx] + full, yb[idx], nu_star[idx])
        better = trial.cost < cur.cost[idx]
        where = idx[better]
        cur.theta[where] = trial.theta[better]
        cur.nuisance[where] = trial.nuisance[better]
        cur.residual[where] = trial.residual[better]
        cur.cost[where] = trial.cost[better]
        cur.jacobian[where] = trial.jacobian[better]
        iterations[idx] += 1
        lam[idx] = np.where(better, np.maximum(lam_i / 3.0, 1e-12), lam_i * 4.0)
        rejected[idx] = np.where(better, 0, rejected[idx] + 1)
        active[idx] = (rejected[idx] < max_reject) & (lam[idx] <= 1e12)
        history.append(cur.cost.copy())
        if stall > 0 and len(history) > 6:
            with np.errstate(invalid="ignore"):
                active &= ~(history[-7] - history[-1] < stall)
    return cur.theta, cur.cost, converged, iterations


@pytest.fixture(scope="module")
def manoeuvre_problem():
    """One manoeuvre on the first 700 s of the Hörst & Oispuu (2010) data, and starts with the
    change-over time spread around the truth's (internal parameters of the search)."""
    from tmakit.batch.manoeuvre import ManoeuvreSearch, ManoeuvreSettings

    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=5)
    meas = meas.take(meas.time <= 700.0)
    problem = ManoeuvreSearch(meas, None, None, ManoeuvreSettings(max_manoeuvres=1)).problem(1)
    base = np.array([-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, 0.0, 0.0, 0.4, 400.0])
    starts = np.tile(base, (7, 1))
    starts[:, -1] += [-120.0, -60.0, -20.0, 0.0, 25.0, 70.0, 130.0]
    starts[:, 0] += np.linspace(-300.0, 300.0, 7)
    return problem, starts


@pytest.mark.parametrize("settings", [
    dict(max_iter=12, held_time=True, prune=25.0),                              # profile
    dict(max_iter=100, rtol=1e-10, atol=1e-7, prune=25.0, max_reject=8, stall=1e-3),  # refine
    dict(max_iter=30, rtol=0.0, atol=0.02, max_reject=8, stall=1e-2, prune=3.7,
         best=2000.0, held_accel=True),                                         # selection
    dict(max_iter=50, rtol=1e-10, atol=1e-7, held_time=True),                   # corner test
    dict(max_iter=40, prune=1.0, max_reject=2, stall=5.0, bad_turns=True),      # early stops
    dict(max_iter=60, rtol=1e-12, atol=1e-9, stall=5.0, bad_turns=True),        # stalls
], ids=["profile", "refine", "selection", "corner", "pruned-rejected", "stalled"])
def test_the_shared_solver_reproduces_the_former_search_solver(manoeuvre_problem, settings,
                                                               monkeypatch):
    from tmakit.batch import varpro
    from tmakit.batch.manoeuvre import lm_fit

    problem, starts = manoeuvre_problem
    kw = dict(settings)
    free = np.ones(problem.p, dtype=bool)
    if kw.pop("held_time", False):
        free[-1] = False
    if kw.pop("held_accel", False):
        free[4] = False
        starts = starts.copy()
        starts[:, 4] = 0.0
    if kw.pop("bad_turns", False):  # starts far off: runs stop on every early rule
        starts = starts.copy()
        starts[:, 7] = [0.1, 0.8, -0.3, 0.4, 1.5, 0.2, 0.05]
    max_iter = kw.pop("max_iter")
    sol = lm_fit(problem, starts, free, max_iter, **kw)  # (J'J by segments, with numba)
    monkeypatch.setattr(varpro, "motion_normal", lambda *args: None)  # the Jacobian itself
    theta, cost, converged, iterations = _former_search_lm(
        problem, problem.group(problem.obs.values), starts, free, max_iter, **kw)
    np.testing.assert_array_equal(sol.iterations, iterations)
    np.testing.assert_array_equal(sol.converged, converged)
    np.testing.assert_allclose(sol.cost, cost, rtol=1e-9)
    np.testing.assert_allclose(sol.theta, theta, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(sol.theta[:, ~free], starts[:, ~free])  # held: untouched


def test_held_parameters_fit_as_the_reduced_model(gu_problem):
    """Holding parameters by ``free`` is fitting the model without them; all free is no
    mask at all, to the last bit."""
    from tmakit.motion import FixedParameters

    problem, y = gu_problem
    gu = tk.load_scenario("gu2007")
    start = gu.theta + np.array([400.0, -300.0, 2.0, -1.5])
    every = levenberg_marquardt(problem, y, start[None])
    masked = levenberg_marquardt(problem, y, start[None], free=np.ones(4, dtype=bool))
    np.testing.assert_array_equal(masked.theta, every.theta)
    np.testing.assert_array_equal(masked.iterations, every.iterations)
    free = np.array([True, True, False, True])  # vx held at its start value
    held = levenberg_marquardt(problem, y, start[None], free=free)
    assert held.converged[0] and held.theta[0, 2] == start[2]
    reduced_model = FixedParameters(gu.motion, {"vx": float(start[2])})
    reduced = VarProProblem(tk.ObservationModel(problem.obs.meas, reduced_model,
                                                gu.measurement_options))
    alone = levenberg_marquardt(reduced, y, start[free][None])
    assert held.cost[0] == pytest.approx(alone.cost[0], rel=1e-9)
    np.testing.assert_allclose(held.theta[0, free], alone.theta[0], rtol=1e-7)
    with pytest.raises(ValueError, match="damping"):
        levenberg_marquardt(problem, y, start[None], damping="fast")


def test_an_evaluation_by_blocks_of_points_is_the_evaluation_at_once(gu_problem, monkeypatch):
    """Blocks of 16 points (the last point joins the last block: a point alone takes other
    paths), into new arrays or a spare's: the same bits and memory layout as one evaluation of
    every point."""
    from tmakit.batch import varpro

    problem, y = gu_problem
    assert problem.eliminates
    gu = tk.load_scenario("gu2007")
    theta = gu.theta + np.random.default_rng(4).standard_normal((33, 4)) * [3e3, 3e3, 5.0, 5.0]
    theta[5, :2] = problem.obs.meas.sensor_state[0, :2]  # on a sensor: no prediction
    u = np.repeat(y[None], 33, 0)
    nu_star = problem.reference_nuisance(u)
    u = problem.data_part(u, nu_star)
    with np.errstate(invalid="ignore", divide="ignore"):
        whole = problem._evaluate(theta, u, nu_star, True)
    monkeypatch.setattr(varpro, "BLOCK_WORK", 1)  # blocks of FEWEST_PER_BLOCK points
    assert varpro._starts_per_block(u.shape[1]) == 16
    spare = problem.evaluate_part(theta[::-1], u, nu_star, True)
    for given in (None, spare):
        blocks = problem.evaluate_part(theta, u, nu_star, True, spare=given)
        for name in ("nuisance", "residual", "cost", "jacobian"):
            got, want = getattr(blocks, name), getattr(whole, name)
            np.testing.assert_array_equal(got, want, err_msg=name)
            assert got.strides == want.strides, name
    assert np.shares_memory(blocks.jacobian, spare.jacobian)  # the spare's arrays were taken
    assert whole.cost[5] == np.inf


def test_the_solver_gives_the_same_bits_with_fresh_arrays_for_every_trial(gu_problem,
                                                                         monkeypatch):
    """Trials written into the arrays of evaluations no longer read change nothing."""
    from tmakit.batch import varpro

    problem, y = gu_problem
    starts = best_starts_many(problem, y[None])[0].first(40)
    reused = levenberg_marquardt(problem, y, starts, groups=np.zeros(len(starts), int))
    taken = []
    real = varpro._buffers

    def fresh(spare, *shape):
        taken.append(spare is not None)
        return real(None, *shape)

    monkeypatch.setattr(varpro, "_buffers", fresh)
    alone = levenberg_marquardt(problem, y, starts, groups=np.zeros(len(starts), int))
    assert sum(taken) >= 2  # (trials were offered a spare)
    for name in ("theta", "nuisance", "cost", "iterations", "converged", "dominated"):
        np.testing.assert_array_equal(getattr(reused, name), getattr(alone, name), err_msg=name)
