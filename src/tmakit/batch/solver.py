"""Batched Levenberg–Marquardt on the reduced problems of :mod:`tmakit.batch.varpro`.

The one solver of every batch estimator (ML and its multi-start, Monte Carlo runs, the
manoeuvre search), vectorised over a leading batch axis.  The Gauss–Newton model at a batch of
points (:class:`GaussNewtonModel`) is the eigen-decomposition of ``J'J`` in variables scaled by
the square roots of its diagonal (Marquardt (1963)); a single run's is built in 2-D arrays with
LAPACK's ``dsyevd`` called directly (:func:`tmakit.core.linalg.eigh`).

References
----------
Marquardt, D. W. (1963). An algorithm for least-squares estimation of nonlinear parameters
(the diagonal scaling).  Nielsen, H. B. (1999). Damping parameter in Marquardt's method,
IMM-REP-1999-05 (the damping update).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from ..core.blas import SINGLE_THREAD_WORK, by_dots, normal_rows
from ..core.linalg import eigh
from .varpro import DeferredNormal, Evaluation, VarProProblem

__all__ = ["DAMPING", "DOMINANCE_FACTOR", "DOMINANCE_MARGIN", "POLISH_INFORMATION", "Evaluation",
           "GaussNewtonModel", "SolveResult", "VarProProblem", "gram", "information_of",
           "information_steady", "levenberg_marquardt", "normal_equations"]

def gram(j: Array) -> Array:
    """Form ``J^T J`` ``(B, p, p)`` of ``J`` ``(B, n, p)`` (or ``(p, p)`` of ``(n, p)``)."""
    if j.ndim == 2 and by_dots(j):
        return normal_rows(j.T)[0]
    return _gram_by_products(j)


def _gram_by_products(j: Array) -> Array:
    """Form ``J^T J`` as :func:`gram` does without dot products (by row blocks if many)."""
    n, p = j.shape[-2:]
    jt = j.swapaxes(-1, -2)
    block = max(1, SINGLE_THREAD_WORK // max(1, p * p))
    if n <= block:  # (2-D: ndarray.dot, the same BLAS call as matmul's, called faster)
        return jt.dot(j) if j.ndim == 2 else jt @ j
    out = np.zeros((*j.shape[:-2], p, p))
    for lo in range(0, n, block):
        out += jt[..., lo:lo + block] @ j[..., lo:lo + block, :]
    return out


def information_of(problem: VarProProblem, ev: Evaluation, run: int,
                   known: Array | None = None) -> Array | None:
    """Give the Fisher information ``J' R^-1 J`` at run ``run``'s evaluated point, if it has it."""
    if problem.eliminates:
        return None
    if known is not None and all(map(math.isfinite, known[run].ravel().tolist())):  # (q^2)
        return np.array(known[run], dtype=float)
    if ev.normal is not None:
        return np.array(ev.normal[0][run], dtype=float)
    if ev.jacobian is None:
        return None
    return gram(ev.jacobian[run])


_DIRECT_EIGH = 32  # largest matrix decomposed by a direct LAPACK call
# (the ufuncs' reductions called directly: ndarray.all and .any go through Python)
_ALL, _ANY = np.logical_and.reduce, np.logical_or.reduce


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
        jtj, jtr = _normal_one(jac[0], ev.residual[0])
        return jtj[None], jtr[None]
    return gram(jac), (jac.swapaxes(1, 2) @ ev.residual[:, :, None])[..., 0]


def _normal_one(j: Array, r: Array) -> tuple[Array, Array]:
    """Give ``J'J`` and ``J'r`` of a single run's ``J`` ``(n, p)`` and residual ``(n,)``."""
    if by_dots(j):
        jtj, jtr = normal_rows(j.T, r)
        assert jtr is not None  # (given the residuals)
        return jtj, jtr
    return _gram_by_products(j), r.dot(j)


