"""Many rows: the no-guess fit first converges its starts on a subset of rows.

Above :data:`PRESOLVE_ROWS` rows (independent noise) :func:`~tmakit.batch.ml.solve_without_guess`
scores its grid and fits its starts on :data:`PRESOLVE_SUBSET` evenly spread rows; the subset's
optimum lies a few of the whole set's standard deviations from the whole set's optimum, so the
solve on every row then takes two Gauss–Newton steps and ends with a third checked by its
residuals alone (:data:`POLISH_DECREMENT`).  Every full-size evaluation costs more than the
subset's whole fit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .init import GridSettings, Starts, best_starts_many, subsample
from .solver import SolveResult, VarProProblem, levenberg_marquardt

__all__ = ["POLISH_DECREMENT", "PRESOLVE_ROWS", "PRESOLVE_SUBSET", "grid_starts", "presolve",
           "presolve_subset", "solve_all_rows"]

PRESOLVE_ROWS = 20_000
"""Rows above which the no-guess fit (:func:`~tmakit.batch.ml.solve_without_guess`) first
converges its starts on a subset."""
PRESOLVE_SUBSET = 2_000
"""Evenly spread rows of that subset (its optimum lies a few standard deviations of the whole
set's from the whole set's: the full solve then needs two steps, not five or six; on 10^5
rows of ``bearings-only-2d`` 2,000 rows cost less in all than 5,000)."""

PRESOLVE_DTOL = 1e-2
"""Decrement (half chi2 of the subset) at which the presolve stops: within 0.14 of the
subset's standard deviations of its optimum, which lies several of them from the whole set's;
the solve on every row starts there either way (1e-5, the solver's default, took one more step)."""


def presolve_subset(problem: VarProProblem
                    ) -> tuple[VarProProblem, NDArray[np.int64]] | None:
    """Give the subset :func:`presolve` fits on and its rows, or None for few rows.

    Parameters
    ----------
    problem : VarProProblem
        The whole problem.

    Returns
    -------
    (VarProProblem, ndarray of int) or None
        :data:`PRESOLVE_SUBSET` evenly spread rows (:func:`~tmakit.batch.init.subsample`) of
        a problem of more than :data:`PRESOLVE_ROWS` rows; None otherwise.
    """
    if len(problem.obs.meas) <= PRESOLVE_ROWS:
        return None
    small, rows = subsample(problem, PRESOLVE_SUBSET)
    return None if small is problem else (small, rows)


def grid_starts(problem: VarProProblem, ys: NDArray[np.float64], settings: GridSettings,
                subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> list[Starts]:
    """Rank the grid's starting points, on the presolve's subset when there is one.

    The grid needs a few tens of rows (:class:`~tmakit.batch.init.GridSettings`); taken from
    the subset (just made, in the caches) rather than from every row.

    Parameters
    ----------
    problem : VarProProblem
        The whole problem.
    ys : ndarray
        ``(B, n)`` data sets (SI, the measurement set's order).
    settings : GridSettings
        The grid.
    subset : (VarProProblem, ndarray of int) or None
        :func:`presolve_subset` of ``problem``.

    Returns
    -------
    list of Starts
        As :func:`~tmakit.batch.init.best_starts_many`.
    """
    if subset is None:
        return best_starts_many(problem, ys, settings)
    return best_starts_many(subset[0], ys[:, subset[1]], settings)


def presolve(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
             max_iter: int, subset: tuple[VarProProblem, NDArray[np.int64]] | None = None
             ) -> tuple[NDArray[np.float64], bool]:
    """Move starting points to their optimum on a subset of rows, for problems of many rows.

    Below :data:`PRESOLVE_ROWS` rows (or with correlated noise) the starts come back as they
    are.  Otherwise each is fitted by Levenberg–Marquardt on :data:`PRESOLVE_SUBSET` evenly
    spread rows; a fit that converged to a finite cost replaces its start.  Every full-size
    evaluation costs as much as the subset's whole fit.

    Parameters
    ----------
    problem : VarProProblem
        The whole problem.
    ys : ndarray
        ``(B, n)`` data, one row per start (SI, the measurement set's order).
    theta : ndarray
        ``(B, p)`` starting points (SI).
    max_iter : int
        Levenberg–Marquardt iterations at most on the subset.
    subset : (VarProProblem, ndarray of int), optional
        :func:`presolve_subset` of ``problem``, already taken.

    Returns
    -------
    (ndarray, bool)
        ``(B, p)`` the starting points for the whole problem, and whether every one is a
        subset's optimum (near the whole set's: its solve may start lightly damped).
    """
    subset = subset or presolve_subset(problem)
    if subset is None:
        return theta, False
    small, rows = subset
    pre = levenberg_marquardt(small, ys[:, rows], theta, max_iter=max_iter, dtol=PRESOLVE_DTOL)
    ok = pre.converged & np.isfinite(pre.cost)
    return np.where(ok[:, None], pre.theta, theta), bool(ok.all())


POLISH_DECREMENT = 0.5
"""Gauss–Newton decrement (half chi2: a step of at most one standard deviation) from which
the full solve after a presolve ends with a step checked by its residuals alone
(``polish`` of :func:`~tmakit.batch.solver.levenberg_marquardt`)."""


def solve_all_rows(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
                   max_iter: int, groups: NDArray[np.int64], ceiling: NDArray[np.float64],
                   subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> SolveResult:
    """Solve every row from starts first converged on the subset (:func:`presolve`).

    From the subset's optima the solve starts lightly damped and ends with a step checked by
    its residuals alone (:data:`POLISH_DECREMENT`); without a subset it is a plain solve.

    Parameters
    ----------
    problem : VarProProblem
        The whole problem.
    ys : ndarray
        ``(B, n)`` data, one row per start (SI, the measurement set's order).
    theta : ndarray
        ``(B, p)`` starting points (SI).
    max_iter : int
        Levenberg–Marquardt iterations at most, on the subset and on every row.
    groups, ceiling : ndarray
        ``(B,)`` data set of each start and the cost it must beat (the dominance test of
        :func:`~tmakit.batch.solver.levenberg_marquardt`).
    subset : (VarProProblem, ndarray of int) or None
        :func:`presolve_subset` of ``problem``.

    Returns
    -------
    SolveResult
        The final state of every start.
    """
    theta, near = presolve(problem, ys, theta, max_iter, subset)
    return levenberg_marquardt(problem, ys, theta, max_iter=max_iter, groups=groups,
                               ceiling=ceiling, damping0=1e-8 if near else 1e-3,
                               polish=POLISH_DECREMENT if near else 0.0)
