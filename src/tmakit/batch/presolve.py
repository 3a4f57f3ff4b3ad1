"""Many rows: the no-guess fit first converges its starts on a subset of rows.

Above :data:`PRESOLVE_ROWS` independent rows the grid and starts run on :data:`PRESOLVE_SUBSET`
rows; the full solve then takes two Gauss–Newton steps and a polished third
(:data:`POLISH_DECREMENT`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..core.frames import wrap_angle_own
from ..observation.planar import gradient_of_rows, planar_gradient_rows
from ..results.observability import full_rank
from .init import GridSettings, Starts, best_starts_many, subsample
from .solver import Fallback, SolveResult, VarProProblem, levenberg_marquardt

__all__ = ["POLISH_DECREMENT", "PRESOLVE_ROWS", "PRESOLVE_SUBSET", "gradient_at", "grid_starts",
           "presolve", "presolve_subset", "solve_all_rows", "subset_step"]

PRESOLVE_ROWS = 20_000
"""Rows above which the no-guess fit (:func:`~tmakit.batch.ml.solve_without_guess`) first
converges its starts on a subset."""
PRESOLVE_SUBSET = 2_000
"""Evenly spread rows of that subset (its optimum a few of the whole set's standard deviations
from the whole set's: the full solve then needs two steps; docs/estimation.md)."""

PRESOLVE_DTOL = 0.5
"""Decrement (half chi2 of the subset) at which the presolve stops: within one of the subset's
standard deviations of its optimum; :func:`subset_step` takes the whole way from there."""


def presolve_subset(problem: VarProProblem
                    ) -> tuple[VarProProblem, NDArray[np.int64]] | None:
    """Give the subset :func:`presolve` fits on and its rows, or None for few rows."""
    if len(problem.obs.meas) <= PRESOLVE_ROWS:
        return None
    small, rows = subsample(problem, PRESOLVE_SUBSET)
    return None if small is problem else (small, rows)


def grid_starts(problem: VarProProblem, ys: NDArray[np.float64], settings: GridSettings,
                subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> list[Starts]:
    """Rank the grid's starting points, on the presolve's subset when there is one."""
    if subset is None:
        return best_starts_many(problem, ys, settings)
    return best_starts_many(subset[0], ys[:, subset[1]], settings)


def presolve(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
             max_iter: int, subset: tuple[VarProProblem, NDArray[np.int64]] | None = None
             ) -> tuple[NDArray[np.float64], bool]:
    """Move starting points to their optimum on a subset of rows, for problems of many rows."""
    theta, near, _ = _presolve(problem, ys, theta, max_iter, subset)
    return theta, near


def _presolve(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
              max_iter: int, subset: tuple[VarProProblem, NDArray[np.int64]] | None
              ) -> tuple[NDArray[np.float64], bool, NDArray[np.float64] | None]:
    """:func:`presolve`, and the subset's ``J'J`` at its optima scaled to every row."""
    subset = subset or presolve_subset(problem)
    if subset is None:
        return theta, False, None
    small, rows = subset
    pre = levenberg_marquardt(small, ys[:, rows], theta, max_iter=max_iter, dtol=PRESOLVE_DTOL)
    ok = pre.converged & np.isfinite(pre.cost)
    if pre.information is not None:
        # A subset that cannot see every parameter has no optimum near the whole set's
        # (bearings from a barely turning observer fit at 10^7 m): such a start stays.
        sound = ok & np.isfinite(pre.information).all(axis=(1, 2))
        ok[sound] = full_rank(pre.information[sound])
    information = None
    if pre.information is not None and not problem.eliminates:
        # each evenly spread row of the subset stands for n / m rows of the whole set
        whole, part = problem.noise.inv_sigma, small.noise.inv_sigma
        information = np.where(ok[:, None, None], pre.information, np.nan) * (
            np.einsum("n,n->", whole, whole) / np.einsum("n,n->", part, part))
    return np.where(ok[:, None], pre.theta, theta), bool(ok.all()), information


def gradient_at(problem: VarProProblem, theta: NDArray[np.float64], u: NDArray[np.float64]
                ) -> tuple[float, NDArray[np.float64]] | None:
    """Give half chi2 and ``J'r`` at one point without forming the Jacobian, or None."""
    theta = np.asarray(theta, dtype=float)
    weights = problem._weights
    if (problem.k or weights is None or not problem.all_angle or u.shape[0] != 1
            or theta.shape[0] != 1):
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        found = planar_gradient_rows(problem.obs, theta, weights)
        if found is None:
            return None
        h0, rows = found
        e = wrap_angle_own(np.subtract(u[0], h0, out=h0), in_place=True)  # (h0 is ours)
        r = problem.noise.whiten(e, overwrite=True)
        return 0.5 * float(np.einsum("n,n->", r, r)), gradient_of_rows(problem.obs, rows, r)


def subset_step(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
                information: NDArray[np.float64] | None
                ) -> tuple[NDArray[np.float64], float] | None:
    """Take the first Gauss–Newton step on every row with the subset's ``J'J``, or None."""
    if (theta.shape[0] != 1 or information is None
            or not np.all(np.isfinite(information))):
        return None
    y = problem.group(ys)
    found = gradient_at(problem, theta, problem.data_part(y, problem.reference_nuisance(y)))
    if found is None or not np.isfinite(found[0]):
        return None
    try:
        step = np.linalg.solve(information[0], found[1])
    except np.linalg.LinAlgError:
        return None
    return (theta + step[None], found[0]) if np.all(np.isfinite(step)) else None


def _fallback(theta: NDArray[np.float64], stepped: tuple[NDArray[np.float64], float] | None,
              information: NDArray[np.float64] | None) -> Fallback | None:
    """Give the presolve's point and cost (and information) to fall back on, if stepped."""
    if stepped is None:
        return None
    cost = np.array([stepped[1]], dtype=np.float64)
    return (theta, cost) if information is None else (theta, cost, information)


POLISH_DECREMENT = 0.5
"""Decrement (half chi2) from which the full solve after a presolve ends with a step checked
by its residuals alone (``polish`` of :func:`~tmakit.batch.solver.levenberg_marquardt`)."""


def solve_all_rows(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
                   max_iter: int, groups: NDArray[np.int64], ceiling: NDArray[np.float64],
                   subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> SolveResult:
    """Solve every row from starts first converged on the subset (:func:`presolve`)."""
    theta, near, information = _presolve(problem, ys, theta, max_iter, subset)
    stepped = subset_step(problem, ys, theta, information) if near else None
    sol = levenberg_marquardt(problem, ys, theta if stepped is None else stepped[0],
                              max_iter=max_iter, groups=groups, ceiling=ceiling,
                              damping0=1e-8 if near else 1e-3,
                              polish=POLISH_DECREMENT if near else 0.0,
                              fallback=_fallback(theta, stepped, information))
    if stepped is not None:
        sol.iterations += 1  # the step taken with the subset's J'J
    return sol