@dataclass
class GaussNewtonModel:
    """The Gauss-Newton model of a batch at its current points, in diagonally scaled variables."""

    w: Array  # (B, p) eigenvalues of the scaled J'J
    v: Array  # (B, p, p) its eigenvectors
    vg: Array  # (B, p) the scaled gradient in that basis
    scale: Array  # (B, p) square roots of the diagonal of J'J
    decrement: Array  # (B,) the Gauss-Newton decrement (half chi2)
    small_grad: NDArray[np.bool_]  # (B,) the gradient test met
    jtj: Array | None = None  # (B, p, p) J'J itself
    evals: Array | None = None  # (1, p) a single run's eigenvalues before their floor

    @classmethod
    def at(cls, ev: Evaluation, gtol: float, free: NDArray[np.bool_] | None) -> GaussNewtonModel:
        """Build the model at the evaluated points ``ev`` (over the ``free`` columns)."""
        jac = ev.jacobian
        if (free is None and ev.normal is None and jac is not None and jac.shape[0] == 1
                and jac.shape[2] <= _DIRECT_EIGH):  # one run, every column: 2-D throughout
            one = cls._one(*_normal_one(jac[0], ev.residual[0]), float(ev.cost[0]), gtol)
            if one is not None:
                return one
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
        scale = np.sqrt(np.maximum(jtj.diagonal(), 1e-300))  # (the same bits as in :meth:`at`)
        try:
            evals, v = eigh(jtj / (scale[:, None] * scale))
        except np.linalg.LinAlgError:
            return None
        w = np.maximum(evals, 1e-12 * float(evals[-1]))  # floored as in :meth:`at`
        vg = (grad / scale).dot(v)
        bound, small = gtol * math.sqrt(2.0 * cost), True  # (p products in floats: fewer calls)
        for g, s in zip(grad.tolist(), scale.tolist(), strict=True):
            if not abs(g) <= bound * s:
                small = False
                break
        return cls(w[None], v[None], vg[None], scale[None],
                   np.array([0.5 * vg.dot(vg / w)]), _ONE if small else _NONE, jtj[None],
                   evals[None])

    def take(self, rows: NDArray[np.bool_]) -> GaussNewtonModel:
        """Keep the runs ``rows``."""
        return GaussNewtonModel(self.w[rows], self.v[rows], self.vg[rows], self.scale[rows],
                                self.decrement[rows], self.small_grad[rows],
                                None if self.jtj is None else self.jtj[rows],
                                None if self.evals is None else self.evals[rows])

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


DAMPING = ("nielsen", "factors")
"""How the damping follows a step: Nielsen's update from how well the model predicted the
decrease, or divided by 3 after an accepted step and multiplied by 4 after a rejected one."""

#: ``(B, p)`` points and ``(B,)`` their costs where a run starts if its own start costs no less,
#: optionally ``(B, p, p)`` ``J'J`` there (for :func:`information_steady`).
Fallback = tuple[Array, Array] | tuple[Array, Array, Array]

DOMINANCE_FACTOR = 10.0
"""A run stops as dominated when its cost exceeds the lowest cost reached in its group by more
than this many times its Gauss-Newton decrement (plus :data:`DOMINANCE_MARGIN`)."""
DOMINANCE_MARGIN = 1.0
"""Cost margin (half a chi2 unit per unit) of the dominance test."""

_STALL_WINDOW = 6  # iterations over which ``stall`` measures the decrease
_ONE = np.ones(1, dtype=bool)  # a single run's masks (read only)
_ONE.flags.writeable = False
_NONE = np.zeros(1, dtype=bool)
_NONE.flags.writeable = False


@dataclass
class SolveResult:
    """The final state of every run of :func:`levenberg_marquardt` (SI)."""

    theta: Array        # (B, p)
    nuisance: Array     # (B, k) eliminated at theta
    cost: Array         # (B,) half the whitened chi2
    iterations: NDArray[np.int64]  # (B,) steps tried
    converged: NDArray[np.bool_]
    evaluation: Evaluation
    dominated: NDArray[np.bool_] | None = None  # stopped: bound for a worse minimum
    information: Array | None = None  # (B, q, q) J'J at the final points (NaN: not formed)
    #: A single run's ``information`` decomposed as :func:`tmakit.results.observability.analyse`
    #: decomposes it (from the solver's last Gauss-Newton model), or None.
    decomposition: tuple[Array, Array, Array] | None = None


