"""Batched weighted least squares with the linear nuisance parameters projected out.

Every nuisance parameter of tmakit enters the predictions linearly — carrier and drift
(``f = (f_s + d t)(1 - rdot/c)``), power constant and path-loss exponent
(``P_dB = C_dB - 10 n log10 R``) — so for fixed motion parameters ``theta`` they have a closed-form
weighted least-squares value.  Eliminating them exactly (variable projection, Golub & Pereyra;
the Kaufman approximation of the projected Jacobian) leaves a small, well-conditioned problem
in ``theta`` alone, solved by Levenberg–Marquardt.  This sidesteps the conditioning problem that
000_bc54bd8c50e47249.txt §3 shows for C/C_0 and c/f_s in the parameter vector.

Everything is vectorised over a leading batch axis ``B``: several starting points of one
problem, or many Monte Carlo runs that share times, sensors and noise (each with its own data
``y``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..frames import wrap_angle
from ..observation import Linearisation, ObservationModel
from ..observation.noise import NoiseModel

Array = NDArray[np.float64]


@dataclass
class Evaluation:
    """Reduced residuals and what a step needs, for a batch of parameter vectors."""

    theta: Array      # (B, p)
    nuisance: Array   # (B, k) eliminated (or fixed) nuisance values
    residual: Array   # (B, n) whitened, nuisance projected out
    cost: Array       # (B,)  half the squared whitened residual
    jacobian: Array | None = None  # (B, n, p) whitened, projected

    def take(self, rows: NDArray[np.bool_] | NDArray[np.int64]) -> Evaluation:
        """The evaluations of ``rows`` (a copy)."""
        return Evaluation(self.theta[rows], self.nuisance[rows], self.residual[rows],
                          self.cost[rows], None if self.jacobian is None
                          else self.jacobian[rows])

    def put(self, rows: NDArray[np.bool_] | NDArray[np.int64], other: Evaluation,
            which: NDArray[np.bool_] | NDArray[np.int64] | slice = slice(None)) -> None:
        """Overwrite ``rows`` with ``other``'s evaluations ``which``."""
        self.theta[rows] = other.theta[which]
        self.nuisance[rows] = other.nuisance[which]
        self.residual[rows] = other.residual[which]
        self.cost[rows] = other.cost[which]
        if self.jacobian is not None and other.jacobian is not None:
            self.jacobian[rows] = other.jacobian[which]


