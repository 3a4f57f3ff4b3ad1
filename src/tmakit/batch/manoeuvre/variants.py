"""Fits that each hold their own parameters, solved in one batch.

The selection of the accelerations (:func:`tmakit.batch.manoeuvre.selection.sparsify`) and the
fine profile of the change-over times (:meth:`ManoeuvreSearch.polish
<tmakit.batch.manoeuvre.search.ManoeuvreSearch.polish>`) fit several variants of one problem,
each holding a different parameter.  The solver holds the same columns for a whole batch, so
fitted one variant after another they cost one solver loop each.  Here the variants share one
loop: every run's parameters are reordered, its free ones first (in their own order), its held
ones last, and a last column carries the run's variant (held, so never moved); the problem seen
by the solver (:class:`HeldVariants`) puts the parameters back in place before evaluating and
reorders the Jacobian's columns.  The free columns of every run are then those a fit of its
variant alone has, in the same order, and each run's steps, damping and stopping tests are its
own (the dominance test within a variant's group, :func:`batched_fit`): the fits are those of
the variants fitted one by one, to the last bit (``tests/test_manoeuvre_variants.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...arrays import Array
from ..solver import Evaluation, SolveResult, VarProProblem


class HeldVariants:
    """A least-squares problem whose runs each hold their own parameters.

    Parameters
    ----------
    problem : VarProProblem
        The problem (``p`` parameters).
    free_sets : ndarray of bool
        ``(V, p)`` the parameters each variant fits; every variant fits as many.

    Raises
    ------
    ValueError
        When the variants fit different numbers of parameters.
    """

    def __init__(self, problem: VarProProblem, free_sets: NDArray[np.bool_]) -> None:
        free_sets = np.atleast_2d(np.asarray(free_sets, dtype=bool))
        counts = free_sets.sum(axis=1)
        if np.any(counts != counts[0]):
            raise ValueError("every variant must fit as many parameters")
        self.problem = problem
        self.p = problem.p + 1
        # free columns first in their own order, then the held ones: stable sort on "held"
        self.order = np.argsort(~free_sets, axis=1, kind="stable")
        self.free = np.zeros(self.p, dtype=bool)
        self.free[:int(counts[0])] = True

    def __getattr__(self, name: str) -> Any:
        """Give the wrapped problem's attributes (data, noise, observation model, ...)."""
        return getattr(self.problem, name)

    def pack(self, theta: Array, variant: NDArray[np.int64]) -> Array:
        """Reorder parameter vectors for the solver.

        Parameters
        ----------
        theta : ndarray
            ``(B, p)`` parameters (SI).
        variant : ndarray of int
            ``(B,)`` every vector's variant.

        Returns
        -------
        ndarray
            ``(B, p + 1)``: each run's free parameters, its held ones, its variant.
        """
        order = self.order[variant]
        packed = np.empty((theta.shape[0], self.p))
        packed[:, :-1] = np.take_along_axis(theta, order, axis=1)
        packed[:, -1] = variant
        return packed

    def unpack(self, packed: Array) -> tuple[Array, NDArray[np.int64]]:
        """Put reordered parameters back in place.

        Parameters
        ----------
        packed : ndarray
            ``(B, p + 1)`` as :meth:`pack` gives them.

        Returns
        -------
        theta : ndarray
            ``(B, p)`` parameters (SI).
        variant : ndarray of int
            ``(B,)`` every vector's variant.
        """
        variant = packed[:, -1].astype(np.int64)
        theta = np.empty((packed.shape[0], self.p - 1))
        np.put_along_axis(theta, self.order[variant], packed[:, :-1], axis=1)
        return theta, variant

    def evaluate_part(self, theta: Array, u: Array, nu_star: Array,
                      with_jacobian: bool = True) -> Evaluation:
        """Evaluate reordered parameter vectors (:meth:`VarProProblem.evaluate_part`).

        Parameters
        ----------
        theta : ndarray
            ``(B, p + 1)`` reordered parameters (:meth:`pack`).
        u, nu_star : ndarray
            As for :meth:`VarProProblem.evaluate_part`.
        with_jacobian : bool
            Whether to compute the Jacobian (its columns reordered like ``theta``; the
            variant's column zero).

        Returns
        -------
        Evaluation
            At ``theta`` (reordered).
        """
        plain, variant = self.unpack(theta)
        ev = self.problem.evaluate_part(plain, u, nu_star, with_jacobian)
        order = self.order[variant]
        jac, normal = None, None
        if ev.jacobian is not None:
            jac = np.zeros((*ev.jacobian.shape[:2], self.p))
            jac[:, :, :-1] = np.take_along_axis(ev.jacobian, order[:, None, :], axis=2)
        if ev.normal is not None:
            gram, grad = ev.normal
            g = np.zeros((theta.shape[0], self.p, self.p))
            rows = np.take_along_axis(gram, order[:, :, None], axis=1)
            g[:, :-1, :-1] = np.take_along_axis(rows, order[:, None, :], axis=2)
            d = np.zeros((theta.shape[0], self.p))
            d[:, :-1] = np.take_along_axis(grad, order, axis=1)
            normal = (g, d)
        return Evaluation(np.array(theta, dtype=float), ev.nuisance, ev.residual, ev.cost, jac,
                          normal)


