"""Fits of many correlated rows: every starting point solved on a subset, one carried to all.

For correlated range differences the whole multi-start strategy runs on :data:`SUBSET_ROWS`
evenly spread rows; only the subset's best fit per data set is then solved on every row.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .init import subsample
from .solver import VarProProblem, information_of, levenberg_marquardt

__all__ = ["SUBSET_FIRST_ROWS", "SUBSET_ROWS", "solve_on_subset_first", "subset_first"]

SUBSET_FIRST_ROWS = 20_000
"""Rows above which a problem with correlated noise is solved on a subset first."""
SUBSET_ROWS = 5_000
"""Evenly spread rows of that subset (every start is solved there, not only the best, as in
:data:`tmakit.batch.presolve.PRESOLVE_SUBSET`)."""


def subset_first(problem: VarProProblem) -> bool:
    """Tell whether ``problem`` chooses its start on a subset (correlated noise, many rows)."""
    rows = len(problem.obs.meas)
    return bool(problem.noise.correlated) and rows > max(SUBSET_FIRST_ROWS, 2 * SUBSET_ROWS)


def solve_on_subset_first(problem: VarProProblem, ys: NDArray[np.float64],
                          solve_all: Callable[[VarProProblem, NDArray[np.float64]],
                                              Sequence[Any]],
                          max_iter: int) -> list[Any]:
    """Fit each data set on a subset with every start, then its best fit on every row."""
    small, rows = subsample(problem, SUBSET_ROWS)
    found = list(solve_all(small, ys[:, rows]))
    runs = [r for r, fit in enumerate(found) if fit is not None]
    if not runs or small is problem:
        return found
    theta = np.stack([found[r].theta for r in runs])
    # The subset's optimum is within a few standard deviations of the whole set's: one or
    # two lightly damped steps.
    sol = levenberg_marquardt(problem, ys[runs], theta, max_iter=max_iter, damping0=1e-8)
    for i, r in enumerate(runs):
        fit = found[r]
        fit.theta, fit.nuisance = sol.theta[i], sol.nuisance[i]
        fit.cost, fit.iterations = float(sol.cost[i]), int(sol.iterations[i])
        fit.converged = bool(sol.converged[i])
        fit.information = information_of(problem, sol.evaluation, i, sol.information)
    return found
