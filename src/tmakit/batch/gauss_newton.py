"""The Gauss-Newton model of :func:`tmakit.batch.solver.levenberg_marquardt` at a batch of points.

``J'J`` and ``J'r`` of the whitened, projected Jacobian, the eigen-decomposition of ``J'J`` in
variables scaled by the square roots of its diagonal (Marquardt (1963)), and from it the
Gauss-Newton decrement and the step at any damping.  A single run (the commonest solve) is
built in 2-D arrays with LAPACK's ``dsyevd`` called directly (:func:`tmakit.core.linalg.eigh`):
NumPy's batched ``eigh`` costs several times the decomposition of a small matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from ..core.blas import SINGLE_THREAD_WORK, by_dots, normal_rows
from ..core.linalg import eigh
from .varpro import Evaluation, VarProProblem

__all__ = ["POLISH_INFORMATION", "GaussNewtonModel", "gram", "information_of",
           "information_steady", "normal_equations"]


def gram(j: Array) -> Array:
    """Form ``J^T J`` ``(B, p, p)`` of ``J`` ``(B, n, p)`` (or ``(p, p)`` of ``(n, p)``)."""
    n, p = j.shape[-2:]
    if j.ndim == 2 and by_dots(j):
        return normal_rows(j.T)[0]
    jt = np.swapaxes(j, -1, -2)
    block = max(1, SINGLE_THREAD_WORK // max(1, p * p))
    if n <= block:
        return jt @ j
    out = np.zeros((*j.shape[:-2], p, p))
    for lo in range(0, n, block):
        out += jt[..., lo:lo + block] @ j[..., lo:lo + block, :]
    return out


def information_of(problem: VarProProblem, ev: Evaluation, run: int,
                   known: Array | None = None) -> Array | None:
    """Give the Fisher information ``J' R^-1 J`` at run ``run``'s evaluated point, if it has it."""
    if problem.eliminates:
        return None
    if known is not None and np.all(np.isfinite(known[run])):
        return np.array(known[run], dtype=float)
    if ev.normal is not None:
        return np.array(ev.normal[0][run], dtype=float)
    if ev.jacobian is None:
        return None
    return gram(ev.jacobian[run])


_DIRECT_EIGH = 32  # largest matrix decomposed by a direct LAPACK call


def _selected_layout(jac: Array) -> bool:
    """Whether ``jac`` ``(B, n, q)`` lies in memory as ``jac[:, :, mask]`` would copy it."""
    b, n, _ = jac.shape
    size = jac.itemsize
    return jac.dtype == np.float64 and jac.strides == (size * n, size, size * n * b)


def normal_equations(ev: Evaluation, free: NDArray[np.bool_] | None) -> tuple[Array, Array]:
    """Give ``J'J`` ``(B, p, p)`` and ``J'r`` ``(B, p)`` at ``ev`` over the ``free`` columns."""
    if ev.normal is not None:  # summed over row chunks (large problems)
        jtj, grad = ev.normal
        if free is not None:
            jtj, grad = jtj[:, free][:, :, free], grad[:, free]
        return jtj, grad
    jac = ev.jacobian
    assert jac is not None  # an evaluation without its normal equations has its Jacobian
    if free is not None and (jac.shape[-1] == free.size or not _selected_layout(jac)):
        # a Jacobian of the free columns only is copied the same way (the same products)
        keep = free if jac.shape[-1] == free.size else np.ones(jac.shape[-1], np.bool_)
        jac = jac[:, :, keep]
    if jac.shape[0] == 1:  # one run: 2-D products (cheaper calls than batched ones)
        if by_dots(jac[0]):
            jtj, jtr = normal_rows(jac[0].T, ev.residual[0])
            assert jtr is not None  # (given the residuals)
            return jtj[None], jtr[None]
        return gram(jac[0])[None], ev.residual[0].dot(jac[0])[None]
    return gram(jac), (jac.swapaxes(1, 2) @ ev.residual[:, :, None])[..., 0]


@dataclass
class GaussNewtonModel:
    """The Gauss-Newton model of a batch at its current points, in diagonally scaled variables.

    Parameters
    ----------
    w, v : ndarray
        ``(B, p)`` eigenvalues and ``(B, p, p)`` eigenvectors of the scaled ``J'J``.
    vg : ndarray
        ``(B, p)`` the scaled gradient in that basis.
    scale : ndarray
        ``(B, p)`` square roots of the diagonal of ``J'J``.
    decrement : ndarray
        ``(B,)`` the Gauss-Newton decrement (half chi2).
    small_grad : ndarray of bool
        ``(B,)`` the gradient test met.
    jtj : ndarray, optional
        ``(B, p, p)`` ``J'J`` itself.
    """

    w: Array
    v: Array
    vg: Array
    scale: Array
    decrement: Array
    small_grad: NDArray[np.bool_]
    jtj: Array | None = None

    @classmethod
    def at(cls, ev: Evaluation, gtol: float, free: NDArray[np.bool_] | None) -> GaussNewtonModel:
        """Build the model at the evaluated points ``ev`` (over the ``free`` columns)."""
        jtj, grad = normal_equations(ev, free)
        if jtj.shape[0] == 1 and jtj.shape[1] <= _DIRECT_EIGH:
            one = cls._one(jtj[0], grad[0], float(ev.cost[0]), gtol)
            if one is not None:
                return one
        scale = np.sqrt(np.maximum(jtj.diagonal(0, 1, 2), 1e-300))
        w, v = np.linalg.eigh(jtj / (scale[:, :, None] * scale[:, None, :]))
        # eigenvalues floored at 1e-12 of the largest: a rank-deficient J'J gives finite steps
        w = np.maximum(w, 1e-12 * w[:, -1:])
        vg = (v.swapaxes(1, 2) @ (grad / scale)[:, :, None])[..., 0]
        rnorm = np.sqrt(2.0 * ev.cost)[:, None]
        return cls(w, v, vg, scale, 0.5 * (vg * vg / w).sum(axis=1),
                   np.asarray((np.abs(grad) <= gtol * scale * rnorm).all(axis=1)), jtj)

    @classmethod
    def _one(cls, jtj: Array, grad: Array, cost: float, gtol: float) -> GaussNewtonModel | None:
        """Build a single run's model as :meth:`at` does, in 2-D arrays (fewer calls)."""
        scale = np.sqrt(np.maximum(jtj.diagonal(), 1e-300))
        try:
            w, v = eigh(jtj / np.multiply.outer(scale, scale))
        except np.linalg.LinAlgError:
            return None
        w = np.maximum(w, 1e-12 * w[-1])  # floored as in :meth:`at`
        vg = (grad / scale).dot(v)
        small = bool((np.abs(grad) <= gtol * math.sqrt(2.0 * cost) * scale).all())
        return cls(w[None], v[None], vg[None], scale[None],
                   np.array([0.5 * vg.dot(vg / w)]), np.array([small]), jtj[None])

    def take(self, rows: NDArray[np.bool_]) -> GaussNewtonModel:
        """Keep the runs ``rows``."""
        return GaussNewtonModel(self.w[rows], self.v[rows], self.vg[rows], self.scale[rows],
                                self.decrement[rows], self.small_grad[rows],
                                None if self.jtj is None else self.jtj[rows])

    def step(self, lam: Array) -> tuple[Array, Array]:
        """Give the step at damping ``lam`` and the decrease the model predicts for it."""
        if self.w.shape[0] == 1:  # one run: 2-D products (fewer, cheaper calls)
            w, vg, lam1 = self.w[0], self.vg[0], float(lam[0])
            lw = w + lam1
            q = vg / lw
            step = self.v[0].dot(q) / self.scale[0]
            return step[None], np.array([0.5 * q.dot(vg * (w + 2.0 * lam1) / lw)])
        lw = self.w + lam[:, None]
        step = (self.v @ (self.vg / lw)[:, :, None])[..., 0] / self.scale
        vg2 = self.vg * self.vg
        return step, 0.5 * (vg2 * (self.w + 2.0 * lam[:, None]) / (lw * lw)).sum(axis=1)


POLISH_INFORMATION = 5e-3
"""Largest relative change of ``J'J`` over a polishing step, extrapolated from the last step
(see :func:`information_steady`): the reported covariance, ``J'J`` of the point the step
left, is then that of the end point to this order."""


def information_steady(model: GaussNewtonModel, theta: Array,
                       previous: tuple[Array, Array] | None, decrement: float,
                       free: NDArray[np.bool_] | None) -> bool:
    """Tell whether ``J'J`` changes little enough over a polishing step of ``decrement``."""
    if previous is None or model.jtj is None:
        return False
    theta_prev, jtj_prev = previous
    jtj = model.jtj[0]
    move = theta - theta_prev
    if free is not None:
        move = move[free]
    if jtj_prev.shape != jtj.shape:
        return False
    moved = float(move @ jtj @ move)
    try:
        lower = np.linalg.cholesky(jtj)
        change = np.linalg.solve(lower, np.linalg.solve(lower, jtj - jtj_prev).T)
    except np.linalg.LinAlgError:
        return False
    if not (moved > 0.0 and np.all(np.isfinite(change))):
        return False
    rate = float(np.linalg.norm(change)) / np.sqrt(moved)
    return rate * np.sqrt(2.0 * decrement) <= POLISH_INFORMATION