class VarProProblem:
    """Weighted least squares for ``theta`` with linear nuisance parameters eliminated.

    ``fixed_nuisance`` (a vector in ``obs.nuisance_names`` order) makes the nuisance known
    instead of estimated.
    """

    def __init__(self, obs: ObservationModel, noise: NoiseModel | None = None,
                 fixed_nuisance: Array | None = None) -> None:
        self.obs = obs
        # Rows are handled grouped by kind (contiguous slices); see ObservationModel.  Only
        # range differences can be correlated: without them the rows' sigmas are the model.
        if noise is None:
            noise = (NoiseModel(obs.grouped) if "range_difference" in obs.models
                     else NoiseModel.independent(obs.sigmas_grouped))
        self.noise = noise
        self.k = obs.n_nuisance
        self.p = obs.motion.n_params
        self.fixed = None if fixed_nuisance is None else np.asarray(fixed_nuisance, float)
        self.angle = obs.angle_mask_grouped
        self.has_angle = bool(self.angle.any())
        self.eliminates = self.fixed is None and self.k > 0
        # The geometry-free part of the design, whitened once (see ObservationModel).
        self.const_design = obs.const_design
        self.const_design_w = self.noise.whiten(self.const_design, axis=-2)
        self._const_w_t = np.ascontiguousarray(self.const_design_w.T)  # (k, n)
        self._reference_fit: tuple[NDArray[np.bool_], NDArray[np.bool_], Array] | None = None
        # One nuisance column per kind at most: the columns touch disjoint rows (whitening
        # mixes rows of one kind only), so they are orthogonal and need no Gram inverse.
        self._orthogonal = all(ns.stop - ns.start <= 1 for ns in obs.nuisance_slices.values())

    def take(self, index: NDArray[np.int64] | NDArray[np.bool_]) -> VarProProblem:
        """The same problem on the rows ``index`` of the set (see
        :meth:`ObservationModel.take`), its noise model made for those rows."""
        obs = self.obs.take(index)
        # Rows of independent rows are independent: no need to look for correlated blocks.
        noise = None if self.noise.correlated else NoiseModel.independent(obs.sigmas_grouped)
        return VarProProblem(obs, noise, self.fixed)

    def group(self, y: Array) -> Array:
        """Data in the set's row order -> the grouped order the solver works in."""
        return np.asarray(y, dtype=float)[..., self.obs.order]

    def reference_nuisance(self, y: Array) -> Array:
        """A nuisance value close to the data's, per data row ``(B, k)``: least squares of the
        geometry-free part of the design on grouped data ``y`` (a carrier near the mean
        received frequency), or the fixed values.  Residuals are formed about it, so that a GHz
        carrier never meets the data in rounding."""
        y = np.atleast_2d(y)
        b = y.shape[0]
        if self.fixed is not None:
            return np.broadcast_to(self.fixed, (b, self.k)).copy()
        if self.k == 0:
            return np.zeros((b, 0))
        if self._reference_fit is None:  # least squares on the rows the design touches
            design = self.const_design
            rows = ~self.angle & (design != 0).any(axis=1)
            cols = (design[rows] != 0).any(axis=0)
            d = design[rows][:, cols]
            size = np.abs(d).max(axis=0) if d.size else np.ones(d.shape[1])
            d = d / size  # columns of unit size: the normal equations are well conditioned
            fit = (np.linalg.solve(d.T @ d, d.T).T if d.size else d) / size
            self._reference_fit = (rows, cols, fit)
        rows, cols, fit = self._reference_fit
        out = np.zeros((b, self.k))
        if rows.any() and cols.any():
            out[:, cols] = y[:, rows] @ fit
        return out

    def data_part(self, y: Array, nu_star: Array) -> Array:
        """``y - A_const nu*`` ``(B, n)`` for grouped data ``y``: the part of the residual that
        does not depend on ``theta``, formed once per solve (the first, exact subtraction of
        two large numbers when the carrier is in GHz)."""
        if self.k == 0:
            return np.array(y, dtype=float)
        return y - nu_star @ self.const_design.T

    def evaluate(self, theta: Array, y: Array, nu_star: Array,
                 with_jacobian: bool = True) -> Evaluation:
        """Eliminate the nuisance at ``theta`` for grouped data ``y`` (B, n) and return the
        reduced residual, cost and (optionally) the projected Jacobian, exact at the
        eliminated nuisance.  Residuals are formed about ``nu_star`` (see
        :meth:`reference_nuisance`)."""
        return self.evaluate_part(theta, self.data_part(y, nu_star), nu_star, with_jacobian)

    def evaluate_part(self, theta: Array, u: Array, nu_star: Array,
                      with_jacobian: bool = True) -> Evaluation:
        """:meth:`evaluate` from the data part ``u`` of :meth:`data_part`."""
        theta = np.asarray(theta, dtype=float)
        # Trial points may sit on a sensor (zero range): their cost is infinite, not an error.
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._evaluate(theta, u, nu_star, with_jacobian)

    def _evaluate(self, theta: Array, u: Array, nu_star: Array, with_jacobian: bool
                  ) -> Evaluation:
        # Worked with the design and the Jacobian transposed, (B, k, n) and (B, p, n): every
        # operation then runs along the rows.
        lin = self.obs.linearisation(theta, with_jacobian)
        at = lin.a_var.swapaxes(-1, -2)
        # y - A_const nu* - h0 - A_var nu*: no two large numbers meet after data_part.
        e = u - lin.h0
        if self.k:
            e -= (nu_star[:, None, :] @ at)[:, 0, :]
        if self.has_angle:
            e = np.where(self.angle, wrap_angle(e), e)
        r = self.noise.whiten(e)
        nu = nu_star
        jt = None
        if self.eliminates:
            nu, r, jt = self._project(lin, nu_star, at, r, with_jacobian)
        elif with_jacobian:
            jt = self.noise.whiten(lin.jacobian(nu).swapaxes(-1, -2))
        cost = 0.5 * np.einsum("bn,bn->b", r, r)
        cost = np.where(cost < np.inf, cost, np.inf)  # nan (no prediction) -> inf
        return Evaluation(theta, np.array(nu, dtype=float), r, cost,
                          None if jt is None else jt.swapaxes(1, 2))

    def _project(self, lin: Linearisation, nu_star: Array, at: Array, r: Array,
                 with_jacobian: bool) -> tuple[Array, Array, Array | None]:
        """Eliminate the nuisance: ``(nu, projected residual, projected Jacobian (B, p, n))``
        for the whitened residual ``r`` about ``nu_star`` and the design ``at`` (B, k, n).

        The design's columns are scaled to unit norm, so the Gram matrix is well conditioned
        and its explicit (k x k) inverse accurate (it is the identity when the columns are
        orthogonal).  A column without weight (all zero) gets coefficient 0."""
        q = self._const_w_t + self.noise.whiten(at)
        norm = np.sqrt(np.einsum("bkn,bkn->bk", q, q))
        empty = norm == 0
        norm[empty] = 1.0
        q /= norm[:, :, None]
        qt = q.swapaxes(1, 2)
        ginv = None
        if not self._orthogonal:
            gram = q @ qt
            gram += np.eye(self.k) * empty[:, None, :]
            ginv = np.linalg.inv(gram)
        coef = q @ r[:, :, None]
        if ginv is not None:
            coef = ginv @ coef
        nu = nu_star + coef[..., 0] / norm
        r = r - (qt @ coef)[..., 0]
        jt = None
        if with_jacobian:
            # Kaufman's projected Jacobian, at the eliminated nuisance.
            jt = self.noise.whiten(lin.jacobian(nu).swapaxes(-1, -2))
            proj = jt @ qt
            if ginv is not None:
                proj = proj @ ginv
            jt = jt - proj @ q
        return nu, r, jt

    def initial_nuisance(self, theta: Array, y: Array) -> Array:
        """Nuisance values eliminated at ``theta`` for grouped data ``y``."""
        y = np.broadcast_to(y, (theta.shape[0], y.shape[-1]))
        return self.evaluate(theta, y, self.reference_nuisance(y), with_jacobian=False).nuisance


