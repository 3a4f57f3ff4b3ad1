"""Batched weighted least squares with the linear nuisance parameters projected out.

Variable projection (Golub & Pereyra (1973); Kaufman (1975)'s projected Jacobian), vectorised
over a leading batch axis; :class:`Evaluation` holds what a Gauss–Newton step needs.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import blas
from ..core.arrays import Array
from ..core.frames import wrap_angle
from ..core.frames import wrap_angle_own as _wrap_own
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..observation.planar import Linearisation
from ..observation.rows import angle_runs


class DeferredNormal:
    """``(J'J, J'r)`` of the runs ``rows`` (None: all ``size``), summed by ``make`` when read."""

    def __init__(self, make: Callable[[NDArray[np.int64] | None], tuple[Array, Array]],
                 size: int, rows: NDArray[np.int64] | None = None) -> None:
        self._make, self._size, self._rows = make, size, rows
        self._value: tuple[Array, Array] | None = None

    def _whole(self) -> tuple[Array, Array]:
        if self._value is None:
            self._value = self._make(self._rows)
        return self._value

    def __getitem__(self, i: int) -> Array:
        """Give ``J'J`` (0) or ``J'r`` (1) of every run."""
        return self._whole()[i]

    def __iter__(self) -> Iterator[Array]:
        """Give ``J'J`` then ``J'r``."""
        return iter(self._whole())

    def __len__(self) -> int:
        """Two: ``J'J`` and ``J'r``."""
        return 2

    def runs(self, which: NDArray[np.bool_] | NDArray[np.int64] | slice) -> tuple[Array, Array]:
        """Give the sums of the runs ``which`` (indices into this object's runs)."""
        if self._value is not None:
            return self._value[0][which], self._value[1][which]
        own = np.arange(self._size) if self._rows is None else self._rows
        return self._make(own[which])

    def take(self, which: NDArray[np.bool_] | NDArray[np.int64] | slice
             ) -> DeferredNormal | tuple[Array, Array]:
        """Stand for the runs ``which`` only (their sums still deferred, or copied if made)."""
        if self._value is not None:
            return self._value[0][which], self._value[1][which]
        own = np.arange(self._size) if self._rows is None else self._rows
        return DeferredNormal(self._make, self._size, own[which])


def motion_normal(obs: Any, lin: Linearisation, residual: Array, weights: Array | None
                  ) -> DeferredNormal | None:
    """Give ``J'J`` and ``J'r`` of the whitened Jacobian from the motion model, or None."""
    if (weights is None or lin.planar_jacobian is not None or lin.d_h0 is None or lin.d_a
            or lin.d_h0_ref is not None or lin.theta.ndim != 2):
        return None
    normal = getattr(obs.motion, "normal_equations_later", None)
    if normal is None:
        return None
    make = normal(lin.d_h0, residual, weights, lin.theta, obs._time)
    return None if make is None else DeferredNormal(make, residual.shape[0])


@dataclass
class Evaluation:
    """Reduced residuals and what a step needs, for a batch of parameter vectors (SI)."""

    theta: Array      # (B, p)
    nuisance: Array   # (B, k) eliminated (or fixed) nuisance values
    residual: Array   # (B, n) whitened, nuisance projected out
    cost: Array       # (B,)  half the squared whitened residual (inf: no prediction)
    jacobian: Array | None = None  # (B, n, p) whitened, projected
    # (B, p, p) J'J and (B, p) J'r: by chunks, or summed when first read (DeferredNormal)
    normal: tuple[Array, Array] | DeferredNormal | None = None

    def take(self, rows: NDArray[np.bool_] | NDArray[np.int64],
             spare: Evaluation | None = None) -> Evaluation:
        """Copy the evaluations of ``rows`` (a mask: into ``spare``'s arrays where they fit)."""
        if spare is not None and self.normal is None and rows.dtype == np.bool_:
            jt = None if self.jacobian is None else self.jacobian.swapaxes(1, 2)
            if jt is None or jt.flags.c_contiguous:
                mask = np.asarray(rows, dtype=np.bool_)  # (the same array)
                m, n = int(np.count_nonzero(mask)), self.residual.shape[1]
                nu, r, cost, jt_out = _buffers(spare, m, n, self.nuisance.shape[1],
                                               None if jt is None else jt.shape[1])
                np.compress(mask, self.nuisance, 0, nu)
                np.compress(mask, self.residual, 0, r)
                np.compress(mask, self.cost, 0, cost)
                if jt is not None and jt_out is not None:
                    np.compress(mask, jt, 0, jt_out)
                return Evaluation(self.theta[mask], nu, r, cost,
                                  None if jt_out is None else jt_out.swapaxes(1, 2))
        normal = self.normal
        if isinstance(normal, DeferredNormal):
            normal = normal.take(rows)  # (still deferred unless already summed)
        elif normal is not None:
            normal = (normal[0][rows], normal[1][rows])
        return Evaluation(self.theta[rows], self.nuisance[rows], self.residual[rows],
                          self.cost[rows], None if self.jacobian is None
                          else self.jacobian[rows], normal)

    def put(self, rows: NDArray[np.bool_] | NDArray[np.int64], other: Evaluation,
            which: NDArray[np.bool_] | NDArray[np.int64] | slice = slice(None)) -> None:
        """Overwrite ``rows`` with ``other``'s evaluations ``which``, in place."""
        if isinstance(self.normal, DeferredNormal):  # written into: summed first, as it was
            self.normal = (self.normal[0], self.normal[1])
        if (self.jacobian is None) != (other.jacobian is None):
            # One holds its Jacobian, the other only J'J and J'r (summed by chunks of rows, or
            # by the compiled batch kernel): both as normal equations.
            self.normal, self.jacobian = normal_of(self), None
            other = Evaluation(other.theta, other.nuisance, other.residual, other.cost, None,
                               normal_of(other))
        self.theta[rows] = other.theta[which]
        self.nuisance[rows] = other.nuisance[which]
        self.residual[rows] = other.residual[which]
        self.cost[rows] = other.cost[which]
        if self.jacobian is not None and other.jacobian is not None:
            self.jacobian[rows] = other.jacobian[which]
        if self.normal is not None and other.normal is not None:
            got = (other.normal.runs(which) if isinstance(other.normal, DeferredNormal)
                   else (other.normal[0][which], other.normal[1][which]))
            self.normal[0][rows], self.normal[1][rows] = got


def normal_of(ev: Evaluation) -> tuple[Array, Array] | DeferredNormal | None:
    """Give ``J'J`` ``(B, p, p)`` and ``J'r`` ``(B, p)`` of ``ev`` (its own when it has them)."""
    if ev.normal is not None or ev.jacobian is None:
        return ev.normal
    jt = ev.jacobian.swapaxes(1, 2)
    return jt @ ev.jacobian, (jt @ ev.residual[:, :, None])[..., 0]


_compiled_batches = [False]  # inside compiled_batches(True)

BLOCK_WORK = 6_000
"""Points times rows evaluated at once when a nuisance is eliminated: the evaluation's dozen
temporaries ``(B, n, .)`` then stay small enough to be reused from one block to the next,
instead of growing the heap for every batch of a Monte Carlo study (fresh pages: page faults)."""
FEWEST_PER_BLOCK = 16


def _starts_per_block(rows: int) -> int:
    """Give the points of one block of :meth:`VarProProblem._evaluate_blocks`."""
    return max(FEWEST_PER_BLOCK, BLOCK_WORK // max(1, rows))


def _buffers(spare: Evaluation | None, b: int, n: int, k: int, p: int | None
             ) -> tuple[Array, Array, Array, Array | None]:
    """Give ``nu``, ``r``, ``cost`` and ``J'`` ``(b, p, n)`` to fill: ``spare``'s, or new."""
    jt = None if spare is None or spare.jacobian is None else spare.jacobian.swapaxes(1, 2)
    if (spare is not None and spare.cost.shape[0] >= b and spare.residual.shape[1:] == (n,)
            and spare.nuisance.shape[1:] == (k,) and (p is None or (
                jt is not None and jt.shape[1] == p and jt.flags.c_contiguous))
            and all(a.flags.c_contiguous and a.dtype == np.float64
                    for a in (spare.nuisance, spare.residual, spare.cost))):
        return (spare.nuisance[:b], spare.residual[:b], spare.cost[:b],
                None if p is None or jt is None else jt[:b])
    return (np.empty((b, k)), np.empty((b, n)), np.empty(b),
            None if p is None else np.empty((b, p, n)))


@contextmanager
def compiled_batches(wanted: bool) -> Iterator[None]:
    """Evaluate by the compiled kernel wherever it applies (True), or never, for a while."""
    before = _compiled_batches[0]
    _compiled_batches[0] = bool(wanted)
    try:
        yield
    finally:
        _compiled_batches[0] = before


class VarProProblem:
    """Weighted least squares for ``theta`` with linear nuisance parameters eliminated.

    Parameters
    ----------
    obs : ObservationModel
    noise : NoiseModel, optional
        Default from the observation model's sigmas and correlated blocks.
    fixed_nuisance : ndarray, optional
        ``(k,)`` known nuisance values, SI, instead of estimated.

    References
    ----------
    Golub & Pereyra (1973) (variable projection); Kaufman (1975) (the projected Jacobian).
    """

    def __init__(self, obs: ObservationModel, noise: NoiseModel | None = None,
                 fixed_nuisance: Array | None = None) -> None:
        self.obs = obs
        # Rows are handled grouped by kind (contiguous slices); see ObservationModel.  Only
        # kinds with correlated noise (the hook; range differences) need the full model:
        # without them the rows' sigmas are the model.
        if noise is None:
            correlated = any(m.correlated_noise for m in obs.models.values())
            noise = (NoiseModel(obs.grouped, obs.models) if correlated
                     else NoiseModel.independent(obs.sigmas_grouped))
        self.noise = noise
        # Independent rows: the planar Jacobian is made whitened (see _evaluate).
        self._weights = None if noise.correlated else noise.inv_sigma
        self.k = obs.n_nuisance
        self.p = obs.motion.n_params
        self.fixed = None if fixed_nuisance is None else np.asarray(fixed_nuisance, float)
        self.angle = obs.angle_mask_grouped
        #: Whether some rows are angles, all are (wrapped without a mask), and the angle rows
        #: as one slice when they form one run (wrapped in place, the other rows untouched).
        self.has_angle, self.all_angle, self._angle_rows = angle_runs(obs.models, obs.slices,
                                                                     len(obs.meas))
        self.eliminates = self.fixed is None and self.k > 0
        # The geometry-free part of the design, whitened once (see ObservationModel).
        self.const_design = obs.const_design
        self.const_design_w = (self.noise.whiten(self.const_design, axis=-2) if self.k
                               else self.const_design)  # (n, 0): nothing to whiten
        # (k, n), read by the elimination only
        self._const_w_t = np.ascontiguousarray(self.const_design_w.T) if self.k else None
        self._reference_fit: tuple[NDArray[np.bool_], NDArray[np.bool_], Array] | None = None
        # One nuisance column per kind at most: the columns touch disjoint rows (whitening
        # mixes rows of one kind only), so they are orthogonal and need no Gram inverse.
        self._orthogonal = all(ns.stop - ns.start <= 1 for ns in obs.nuisance_slices.values())
        self._batch_plan: object = None  # the compiled kernel's plan (False: none applies)

    def take(self, index: NDArray[np.int64] | NDArray[np.bool_]) -> VarProProblem:
        """Restrict the problem to the rows ``index`` of the set.

        Parameters
        ----------
        index : ndarray of int or bool

        Returns
        -------
        VarProProblem
        """
        obs = self.obs.take(index)
        # Rows of independent rows are independent: no need to look for correlated blocks.
        noise = None if self.noise.correlated else NoiseModel.independent(obs.sigmas_grouped)
        return VarProProblem(obs, noise, self.fixed)

    def group(self, y: Array) -> Array:
        """Reorder data ``(..., n)`` from the set's row order to the solver's grouped order.

        Parameters
        ----------
        y : ndarray

        Returns
        -------
        ndarray
        """
        y = np.asarray(y, dtype=float)
        return y if self.obs.in_set_order else y[..., self.obs.order]

    def reference_nuisance(self, y: Array) -> Array:
        """Give a nuisance ``(B, k)`` close to the data's, about which residuals are formed.

        Parameters
        ----------
        y : ndarray
            ``(B, n)`` or ``(n,)`` grouped data, SI.

        Returns
        -------
        ndarray
        """
        b = y.shape[0] if y.ndim == 2 else 1
        if self.fixed is not None:
            return np.broadcast_to(self.fixed, (b, self.k)).copy()
        if self.k == 0:
            return np.zeros((b, 0))
        y = np.atleast_2d(y)
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
        """Form ``y - A_const nu*``, the part of the residual independent of ``theta``.

        Parameters
        ----------
        y, nu_star : ndarray
            ``(B, n)`` grouped data and ``(B, k)`` reference nuisance, SI.

        Returns
        -------
        ndarray
            ``(B, n)``.
        """
        if self.k == 0:
            y_float = isinstance(y, np.ndarray) and y.dtype == np.float64 and y.flags.writeable
            return y if y_float else np.array(y, dtype=float)
        return y - nu_star @ self.const_design.T

    def evaluate(self, theta: Array, y: Array, nu_star: Array,
                 with_jacobian: bool = True) -> Evaluation:
        """Eliminate the nuisance at ``theta``; give the reduced residual, cost and Jacobian.

        Parameters
        ----------
        theta, y, nu_star : ndarray
            ``(B, p)`` parameters, ``(B, n)`` grouped data, ``(B, k)`` reference nuisance, SI.
        with_jacobian : bool

        Returns
        -------
        Evaluation
            Cost is half chi2 (inf where a point has no prediction).
        """
        return self.evaluate_part(theta, self.data_part(y, nu_star), nu_star, with_jacobian)

    def evaluate_part(self, theta: Array, u: Array, nu_star: Array,
                      with_jacobian: bool = True, quiet: bool = False,
                      spare: Evaluation | None = None) -> Evaluation:
        """Evaluate as :meth:`evaluate`, from the data part ``u`` ``(B, n)`` of :meth:`data_part`.

        Parameters
        ----------
        theta, u, nu_star, with_jacobian
            As for :meth:`evaluate`.
        quiet : bool
            The caller already ignores floating-point errors.
        spare : Evaluation, optional
            An evaluation of at least ``B`` points no longer read, whose arrays the new one may
            take (a solver's previous trial).

        Returns
        -------
        Evaluation
        """
        theta = np.asarray(theta, dtype=float)
        if quiet:
            return self._evaluate_any(theta, u, nu_star, with_jacobian, spare)
        # Trial points may sit on a sensor (zero range): their cost is infinite, not an error.
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._evaluate_any(theta, u, nu_star, with_jacobian, spare)

    def _evaluate_any(self, theta: Array, u: Array, nu_star: Array, with_jacobian: bool,
                      spare: Evaluation | None = None) -> Evaluation:
        """Evaluate by chunks of rows or at once (see :meth:`evaluate_part`)."""
        if self._batch_plan is not False and _compiled_batches[0]:
            compiled = self._evaluate_batch_compiled(theta, u, nu_star, with_jacobian)
            if compiled is not None:
                return compiled
        if u.shape[-1] > blas.CHUNKED_ROWS and self.k == 0:
            return self._evaluate_chunked(theta, u, nu_star, with_jacobian)
        if self.eliminates and u.shape[0] > _starts_per_block(u.shape[-1]):
            return self._evaluate_blocks(theta, u, nu_star, with_jacobian, spare)
        return self._evaluate(theta, u, nu_star, with_jacobian)

    def _evaluate_batch_compiled(self, theta: Array, u: Array, nu_star: Array,
                                 with_jacobian: bool) -> Evaluation | None:
        """Evaluate by the compiled kernel of :mod:`tmakit.observation.varpro_compiled`."""
        from ..observation.varpro_compiled import evaluate_batch, plan_for

        if self._batch_plan is None:
            independent = not self.noise.correlated and not self.noise.blocks
            self._batch_plan = plan_for(self.obs, self.noise.inv_sigma if independent else None,
                                        self.const_design) or False
        if self._batch_plan is False:
            return None
        got = evaluate_batch(self._batch_plan, theta, u, nu_star,  # type: ignore[arg-type]
                             self.eliminates, with_jacobian)
        if got is None:
            return None
        r, nu, cost, jtj, jtr = got
        cost = np.where(cost < np.inf, cost, np.inf)  # nan (no prediction) -> inf
        return Evaluation(theta, nu, r, cost, None, (jtj, jtr) if with_jacobian else None)

    def _evaluate_chunked(self, theta: Array, u: Array, nu_star: Array, with_jacobian: bool
                          ) -> Evaluation:
        """Evaluate in chunks of rows, summing J'J and J'r (no Jacobian held)."""
        b, n = u.shape
        r = np.empty((b, n))
        gram, grad = np.zeros((b, self.p, self.p)), np.zeros((b, self.p))
        for lo, hi in self.noise.chunk_bounds(blas.CHUNK_ROWS):
            part = self.take(self.obs.order[lo:hi])._evaluate(theta, u[:, lo:hi], nu_star,
                                                              with_jacobian)
            r[:, lo:hi] = part.residual
            if (normal := normal_of(part)) is not None:  # (its J'J and J'r, however held)
                gram += normal[0]
                grad += normal[1]
        cost = 0.5 * np.einsum("bn,bn->b", r, r)
        cost = np.where(cost < np.inf, cost, np.inf)  # nan (no prediction) -> inf
        return Evaluation(theta, np.array(nu_star, dtype=float), r, cost, None,
                          (gram, grad) if with_jacobian else None)

    def _evaluate_blocks(self, theta: Array, u: Array, nu_star: Array, with_jacobian: bool,
                         spare: Evaluation | None = None) -> Evaluation:
        """Evaluate as :meth:`_evaluate` (the same numbers), by blocks of points."""
        b, n = u.shape
        nu, r, cost, jt = _buffers(spare, b, n, self.k, self.p if with_jacobian else None)
        edges = [*range(0, b, _starts_per_block(n)), b]
        if edges[-1] - edges[-2] == 1:  # a point alone takes other paths (other last bits)
            del edges[-2]
        for lo, hi in itertools.pairwise(edges):  # (nu, r and J' written in place)
            cost[lo:hi] = self._evaluate(theta[lo:hi], u[lo:hi], nu_star[lo:hi], with_jacobian,
                                         (nu[lo:hi], r[lo:hi], None if jt is None
                                          else jt[lo:hi])).cost
        return Evaluation(theta, nu, r, cost, None if jt is None else jt.swapaxes(1, 2))

    def _evaluate(self, theta: Array, u: Array, nu_star: Array, with_jacobian: bool,
                  into: tuple[Array, Array, Array | None] | None = None) -> Evaluation:
        # design and Jacobian transposed, (B, k, n) and (B, p, n): operations run along rows
        lin = self.obs.linearisation(theta, with_jacobian, weights=self._weights)
        at = lin.a_var.swapaxes(-1, -2) if self.k else None
        # y - A_const nu* - h0 - A_var nu*: no two large numbers meet after data_part.
        # The planar path's h0 is its own fresh array, read only here: the residual takes it.
        h0 = lin.h0
        own = lin.planar_jacobian is not None and h0.shape == u.shape
        e = np.subtract(u, h0, out=h0) if own else u - h0
        if at is not None:
            e -= (nu_star[:, None, :] @ at)[:, 0, :]
        if self.all_angle:
            e = _wrap_own(e, in_place=True)  # e is this function's own array
        elif self._angle_rows is not None:  # (e is this function's own array)
            e[..., self._angle_rows] = _wrap_own(e[..., self._angle_rows], in_place=True)
        elif self.has_angle:
            e = np.where(self.angle, wrap_angle(e), e)
        r = self.noise.whiten(e, overwrite=True)  # e is this function's own array
        nu, jac, normal = nu_star, None, None
        if self.eliminates:
            assert at is not None  # (a nuisance to eliminate has its design)
            nu, r, jt = self._project(lin, nu_star, at, r, with_jacobian, into)
            jac = None if jt is None else jt.swapaxes(1, 2)
        elif with_jacobian and (lin.planar_jacobian is not None or (
                normal := motion_normal(self.obs, lin, r, self._weights)) is None):
            jac = lin.jacobian(nu)  # (a new array: whitened in place)
            if not lin.whitened:
                jac = self.noise.whiten(jac, axis=-2, overwrite=True)
        cost = np.einsum("bn,bn->b", r, r)
        if r.shape[0] == 1:  # one point: halved and tested as a float (fewer calls)
            half = 0.5 * float(cost[0])
            cost[0] = half if half < math.inf else math.inf  # nan (no prediction) -> inf
        else:
            cost *= 0.5
            cost = np.where(cost < np.inf, cost, np.inf)  # nan (no prediction) -> inf
        if nu is nu_star and not (isinstance(nu, np.ndarray) and nu.size == 0):
            nu = np.array(nu, dtype=float)  # (eliminated: already a new array)
        return Evaluation(theta, nu, r, cost, jac, normal)

    def _project(self, lin: Linearisation, nu_star: Array, at: Array, r: Array,
                 with_jacobian: bool, into: tuple[Array, Array, Array | None] | None = None
                 ) -> tuple[Array, Array, Array | None]:
        """Eliminate the nuisance: give ``nu``, the projected residual, ``J'`` (into ``into``)."""
        nu_out, r_out, jt_out = (None, None, None) if into is None else into
        assert self._const_w_t is not None  # (made when there is a nuisance)
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
        nu = np.add(nu_star, coef[..., 0] / norm, out=nu_out)
        r = np.subtract(r, (qt @ coef)[..., 0], out=r_out)
        jt = None
        if with_jacobian:
            # Kaufman's projected Jacobian, at the eliminated nuisance.
            jt = self.noise.whiten(lin.jacobian(nu).swapaxes(-1, -2), overwrite=True)
            proj = jt @ qt
            if ginv is not None:
                proj = proj @ ginv
            jt = np.subtract(jt, proj @ q, out=jt_out)
        return nu, r, jt

    def initial_nuisance(self, theta: Array, y: Array) -> Array:
        """Give the nuisance values ``(B, k)`` eliminated at ``theta``.

        Parameters
        ----------
        theta, y : ndarray
            ``(B, p)``, SI; ``(n,)`` or ``(B, n)`` grouped data, SI.

        Returns
        -------
        ndarray
        """
        y = np.broadcast_to(y, (theta.shape[0], y.shape[-1]))
        return self.evaluate(theta, y, self.reference_nuisance(y), with_jacobian=False).nuisance