@dataclass  # (not frozen: a frozen dataclass's __init__ sets each field by object.__setattr__)
class _Rules:
    """The tests and schedule of one :func:`levenberg_marquardt` call (see there)."""

    ftol: float
    xtol: float
    gtol: float
    dtol: float
    free: NDArray[np.bool_] | None
    damping: str
    max_reject: int | None
    stall: float
    dominance: tuple[float, float]
    polish: float = 0.0

    @property
    def plain(self) -> bool:
        """Nielsen's damping without ``max_reject`` or ``stall`` (the no-guess fit's rules)."""
        return self.damping == "nielsen" and self.max_reject is None and self.stall <= 0


class _Runs:
    """The runs still iterating, compacted (``ids``: their rows); ``out``: every final state."""

    def __init__(self, out: Evaluation, u: Array, nu_star: Array,
                 groups: NDArray[np.int64] | None, reached: Array | None,
                 stall: bool, damping0: float = 1e-3) -> None:
        b = out.cost.shape[0]
        self.out = out
        self.converged = np.zeros(b, dtype=bool)
        self.dominated = np.zeros(b, dtype=bool)
        self.iterations = np.zeros(b, dtype=np.int64)
        self.ids = np.arange(b)
        self.cur, self.u, self.nu_star, self.groups = out, u, nu_star, groups
        self.reached = reached  # per group, the lowest cost of a stopped run
        self.lam = np.empty(b)
        self.lam.fill(damping0)
        self.grow = np.empty(b)  # Nielsen's factor for the damping after a failure
        self.grow.fill(2.0)
        self.rejected = np.zeros(b, dtype=np.int64)  # rejected steps in a row
        # costs after the last iterations, by run (a ring over _STALL_WINDOW + 1 slots)
        self.history = np.tile(out.cost, (_STALL_WINDOW + 1, 1)) if stall else None
        self.model: GaussNewtonModel | None = None
        # an evaluation no longer read, whose arrays the next trial takes (no new pages)
        self.spare: Evaluation | None = None
        self.information: Array | None = None  # J'J of stopped runs at their final points
        self.last_model: GaussNewtonModel | None = None  # a single run's, when it stopped
        # a single run's previous point and its J'J (how fast J'J changes: information_steady)
        self.previous: tuple[Array, Array] | None = None
        finite = np.isfinite(out.cost)
        if not _ALL(finite):
            self.stop(~finite, np.zeros(b, dtype=bool))

    def stop(self, mask: NDArray[np.bool_], converged: NDArray[np.bool_],
             dominated: NDArray[np.bool_] | None = None) -> None:
        """Record the runs ``mask`` as stopped and drop them from the live arrays."""
        if not _ANY(mask):
            return
        b = self.out.cost.shape[0]
        ids = self.ids[mask]
        # The model is at cur (or at the point a polishing step left: see _polished).
        if self.model is not None and self.model.jtj is not None:
            if self.information is None and ids.size == b:  # every run at once (ids ascending)
                self.information = self.model.jtj.copy()  # (jtj[mask]: mask is all True)
            else:
                if self.information is None:
                    q = self.model.jtj.shape[-1]
                    self.information = np.full((b, q, q), np.nan)
                self.information[ids] = self.model.jtj[mask]
            if b == 1:
                self.last_model = self.model
        if self.reached is not None and self.groups is not None:  # (reached: with groups)
            np.minimum.at(self.reached, self.groups[mask], self.cur.cost[mask])
        self.converged[ids] = converged[mask]
        if dominated is not None:
            self.dominated[ids] = dominated[mask]
        if self.cur is not self.out:
            if ids.size == b:  # every run at once: no copy
                self.out = self.cur
            else:
                self.out.put(ids, self.cur, mask)
        if ids.size == self.ids.size:  # every live run stopped: nothing left to compact
            self.ids = ids[:0]
            return
        keep = ~mask
        self.ids = self.ids[keep]
        cur, self.cur = self.cur, self.cur.take(keep, self.spare)
        self.spare = None if cur is self.out else cur
        self.u, self.nu_star = self.u[keep], self.nu_star[keep]
        self.lam, self.grow = self.lam[keep], self.grow[keep]
        self.rejected = self.rejected[keep]
        if self.groups is not None:
            self.groups = self.groups[keep]
        if self.model is not None:
            self.model = self.model.take(keep)

    def stalled(self, iteration: int, stall: float) -> NDArray[np.bool_]:
        """Record the live runs' costs after ``iteration`` (1, 2, ...) steps; flag the stalled."""
        if self.history is None:
            return np.zeros(self.ids.size, dtype=bool)
        slots = _STALL_WINDOW + 1
        self.history[iteration % slots, self.ids] = self.cur.cost
        if iteration < _STALL_WINDOW:
            return np.zeros(self.ids.size, dtype=bool)
        then = self.history[(iteration - _STALL_WINDOW) % slots, self.ids]
        return then - self.cur.cost < stall

    def decomposition(self) -> tuple[Array, Array, Array] | None:
        """Give a single run's final ``J'J`` decomposed as ``analyse`` does, if it has one."""
        model = self.last_model
        if model is None or model.evals is None or model.jtj is None:
            return None
        evals = model.evals[0]
        if not all(map(math.isfinite, evals.tolist())):  # (a J'J not finite: none made)
            return None
        # analyse's normalisation divides by sqrt(d), and by 1 where d is not positive
        inverse = [1.0 / s if d > 0 else 1.0
                   for d, s in zip(model.jtj[0].diagonal().tolist(), model.scale[0].tolist(),
                                   strict=True)]
        return evals, model.v[0], np.array(inverse)

    def finish(self) -> Evaluation:
        """Write the state of the runs still live (the iteration limit) into ``out``; give it."""
        if self.cur is not self.out and self.ids.size:
            if self.ids.size == self.out.cost.shape[0]:  # every run still live: no copy
                self.out = self.cur
            else:
                self.out.put(self.ids, self.cur)
        return self.out


