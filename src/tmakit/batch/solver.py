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

from ..bounds.noise import NoiseModel
from ..frames import wrap_angle
from ..observation import ObservationModel

Array = NDArray[np.float64]


@dataclass
class Evaluation:
    """Reduced residuals and what a step needs, for a batch of parameter vectors."""

    theta: Array      # (B, p)
    nuisance: Array   # (B, k) eliminated (or fixed) nuisance values
    residual: Array   # (B, n) whitened, nuisance projected out
    cost: Array       # (B,)  half the squared whitened residual
    jacobian: Array | None = None  # (B, n, p) whitened, projected


class VarProProblem:
    """Weighted least squares for ``theta`` with linear nuisance parameters eliminated.

    ``fixed_nuisance`` (a vector in ``obs.nuisance_names`` order) makes the nuisance known
    instead of estimated.
    """

    def __init__(self, obs: ObservationModel, noise: NoiseModel | None = None,
                 fixed_nuisance: Array | None = None) -> None:
        self.obs = obs
        # Rows are handled grouped by kind (contiguous slices); see ObservationModel.
        self.noise = noise or NoiseModel(obs.grouped)
        self.k = obs.n_nuisance
        self.p = obs.motion.n_params
        self.fixed = None if fixed_nuisance is None else np.asarray(fixed_nuisance, float)
        self.angle = obs.angle_mask_grouped
        self.has_angle = bool(self.angle.any())

    def group(self, y: Array) -> Array:
        """Data in the set's row order -> the grouped order the solver works in."""
        return np.asarray(y, dtype=float)[..., self.obs.order]

    def evaluate(self, theta: Array, y: Array, nu_lin: Array,
                 with_jacobian: bool = True, nu_star: Array | None = None) -> Evaluation:
        """Eliminate the nuisance at ``theta`` for data ``y`` (B, n, grouped order: see
        :meth:`group`) and return the reduced residual, cost and (optionally) projected
        Jacobian.

        ``nu_lin`` is the current nuisance estimate (the residual is formed about it);
        ``nu_star`` (default ``nu_lin``) a value held fixed for a whole solve, whose
        geometry-free part of the predictions is subtracted from the data exactly once, so
        that the cost is smooth to rounding even with GHz carriers.
        """
        theta = np.asarray(theta, dtype=float)
        # Trial points may sit on a sensor (zero range): their cost is infinite, not an error.
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._evaluate(theta, y, nu_lin, with_jacobian, nu_star)

    def _evaluate(self, theta: Array, y: Array, nu_lin: Array, with_jacobian: bool,
                  nu_star: Array | None) -> Evaluation:
        h0, a_const, a_var, j_theta = self.obs.linearise_grouped(theta, nu_lin, with_jacobian)
        nu_ref = (np.broadcast_to(self.fixed, nu_lin.shape) if self.fixed is not None
                  else nu_lin)
        star = nu_ref if nu_star is None else nu_star
        a = a_const + a_var
        # y - h0 - A nu_ref, arranged so that no two large numbers meet after the first
        # subtraction (which is exact for data close to A_const nu_star).
        shifted = y - np.einsum("bnk,bk->bn", a_const, star)
        e = (shifted - h0 - np.einsum("bnk,bk->bn", a_var, nu_ref)
             - np.einsum("bnk,bk->bn", a_const, nu_ref - star))
        if self.has_angle:
            e = np.where(self.angle, wrap_angle(e), e)
        ew = self.noise.whiten(e)
        if self.fixed is not None or self.k == 0:
            nu = np.array(nu_ref, dtype=float)
            r = ew
            jr = None if j_theta is None else self.noise.whiten(j_theta, axis=-2)
        else:
            aw = self.noise.whiten(a, axis=-2)
            scale = np.sqrt(np.einsum("bnk,bnk->bk", aw, aw))   # (B, k) column norms
            scale = np.where(scale > 0, scale, 1.0)
            q = aw / scale[:, None, :]
            # Columns are scaled to unit norm, so the Gram matrix is well conditioned and its
            # explicit (k x k) inverse is accurate.
            ginv = np.linalg.inv(np.einsum("bnk,bnl->bkl", q, q))
            coef = np.einsum("bkl,bl->bk", ginv, np.einsum("bnk,bn->bk", q, ew))
            nu = nu_ref + coef / scale
            r = ew - np.einsum("bnk,bk->bn", q, coef)
            jr = None
            if j_theta is not None:
                jw = self.noise.whiten(j_theta, axis=-2)
                proj = np.einsum("bkl,blp->bkp", ginv, np.einsum("bnk,bnp->bkp", q, jw))
                jr = jw - np.einsum("bnk,bkp->bnp", q, proj)
        cost = 0.5 * np.einsum("bn,bn->b", r, r)
        cost = np.where(np.isfinite(cost), cost, np.inf)
        return Evaluation(theta, nu, r, cost, jr)

    def initial_nuisance(self, theta: Array, y: Array) -> Array:
        """Nuisance values eliminated at ``theta`` for grouped data ``y`` (needs no prior
        value: the predictions are affine in the nuisance)."""
        b = theta.shape[0]
        if self.fixed is not None:
            return np.broadcast_to(self.fixed, (b, self.k)).copy()
        # Formed about zero, this loses ~1e-16 of the nuisance's magnitude (0.2 uHz of a GHz
        # carrier): ample for a reference about which later residuals are formed.
        return self.evaluate(theta, y, np.zeros((b, self.k)), with_jacobian=False).nuisance


