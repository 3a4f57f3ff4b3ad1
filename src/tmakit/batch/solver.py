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
        self._const_design: Array | None = None

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
        if self._const_design is None:  # geometry-free: any theta gives it
            with np.errstate(invalid="ignore", divide="ignore"):
                _, a_const, _, _, _ = self.obs.linearise_grouped(
                    np.ones((1, self.p)), derivatives=False)
            self._const_design = a_const[0]
        design = self._const_design
        rows = ~self.angle & np.any(design != 0, axis=1)
        out = np.zeros((b, self.k))
        cols = np.any(design[rows] != 0, axis=0)
        if np.any(rows) and np.any(cols):
            sol, *_ = np.linalg.lstsq(design[np.ix_(rows, cols)], y[:, rows].T, rcond=None)
            out[:, cols] = sol.T
        return out

    def evaluate(self, theta: Array, y: Array, nu_star: Array,
                 with_jacobian: bool = True) -> Evaluation:
        """Eliminate the nuisance at ``theta`` for grouped data ``y`` (B, n) and return the
        reduced residual, cost and (optionally) the projected Jacobian, exact at the
        eliminated nuisance.  Residuals are formed about ``nu_star`` (see
        :meth:`reference_nuisance`)."""
        theta = np.asarray(theta, dtype=float)
        # Trial points may sit on a sensor (zero range): their cost is infinite, not an error.
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._evaluate(theta, y, nu_star, with_jacobian)

    def _evaluate(self, theta: Array, y: Array, nu_star: Array, with_jacobian: bool
                  ) -> Evaluation:
        h0, a_const, a_var, dh0, d_a = self.obs.linearise_grouped(theta, with_jacobian)
        # y - h0 - A nu_star, arranged so that no two large numbers meet after the first
        # subtraction (exact for data close to A_const nu_star).
        e = ((y - np.einsum("bnk,bk->bn", a_const, nu_star)) - h0
             - np.einsum("bnk,bk->bn", a_var, nu_star))
        if self.has_angle:
            e = np.where(self.angle, wrap_angle(e), e)
        ew = self.noise.whiten(e)
        if self.fixed is not None or self.k == 0:
            nu = np.array(nu_star, dtype=float)
            r = ew
            jr = None
            if with_jacobian:
                jr = self.noise.whiten(dh0 + np.einsum("bnkp,bk->bnp", d_a, nu), axis=-2)
        else:
            aw = self.noise.whiten(a_const + a_var, axis=-2)
            scale = np.sqrt(np.einsum("bnk,bnk->bk", aw, aw))   # (B, k) column norms
            scale = np.where(scale > 0, scale, 1.0)
            q = aw / scale[:, None, :]
            # Columns are scaled to unit norm, so the Gram matrix is well conditioned and its
            # explicit (k x k) inverse is accurate.
            ginv = np.linalg.inv(np.einsum("bnk,bnl->bkl", q, q))
            coef = np.einsum("bkl,bl->bk", ginv, np.einsum("bnk,bn->bk", q, ew))
            nu = nu_star + coef / scale
            r = ew - np.einsum("bnk,bk->bn", q, coef)
            jr = None
            if with_jacobian:
                # Kaufman's projected Jacobian, at the eliminated nuisance.
                jw = self.noise.whiten(dh0 + np.einsum("bnkp,bk->bnp", d_a, nu), axis=-2)
                proj = np.einsum("bkl,blp->bkp", ginv, np.einsum("bnk,bnp->bkp", q, jw))
                jr = jw - np.einsum("bnk,bkp->bnp", q, proj)
        cost = 0.5 * np.einsum("bn,bn->b", r, r)
        cost = np.where(np.isfinite(cost), cost, np.inf)
        return Evaluation(theta, nu, r, cost, jr)

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
    b = theta.shape[0]
    nu_star = problem.reference_nuisance(y)
    cur = problem.evaluate(theta, y, nu_star)
    lam = np.full(b, 1e-3)
    active = np.isfinite(cur.cost)
    converged = np.zeros(b, dtype=bool)
    iterations = np.zeros(b, dtype=np.int64)
    for _ in range(max_iter):
        if not np.any(active):
            break
        # Slices (views) when every run is still going: the common case.
        idx = slice(None) if active.all() else np.flatnonzero(active)
        jr, r = cur.jacobian[idx], cur.residual[idx]
        jrt = np.swapaxes(jr, 1, 2)
        jtj = jrt @ jr
        grad = (jrt @ r[..., None])[..., 0]
        # Marquardt's scaling: in variables scaled by sqrt(diag J'J) the damping is lam * I,
        # so one eigen-decomposition gives the damped step and the Gauss-Newton decrement.
        scale = np.sqrt(np.maximum(np.diagonal(jtj, axis1=1, axis2=2), 1e-300))
        w, v = np.linalg.eigh(jtj / (scale[:, :, None] * scale[:, None, :]))
        w = np.maximum(w, 1e-12 * w[:, -1:])
        vg = (np.swapaxes(v, 1, 2) @ (grad / scale)[..., None])[..., 0]
        lam_i = lam[idx]
        step = (v @ (vg / (w + lam_i[:, None]))[..., None])[..., 0] / scale
        decrement = 0.5 * np.sum(vg * vg / w, axis=1)
        old_cost = cur.cost[idx]
        rnorm = np.sqrt(2.0 * old_cost)[:, None]
        small_grad = np.all(np.abs(grad) <= gtol * scale * rnorm, axis=1)
        trial = problem.evaluate(cur.theta[idx] + step, y[idx], nu_star[idx])
        better = trial.cost < old_cost
        iterations[idx] += 1
        if np.any(better):
            where = (np.flatnonzero(better) if isinstance(idx, slice)
                     else idx[better])
            cur.theta[where] = trial.theta[better]
            cur.nuisance[where] = trial.nuisance[better]
            cur.residual[where] = trial.residual[better]
            cur.cost[where] = trial.cost[better]
            cur.jacobian[where] = trial.jacobian[better]
        lam[idx] = np.where(better, np.maximum(lam_i / 3.0, 1e-12), lam_i * 4.0)
        # The Gauss-Newton decrement is half the squared distance to the minimum in standard
        # deviations (whitened residuals) and does not depend on the damping, so a run sitting
        # at the minimum is recognised even after rounding made a step look worse; dtol = 1e-7
        # means within 4.5e-4 sigma.  A heavily damped step is small without being converged,
        # hence the damping condition on the step test.
        rel_step = np.max(np.abs(step) / (np.abs(cur.theta[idx]) + 1.0), axis=1)
        done = small_grad | (decrement <= ftol * old_cost + dtol) | (
            better & (lam_i <= 1e-2) & (rel_step <= xtol))
        converged[idx] |= done
        active[idx] = ~(done | (lam[idx] > 1e12))
    # Every accepted point carries the nuisance eliminated at its own theta: no re-evaluation.
    return SolveResult(cur.theta, cur.nuisance, cur.cost, iterations, converged, cur)