def levenberg_marquardt(problem: VarProProblem, y: Array, theta0: Array,
                        max_iter: int = 100, ftol: float = 1e-10, xtol: float = 1e-12,
                        gtol: float = 1e-10, dtol: float = 1e-5,
                        groups: NDArray[np.int64] | None = None, ceiling: Array | None = None, *,
                        free: NDArray[np.bool_] | None = None, damping: str = "nielsen",
                        max_reject: int | None = None, stall: float = 0.0, polish: float = 0.0,
                        dominance: tuple[float, float] = (DOMINANCE_FACTOR, DOMINANCE_MARGIN),
                        damping0: float = 1e-3, fallback: Fallback | None = None) -> SolveResult:
    """Fit a batch by Levenberg–Marquardt (Marquardt's diagonal scaling), nuisance reduced.

    Convergence tests precede each step; damping past 1e12 stops a run unconverged.  With
    ``groups`` or ``ceiling`` a run heading for a worse minimum than one found stops as
    ``dominated``.

    Parameters
    ----------
    problem : VarProProblem
    y : ndarray
        ``(n,)`` or ``(B, n)`` data in the set's row order, SI.
    theta0 : ndarray
        ``(B, p)`` or ``(p,)`` starts.
    max_iter : int
    ftol, dtol : float
        Converged when the Gauss–Newton decrement is below ``ftol * cost + dtol``.
    xtol : float
        Converged after a lightly damped step moving every parameter less than ``xtol`` relative.
    gtol : float
        Converged when the gradient's cosine with every Jacobian column is below ``gtol``.
    groups, ceiling : ndarray, optional
        ``(B,)`` labels of runs fitting the same data, and a cost each must beat.
    free : ndarray of bool, optional
        ``(p,)`` the parameters fitted (default all).
    damping, damping0 : {"nielsen", "factors"}, float
        The damping schedule (:data:`DAMPING`) and its start.
    max_reject, stall : int or None, float
        Stop after ``max_reject`` rejections in a row, or six steps lowering the cost by less
        than ``stall`` in all.
    dominance : (float, float)
        ``(factor, margin)`` of the dominance test.
    polish, fallback : float, (ndarray, ndarray) or None
        A last step checked by residuals alone below ``polish``; per-run fallback starts.

    Returns
    -------
    SolveResult

    Raises
    ------
    ValueError
        For an unknown ``damping``.

    References
    ----------
    Marquardt (1963), the scaling; Nielsen (1999), the ``"nielsen"`` damping; Golub & Pereyra
    (1973), variable projection, which avoids the ill-conditioning of Gu et al. (2007), §3.
    """
    if damping not in DAMPING:
        raise ValueError(f"damping must be one of {', '.join(DAMPING)}, got {damping!r}")
    rules = _Rules(ftol, xtol, gtol, dtol, None if free is None else np.asarray(free, bool),
                   damping, max_reject, stall, dominance, polish)
    with np.errstate(invalid="ignore", divide="ignore"):  # a trial on a sensor: cost inf
        runs = _iterate(problem, _start(problem, y, theta0, groups, ceiling, stall > 0,
                                        damping0, fallback), max_iter, rules)
    out = runs.finish()  # each accepted point carries its own eliminated nuisance: no re-evaluation
    return SolveResult(out.theta, out.nuisance, out.cost, runs.iterations, runs.converged,
                       out, runs.dominated, runs.information, runs.decomposition())