@dataclass
class SolveResult:
    theta: Array        # (B, p)
    nuisance: Array     # (B, k)
    cost: Array         # (B,)
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    evaluation: Evaluation


def levenberg_marquardt(problem: VarProProblem, y: Array, theta0: Array,
                        max_iter: int = 100, ftol: float = 1e-10, xtol: float = 1e-12,
                        gtol: float = 1e-10, dtol: float = 1e-7) -> SolveResult:
    """Batched Levenberg–Marquardt (Marquardt's diagonal scaling) on the reduced problem.

    ``y`` is the data in the measurement set's own row order, ``(n,)`` or ``(B, n)``.

    Converged: a Gauss-Newton decrement (the decrease an undamped step predicts) below ``ftol``
    relative to the cost plus ``dtol``, or an accepted lightly damped step that moves every
    parameter by less than ``xtol`` relative, or a gradient whose cosine with every Jacobian
    column is below ``gtol``.  Runs that stall (damping above 1e12) without meeting a test are
    reported as not converged.
    """
    theta = np.array(theta0, dtype=float, ndmin=2)
    y = np.broadcast_to(problem.group(y), (theta.shape[0], len(problem.obs.meas)))
    b, p = theta.shape
    nu = problem.initial_nuisance(theta, y)
    nu_star = nu.copy()
    cur = problem.evaluate(theta, y, nu, nu_star=nu_star)
    lam = np.full(b, 1e-3)
    active = np.isfinite(cur.cost)
    converged = np.zeros(b, dtype=bool)
    iterations = np.zeros(b, dtype=np.int64)
    for _ in range(max_iter):
        if not np.any(active):
            break
        idx = np.flatnonzero(active)
        jr = cur.jacobian[idx]
        r = cur.residual[idx]
        jtj = np.einsum("bnp,bnq->bpq", jr, jr)
        grad = np.einsum("bnp,bn->bp", jr, r)
        diag = np.einsum("bpp->bp", jtj)
        col = np.sqrt(np.maximum(diag, 1e-300))
        rnorm = np.sqrt(2.0 * cur.cost[idx])[:, None]
        small_grad = np.all(np.abs(grad) <= gtol * col * np.maximum(rnorm, 1e-300), axis=1)
        floor = 1e-12 * np.max(diag, axis=1, keepdims=True)
        damp = np.maximum(diag, floor) * lam[idx, None]
        mat = jtj + damp[:, :, None] * np.eye(p)
        try:
            step = np.linalg.solve(mat, grad[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.stack([np.linalg.lstsq(m, g, rcond=None)[0] for m, g in zip(mat, grad,
                                                                                   strict=True)])
        trial_theta = cur.theta[idx] + step
        trial = problem.evaluate(trial_theta, y[idx], cur.nuisance[idx],
                                 nu_star=nu_star[idx])
        better = trial.cost < cur.cost[idx]
        iterations[idx] += 1
        old_cost = cur.cost[idx]
        acc = idx[better]
        if acc.size:
            cur.theta[acc] = trial.theta[better]
            cur.nuisance[acc] = trial.nuisance[better]
            cur.residual[acc] = trial.residual[better]
            cur.cost[acc] = trial.cost[better]
            cur.jacobian[acc] = trial.jacobian[better]
        lam[idx] = np.where(better, np.maximum(lam[idx] / 3.0, 1e-12), lam[idx] * 4.0)
        # Convergence is judged on the decrease the linearised model predicts for a (nearly)
        # undamped step: the measured decrease is lost in rounding once it falls below
        # ~1e-8 of the cost (data such as 1.9 GHz frequencies carry ~16 digits in all).
        # A heavily damped step is small without being converged, hence the damping test.
        # The Gauss-Newton decrement g' (J'J)^-1 g / 2 does not depend on the damping, so a
        # run sitting at the minimum is recognised even after rounding made a step look worse.
        gn = np.linalg.solve(jtj + floor[:, :, None] * np.eye(p), grad[..., None])[..., 0]
        decrement = 0.5 * np.einsum("bp,bp->b", grad, gn)
        rel_step = np.max(np.abs(step) / (np.abs(cur.theta[idx]) + 1.0), axis=1)
        gauss_newton = lam[idx] <= 1e-2
        # The decrement is half the squared distance to the minimum in standard deviations
        # (the residuals are whitened): dtol = 1e-7 means within 4.5e-4 sigma of it.
        done = small_grad | (decrement <= ftol * old_cost + dtol) | (
            better & gauss_newton & (rel_step <= xtol))
        converged[idx] |= done
        stalled = lam[idx] > 1e12
        active[idx] = ~(done | stalled)
    # Every accepted point carries the nuisance eliminated at its own theta: no re-evaluation.
    return SolveResult(cur.theta, cur.nuisance, cur.cost, iterations, converged, cur)