def batched_fit(fit: Callable[..., SolveResult], problem: VarProProblem, starts: Array,
                free_sets: NDArray[np.bool_], variant: NDArray[np.int64],
                **kw: Any) -> SolveResult:
    """Fit starts of several held variants in one solver loop.

    Parameters
    ----------
    fit : callable
        :func:`tmakit.batch.manoeuvre.search.lm_fit` (its keywords in ``kw``).
    problem : VarProProblem
        The problem.
    starts : ndarray
        ``(B, p)`` starting points (SI).
    free_sets : ndarray of bool
        ``(V, p)`` the parameters each variant fits (as many for all).
    variant : ndarray of int
        ``(B,)`` every start's variant.
    **kw
        Keywords of ``fit`` (``max_iter``, ``prune``, ...); with ``prune``, every variant is
        its own group for the dominance test, as when fitted alone.

    Returns
    -------
    SolveResult
        In place (``theta`` ``(B, p)`` in the problem's own order), as if each variant had
        been fitted alone.
    """
    held = HeldVariants(problem, free_sets)
    groups = np.asarray(variant, dtype=np.int64) if kw.get("prune") is not None else None
    sol = fit(held, held.pack(np.asarray(starts, dtype=float), variant), held.free,
              groups=groups, **kw)
    sol.theta = held.unpack(sol.theta)[0]
    return sol


BLOCK = 32
"""Parameter vectors per evaluation in :class:`BlockedProblem` (bounds the working set)."""


class BlockedProblem(VarProProblem):
    """A :class:`VarProProblem` that evaluates large batches in blocks of :data:`BLOCK` rows.

    The profile of the change-over times fits hundreds of grid points at once; evaluated in
    one piece their ``(B, n, p)`` arrays leave the caches.  Each row's evaluation is its own,
    so the blocks give the same numbers (``tests/test_manoeuvre_variants.py``).
    """

    def evaluate_part(self, theta: Array, u: Array, nu_star: Array,
                      with_jacobian: bool = True) -> Evaluation:
        """Evaluate as :meth:`VarProProblem.evaluate_part`, in blocks of rows.

        Parameters
        ----------
        theta, u, nu_star : ndarray
            ``(B, p)``, ``(B, n)``, ``(B, k)`` as for :meth:`VarProProblem.evaluate_part`.
        with_jacobian : bool
            Whether to compute the Jacobian.

        Returns
        -------
        Evaluation
            Of every row.
        """
        b = np.shape(theta)[0]
        if b <= BLOCK:
            return super().evaluate_part(theta, u, nu_star, with_jacobian)
        parts = [super(BlockedProblem, self).evaluate_part(theta[a:a + BLOCK], u[a:a + BLOCK],
                                                           nu_star[a:a + BLOCK], with_jacobian)
                 for a in range(0, b, BLOCK)]

        def join(name: str) -> Array | None:
            got = [getattr(p, name) for p in parts]
            return None if got[0] is None else np.concatenate(got)

        normal = None
        if parts[0].normal is not None:
            normal = (np.concatenate([p.normal[0] for p in parts]),
                      np.concatenate([p.normal[1] for p in parts]))
        return Evaluation(join("theta"), join("nuisance"), join("residual"), join("cost"),
                          join("jacobian"), normal)
