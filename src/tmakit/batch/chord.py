"""The grid's chord cost ``sum w^2 (1 - cos(y - h))`` for bearings alone under affine motion.

``cos h`` and ``sin h`` come from the relative positions
(:class:`~tmakit.observation.planar.PlanarUnits`): no trigonometry per candidate and row.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..core.blas import matmul
from ..observation.planar import PlanarUnits, planar_units
from .solver import VarProProblem

__all__ = ["ChordScorer", "chord_units"]


def chord_units(problem: VarProProblem, rows: NDArray[np.int64] | None = None
                ) -> PlanarUnits | None:
    """Give the predicted angles' sines and cosines of a problem's rows, or None."""
    obs = problem.obs
    if not problem.all_angle or problem.noise.correlated or not obs.in_set_order:
        return None
    return planar_units(obs, rows)


class ChordScorer:
    """Chord cost ``sum w^2 (1 - cos(y - h))`` of candidates from the rows' sines and cosines.

    Parameters
    ----------
    units : PlanarUnits
        The rows' ``theta -> (sin h, cos h)``.
    weight2 : ndarray, shape (m,)
        ``1 / sigma^2``, rad^-2.
    candidates : ndarray, shape (C, p)
        SI.
    step : int
        Candidates per block.
    """

    def __init__(self, units: PlanarUnits, weight2: NDArray[np.float64],
                 candidates: NDArray[np.float64], step: int) -> None:
        self.units = units
        self.weight2 = weight2
        self.candidates = candidates
        self.blocks = [slice(lo, lo + step) for lo in range(0, candidates.shape[0], step)]

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the chord costs of every candidate for each data set."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        w2 = self.weight2
        sin_w, cos_w = (np.sin(y) * w2).T, (np.cos(y) * w2).T  # (m, B)
        total = w2.sum()
        cost = np.empty((y.shape[0], self.candidates.shape[0]))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            for block in self.blocks:
                sin_h, cos_h = self.units(self.candidates[block])
                dot = matmul(sin_h, sin_w)
                dot += matmul(cos_h, cos_w)
                cost[:, block] = (total - dot).T
        return np.where(np.isfinite(cost), cost, np.inf)