def _start(problem: VarProProblem, y: Array, theta0: Array,
           groups: NDArray[np.int64] | None, ceiling: Array | None, stall: bool,
           damping0: float = 1e-3, fallback: Fallback | None = None) -> _Runs:
    """Set up the runs of :func:`levenberg_marquardt` at their starting points (or fallbacks)."""
    theta = np.array(theta0, dtype=float, ndmin=2)
    b = theta.shape[0]
    y = problem.group(y)
    if y.shape != (b, len(problem.obs.meas)):  # (a view of the right shape is read-only)
        y = np.broadcast_to(y, (b, len(problem.obs.meas)))
    nu_star = problem.reference_nuisance(y)
    u = problem.data_part(y, nu_star)
    reached = None
    if groups is not None or ceiling is not None:
        groups = np.zeros(b, dtype=np.int64) if groups is None else np.asarray(groups)
        reached = np.full(int(groups.max()) + 1, np.inf)  # lowest cost of a stopped run
        if ceiling is not None:
            np.minimum.at(reached, groups, np.broadcast_to(ceiling, (b,)))
    start = problem.evaluate_part(theta, u, nu_star, True, quiet=True)  # (errors ignored)
    if fallback is not None:
        back = ~(start.cost < np.asarray(fallback[1]))
        if back.any():  # (all runs again: a step that failed is rare)
            theta = np.where(back[:, None], fallback[0], theta)
            start = problem.evaluate_part(theta, u, nu_star, True, quiet=True)
    runs = _Runs(start, u, nu_star, groups, reached, stall, damping0)
    if fallback is not None and len(fallback) == 3 and b == 1 and not back[0]:
        runs.previous = (np.asarray(fallback[0])[0], np.asarray(fallback[2])[0])
    return runs


