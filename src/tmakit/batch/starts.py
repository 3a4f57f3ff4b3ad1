"""The distinct starting points the grid gives, best first (:mod:`tmakit.batch.init`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["Starts", "starts_of"]


class Starts:
    """The mutually distinct candidates of one data set, best first, chosen when asked for.

    Greedily in order of cost, each candidate not within 5 % of each parameter's spread of one
    already chosen.

    Parameters
    ----------
    candidates : ndarray, shape (C, p)
        Motion parameters (SI).
    cost : ndarray, shape (C,)
        Their grid costs (non-finite: never chosen).
    scaled : ndarray, shape (p, C), optional
        The candidates over that spread, transposed; may be shared by data sets with the
        same candidates.
    """

    def __init__(self, candidates: NDArray[np.float64], cost: NDArray[np.float64],
                 scaled: NDArray[np.float64] | None = None) -> None:
        self.candidates = candidates
        self.scaled = _scaled(candidates) if scaled is None else scaled
        self.left = np.where(np.isfinite(cost), cost, np.inf)
        self.chosen: list[int] = []

    def first(self, m: int) -> NDArray[np.float64]:
        """Return the ``m`` best distinct candidates.

        Parameters
        ----------
        m : int
            How many.

        Returns
        -------
        ndarray, shape (<= m, p)
            Motion parameters (SI), best first; fewer when no more are finite.
        """
        while len(self.chosen) < m:
            i = int(np.argmin(self.left))
            if not np.isfinite(self.left[i]):
                break
            self.chosen.append(i)
            near = np.max(np.abs(self.scaled - self.scaled[:, i:i + 1]), axis=0) <= 0.05
            self.left[near] = np.inf
        return self.candidates[self.chosen[:m]]


def _scaled(candidates: NDArray[np.float64]) -> NDArray[np.float64]:
    """Candidates over each parameter's spread, transposed ``(p, C)`` for fast distances."""
    scaled = np.array(candidates.T, order="C")  # a copy; reductions along rows: fast
    scaled /= np.maximum(np.abs(scaled).max(axis=1), 1.0)[:, None]
    return scaled


def starts_of(candidates: NDArray[np.float64], costs: NDArray[np.float64]) -> list[Starts]:
    """Return the :class:`Starts` of several data sets scored on the same candidates.

    They share the scaled candidates (made once).

    Parameters
    ----------
    candidates : ndarray, shape (C, p)
        Motion parameters (SI).
    costs : ndarray, shape (B, C)
        The grid costs of each data set (non-finite: never chosen).

    Returns
    -------
    list of Starts
        One per data set.
    """
    scaled = _scaled(candidates)
    return [Starts(candidates, cost, scaled) for cost in costs]