@dataclass
class SolveResult:
    theta: Array        # (B, p)
    nuisance: Array     # (B, k)
    cost: Array         # (B,)
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    evaluation: Evaluation
    dominated: NDArray[np.bool_] | None = None  # stopped: bound for a worse minimum


@dataclass
class _Model:
    """The Gauss-Newton model of a batch at its current points, for
    :func:`levenberg_marquardt`: ``J'J`` in variables scaled by the square roots of its
    diagonal (``scale``) as ``v diag(w) v'``, the scaled gradient ``vg`` in that basis, the
    Gauss-Newton decrement (the decrease an undamped step predicts) and whether the gradient is
    orthogonal to every Jacobian column (``gtol``)."""

    w: Array
    v: Array
    vg: Array
    scale: Array
    decrement: Array
    small_grad: NDArray[np.bool_]

    @classmethod
    def at(cls, ev: Evaluation, gtol: float) -> _Model:
        jrt = ev.jacobian.swapaxes(1, 2)
        jtj = jrt @ ev.jacobian
        grad = (jrt @ ev.residual[:, :, None])[..., 0]
        scale = np.sqrt(np.maximum(jtj.diagonal(0, 1, 2), 1e-300))
        w, v = np.linalg.eigh(jtj / (scale[:, :, None] * scale[:, None, :]))
        # eigenvalues floored at 1e-12 of the largest: a rank-deficient J'J gives finite steps
        w = np.maximum(w, 1e-12 * w[:, -1:])
        vg = (v.swapaxes(1, 2) @ (grad / scale)[:, :, None])[..., 0]
        rnorm = np.sqrt(2.0 * ev.cost)[:, None]
        return cls(w, v, vg, scale, 0.5 * (vg * vg / w).sum(axis=1),
                   (np.abs(grad) <= gtol * scale * rnorm).all(axis=1))

    def take(self, rows: NDArray[np.bool_]) -> _Model:
        return _Model(self.w[rows], self.v[rows], self.vg[rows], self.scale[rows],
                      self.decrement[rows], self.small_grad[rows])

    def step(self, lam: Array) -> tuple[Array, Array]:
        """The step at damping ``lam`` (``lam * I`` in the scaled variables) and the decrease
        the model predicts for it."""
        lw = self.w + lam[:, None]
        step = (self.v @ (self.vg / lw)[:, :, None])[..., 0] / self.scale
        vg2 = self.vg * self.vg
        return step, 0.5 * (vg2 * (self.w + 2.0 * lam[:, None]) / (lw * lw)).sum(axis=1)