def _stop_converged_or_dominated(runs: _Runs, rules: _Rules) -> None:
    """Make the tests before a step: convergence, and dominance within a group."""
    cur, model = runs.cur, runs.model
    assert model is not None
    # The Gauss-Newton decrement is half the squared distance to the minimum in standard
    # deviations (whitened residuals) and does not depend on the damping, so a run sitting
    # at the minimum is recognised even where rounding makes every step look worse;
    # dtol = 1e-5 means within 4.5e-3 sigma, far inside the statistical error.
    if runs.reached is None and runs.ids.size == 1:  # one run: the test in floats
        if model.small_grad[0] or (float(model.decrement[0])
                                   <= rules.ftol * float(cur.cost[0]) + rules.dtol):
            runs.stop(_ONE, _ONE)
        return
    done = model.small_grad | (model.decrement <= rules.ftol * cur.cost + rules.dtol)
    beaten = None
    if runs.reached is not None and runs.groups is not None:
        best = runs.reached.copy()  # the lowest cost reached in each group
        np.minimum.at(best, runs.groups, cur.cost)
        factor, margin = rules.dominance
        beaten = ~done & (cur.cost - factor * model.decrement > best[runs.groups] + margin)
    runs.stop(done if beaten is None else done | beaten, done, beaten)


def _damp(runs: _Runs, better: NDArray[np.bool_], gain: Array, rules: _Rules) -> None:
    """Update the damping after a step (accepted where ``better``)."""
    lam = runs.lam
    if rules.damping == "factors":
        runs.lam = np.where(better, np.maximum(lam / 3.0, 1e-12), lam * 4.0)
        return
    # Nielsen's update: the damping follows how well the model predicted the decrease.
    shrink = np.maximum(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
    runs.lam = np.where(better, np.maximum(lam * shrink, 1e-12), lam * runs.grow)
    runs.grow = np.where(better, 2.0, 2.0 * runs.grow)


def _damp_one(runs: _Runs, better: bool, cost: float, trial: float, predicted: float) -> float:
    """Update the damping of a single run after a step, as :func:`_damp` does (Nielsen); give it."""
    lam, grow = float(runs.lam[0]), float(runs.grow[0])
    if better:  # 0 < gain <= 1 here: no overflow in floats
        gain = min((cost - trial) / max(predicted, 1e-300), 1.0)
        lam, grow = max(lam * max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3), 1e-12), 2.0
    else:
        lam, grow = lam * grow, 2.0 * grow
    runs.lam[0], runs.grow[0] = lam, grow  # (the run's own arrays)
    return lam


def _after_step_one(runs: _Runs, trial: Evaluation, step: Array, predicted: float,
                    rules: _Rules) -> None:
    """Accept or reject a single run's step, as :func:`_iterate` does for a batch (floats)."""
    cost, new = float(runs.cur.cost[0]), float(trial.cost[0])
    better, lam = new < cost, float(runs.lam[0])
    damped = _damp_one(runs, better, cost, new, predicted)
    # A heavily damped step is small without being converged (see _iterate).
    tiny = better and lam <= 1e-2
    if tiny:
        xtol = rules.xtol
        for s, t in zip(step[0].tolist(), trial.theta[0].tolist(), strict=True):
            if not abs(s) <= xtol * (abs(t) + 1.0):
                tiny = False
                break
    if better:
        if rules.polish > 0 and runs.model is not None and runs.model.jtj is not None:
            runs.previous = (runs.cur.theta[0], runs.model.jtj[0])  # (read by _polished)
        runs.cur, runs.model = trial, None
    if tiny or damped > 1e12:
        runs.stop(_ONE, _ONE if tiny else _NONE)


POLISH_AGREEMENT = 0.01
"""Largest relative gap between a polishing step's decrease and the one its model predicted."""

def _polished(problem: VarProProblem, runs: _Runs, rules: _Rules) -> bool:
    """End a single run with a Gauss–Newton step checked by its residuals alone."""
    model, cur = runs.model, runs.cur
    assert model is not None
    predicted = float(model.decrement[0])
    if (runs.ids.size != 1 or predicted > rules.polish or float(runs.lam[0]) > 1e-2
            or not information_steady(model, runs.cur.theta[0], runs.previous, predicted,
                                      rules.free)):
        return False
    step, expected = model.step(runs.lam)
    if rules.free is not None:
        full = np.zeros_like(cur.theta)
        full[:, rules.free] = step
        step = full
    trial = problem.evaluate_part(cur.theta + step, runs.u, runs.nu_star, False, quiet=True)
    runs.iterations[runs.ids] += 1
    drop, want = float(cur.cost[0]) - float(trial.cost[0]), float(expected[0])
    if not (drop > 0.0 and abs(drop - want) <= POLISH_AGREEMENT * want):
        return False
    runs.cur = trial  # the model (its J'J) stays that of the point the step left
    runs.stop(_ONE, _ONE)
    return True