DOMINANCE_FACTOR = 10.0
"""A run stops as dominated when its cost exceeds the lowest cost reached in its group by more
than this many times its Gauss-Newton decrement (plus :data:`DOMINANCE_MARGIN`)."""
DOMINANCE_MARGIN = 1.0
"""Cost margin (half a chi2 unit per unit) of the dominance test."""


class _Runs:
    """The runs of :func:`levenberg_marquardt` still iterating, compacted (``ids`` their rows
    in the batch), and the final state of every run in ``out``."""

    def __init__(self, out: Evaluation, u: Array, nu_star: Array,
                 groups: NDArray[np.int64] | None, reached: Array | None) -> None:
        b = out.cost.shape[0]
        self.out = out
        self.converged = np.zeros(b, dtype=bool)
        self.dominated = np.zeros(b, dtype=bool)
        self.iterations = np.zeros(b, dtype=np.int64)
        self.ids = np.arange(b)
        self.cur, self.u, self.nu_star, self.groups = out, u, nu_star, groups
        self.reached = reached  # per group, the lowest cost of a stopped run
        self.lam = np.full(b, 1e-3)
        self.grow = np.full(b, 2.0)  # Nielsen's factor for the damping after a failure
        self.model: _Model | None = None
        self.stop(~np.isfinite(out.cost), np.zeros(b, dtype=bool))

    def stop(self, mask: NDArray[np.bool_], converged: NDArray[np.bool_],
             dominated: NDArray[np.bool_] | None = None) -> None:
        """Record the runs ``mask`` as stopped (``converged``, ``dominated`` where set) and
        drop them from the live arrays."""
        if not mask.any():
            return
        ids = self.ids[mask]
        if self.reached is not None:
            np.minimum.at(self.reached, self.groups[mask], self.cur.cost[mask])
        self.converged[ids] = converged[mask]
        if dominated is not None:
            self.dominated[ids] = dominated[mask]
        if self.cur is not self.out:
            self.out.put(ids, self.cur, mask)
        keep = ~mask
        self.ids = self.ids[keep]
        self.cur = self.cur.take(keep)
        self.u, self.nu_star = self.u[keep], self.nu_star[keep]
        self.lam, self.grow = self.lam[keep], self.grow[keep]
        if self.groups is not None:
            self.groups = self.groups[keep]
        if self.model is not None:
            self.model = self.model.take(keep)

    def finish(self) -> None:
        """Write the state of the runs still live (the iteration limit) into ``out``."""
        if self.cur is not self.out and self.ids.size:
            self.out.put(self.ids, self.cur)