def _accept(runs: _Runs, cur: Evaluation, trial: Evaluation, better: NDArray[np.bool_]) -> None:
    """Make the runs' points the trial's where ``better``; the evaluation left over is the spare."""
    runs.model = None
    n_better = int(np.count_nonzero(better))
    if n_better == better.size:
        runs.spare = None if cur is runs.out else cur
        runs.cur = trial
    elif (_same_form(cur, trial) and (cur is runs.out or 2 * n_better > better.size)):
        # The fewer rows copied: the rejected into the trial (never into the stopped runs' out).
        trial.put(~better, cur, ~better)
        runs.spare = None if cur is runs.out else cur
        runs.cur = trial
    else:
        if cur is runs.out:  # never write into the results of stopped runs
            runs.cur = cur.take(np.ones(cur.cost.shape[0], dtype=np.bool_))
        runs.cur.put(better, trial, better)
        runs.spare = trial


def _same_form(a: Evaluation, b: Evaluation) -> bool:
    """Tell whether ``a`` and ``b`` hold the same parts, each copied row by row as it is."""
    return (not isinstance(a.normal, DeferredNormal) and not isinstance(b.normal, DeferredNormal)
            and (a.jacobian is None) == (b.jacobian is None)
            and (a.normal is None) == (b.normal is None))


def _iterate(problem: VarProProblem, runs: _Runs, max_iter: int, rules: _Rules) -> _Runs:
    """Run the iterations of :func:`levenberg_marquardt` (see there for the tests)."""
    free, plain = rules.free, rules.plain
    for iteration in range(1, max_iter + 1):
        if runs.ids.size == 0:
            break
        if runs.model is None:  # a new point for some run: its Gauss-Newton model
            runs.model = GaussNewtonModel.at(runs.cur, rules.gtol, free)
        _stop_converged_or_dominated(runs, rules)
        if runs.ids.size == 0 or (rules.polish > 0 and _polished(problem, runs, rules)):
            break
        cur, model, lam = runs.cur, runs.model, runs.lam
        step, predicted = model.step(lam)
        if free is not None:
            full = np.zeros_like(cur.theta)
            full[:, free] = step
            step = full
        trial = problem.evaluate_part(cur.theta + step, runs.u, runs.nu_star, True, quiet=True,
                                      spare=runs.spare)
        runs.spare = None  # (its arrays may be the trial's now)
        if lam.shape[0] == 1 and plain:  # one run: its tests in floats
            runs.iterations[int(runs.ids[0])] += 1
            _after_step_one(runs, trial, step, float(predicted[0]), rules)
            continue
        runs.iterations[runs.ids] += 1
        better = trial.cost < cur.cost
        _damp(runs, better, np.minimum((cur.cost - trial.cost)
                                       / np.maximum(predicted, 1e-300), 1.0), rules)
        # A heavily damped step is small without being converged, hence the damping
        # condition on the step test.
        tiny = better & (lam <= 1e-2)
        if tiny.any():
            tiny &= (np.abs(step) <= rules.xtol * (np.abs(trial.theta) + 1.0)).all(axis=1)
        if better.any():
            _accept(runs, cur, trial, better)
        else:
            runs.spare = trial
        give_up = runs.lam > 1e12
        if rules.max_reject is not None:
            runs.rejected = np.where(better, 0, runs.rejected + 1)
            give_up |= runs.rejected >= rules.max_reject
        if runs.history is not None:  # (``stall`` set)
            give_up |= runs.stalled(iteration, rules.stall)
        runs.stop(tiny | give_up, tiny)
    return runs