def levenberg_marquardt(problem: VarProProblem, y: Array, theta0: Array,
                        max_iter: int = 100, ftol: float = 1e-10, xtol: float = 1e-12,
                        gtol: float = 1e-10, dtol: float = 1e-5,
                        groups: NDArray[np.int64] | None = None,
                        ceiling: Array | None = None) -> SolveResult:
    """Batched Levenberg–Marquardt (Marquardt's diagonal scaling, Nielsen's damping update) on
    the reduced problem.

    ``y`` is the data in the measurement set's own row order, ``(n,)`` or ``(B, n)``.

    Converged: a Gauss-Newton decrement (the decrease an undamped step predicts) below ``ftol``
    relative to the cost plus ``dtol``, or a gradient whose cosine with every Jacobian column is
    below ``gtol`` — both tested before a step is tried, so a converged run costs no further
    evaluation — or an accepted lightly damped step that moves every parameter by less than
    ``xtol`` relative.  Runs that stall (damping above 1e12) without meeting a test are
    reported as not converged.  ``iterations`` counts the steps tried.

    Multi-start: ``groups`` ``(B,)`` labels the runs that fit the same data (the starting
    points of one data set).  A run whose cost exceeds the lowest cost reached in its group
    (or its ``ceiling`` ``(B,)``, a cost reached by an earlier solve) by more than
    :data:`DOMINANCE_FACTOR` times its Gauss-Newton decrement plus :data:`DOMINANCE_MARGIN`
    is heading for a worse minimum than a point already found: it stops, not converged, and is
    marked ``dominated``.
    """
    theta = np.array(theta0, dtype=float, ndmin=2)
    y = np.broadcast_to(problem.group(y), (theta.shape[0], len(problem.obs.meas)))
    b = theta.shape[0]
    nu_star = problem.reference_nuisance(y)
    u = problem.data_part(y, nu_star)
    grouped = groups is not None or ceiling is not None
    reached = None
    if grouped:
        groups = np.zeros(b, dtype=np.int64) if groups is None else np.asarray(groups)
        reached = np.full(int(groups.max()) + 1, np.inf)  # lowest cost of a stopped run
        if ceiling is not None:
            np.minimum.at(reached, groups, np.broadcast_to(ceiling, (b,)))
    # Trial points may sit on a sensor (zero range): infinite cost, not an error.
    with np.errstate(invalid="ignore", divide="ignore"):
        runs = _iterate(problem, _Runs(problem._evaluate(theta, u, nu_star, True), u,
                                       nu_star, groups, reached), max_iter, ftol, xtol,
                        gtol, dtol)
    runs.finish()
    out = runs.out
    # Every accepted point carries the nuisance eliminated at its own theta: no re-evaluation.
    return SolveResult(out.theta, out.nuisance, out.cost, runs.iterations, runs.converged,
                       out, runs.dominated)


def _iterate(problem: VarProProblem, runs: _Runs, max_iter: int, ftol: float, xtol: float,
             gtol: float, dtol: float) -> _Runs:
    """The iterations of :func:`levenberg_marquardt` (see there for the tests)."""
    for _ in range(max_iter):
        if runs.ids.size == 0:
            break
        if runs.model is None:  # a new point for some run: its Gauss-Newton model
            runs.model = _Model.at(runs.cur, gtol)
        cur, model = runs.cur, runs.model
        # The Gauss-Newton decrement is half the squared distance to the minimum in standard
        # deviations (whitened residuals) and does not depend on the damping, so a run sitting
        # at the minimum is recognised even where rounding makes every step look worse;
        # dtol = 1e-5 means within 4.5e-3 sigma, far inside the statistical error.
        done = model.small_grad | (model.decrement <= ftol * cur.cost + dtol)
        beaten = None
        if runs.reached is not None:
            best = runs.reached.copy()  # the lowest cost reached in each group
            np.minimum.at(best, runs.groups, cur.cost)
            beaten = ~done & (cur.cost - DOMINANCE_FACTOR * model.decrement
                              > best[runs.groups] + DOMINANCE_MARGIN)
        runs.stop(done if beaten is None else done | beaten, done, beaten)
        if runs.ids.size == 0:
            break
        cur, model, lam = runs.cur, runs.model, runs.lam
        step, predicted = model.step(lam)
        trial = problem._evaluate(cur.theta + step, runs.u, runs.nu_star, True)
        runs.iterations[runs.ids] += 1
        better = trial.cost < cur.cost
        # Nielsen's update: the damping follows how well the model predicted the decrease.
        gain = np.minimum((cur.cost - trial.cost) / np.maximum(predicted, 1e-300), 1.0)
        shrink = np.maximum(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
        runs.lam = np.where(better, np.maximum(lam * shrink, 1e-12), lam * runs.grow)
        runs.grow = np.where(better, 2.0, 2.0 * runs.grow)
        # A heavily damped step is small without being converged, hence the damping
        # condition on the step test.
        tiny = better & (lam <= 1e-2) & (
            np.abs(step) <= xtol * (np.abs(trial.theta) + 1.0)).all(axis=1)
        if better.all():
            runs.cur, runs.model = trial, None
        elif better.any():
            if runs.cur is runs.out:  # never write into the results of stopped runs
                runs.cur = cur.take(slice(None))
            runs.cur.put(better, trial, better)
            runs.model = None
        runs.stop(tiny | (runs.lam > 1e12), tiny)
    return runs
