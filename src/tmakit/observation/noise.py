"""The measurement noise covariance of a measurement set, and whitening by it.

Most rows are independent with their own sigma.  Range differences of one sensor that share
pulse intervals are correlated (003_e5155d4fe60daef8.txt eq. 1: one noise term per interval); their
block is dense and whitened with its eigen-decomposition.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet
from ..measurements import range_difference_covariance


class NoiseModel:
    """Whitening ``x -> W x`` with ``W^T W = R^+`` for the noise covariance ``R`` (SI units).

    Range differences that share pulse intervals have a dense covariance block, whitened with
    its eigen-decomposition.  Sets that repeat information (a lag-2 difference next to the two
    lag-1 differences it is the sum of) have a singular block: the repeated combinations get
    zero weight and :attr:`rank` counts the independent rows (use it for degrees of freedom).
    """

    def __init__(self, meas: MeasurementSet) -> None:
        sigma = meas.sigma_si
        self.n = len(meas)
        self.inv_sigma = 1.0 / sigma
        self.blocks: list[tuple[NDArray[np.int64], NDArray[np.float64]]] = []
        self.rank = self.n
        self.log_det = float(2.0 * np.sum(np.log(sigma)))
        rd = meas.kind == "range_difference"
        for s in np.unique(meas.sensor[rd]) if rd.any() else ():
            rows = np.flatnonzero(rd & (meas.sensor == s))
            cov = range_difference_covariance(meas.time[rows], meas.time_ref[rows],
                                              sigma[rows])
            if np.count_nonzero(cov - np.diag(np.diag(cov))) == 0:
                continue  # no shared intervals: the diagonal is exact
            evals, evecs = np.linalg.eigh(cov)
            keep = evals > 1e-10 * evals.max()
            whitener = np.zeros((rows.size, rows.size))
            whitener[: keep.sum()] = (evecs[:, keep] / np.sqrt(evals[keep])).T
            self.blocks.append((rows, whitener))
            self.rank -= int(rows.size - keep.sum())
            self.log_det += float(np.sum(np.log(evals[keep])) - 2.0 * np.sum(np.log(
                sigma[rows])))
        self.correlated = bool(self.blocks)

    @classmethod
    def independent(cls, sigma: NDArray[np.float64]) -> NoiseModel:
        """The model of independent rows with standard deviations ``sigma`` (SI): what the
        constructor makes for a set without correlated range differences, without the set."""
        out = object.__new__(cls)
        sigma = np.asarray(sigma, dtype=float)
        out.n = sigma.shape[0]
        out.inv_sigma = 1.0 / sigma
        out.blocks = []
        out.rank = out.n
        out.log_det = float(2.0 * np.sum(np.log(sigma)))
        out.correlated = False
        return out

    def whiten(self, x: NDArray[np.float64], axis: int = -1) -> NDArray[np.float64]:
        """``W x`` along ``axis`` (the measurement axis) of ``x``."""
        if not self.blocks:  # independent rows: a scaling (the common, hot case)
            x = np.asarray(x, dtype=float)
            if axis == -1:
                return x * self.inv_sigma
            if axis == -2:
                return x * self.inv_sigma[:, None]
        x = np.moveaxis(np.asarray(x, dtype=float), axis, -1)
        out = x * self.inv_sigma
        for rows, whitener in self.blocks:
            out[..., rows] = np.einsum("ij,...j->...i", whitener, x[..., rows])
        return np.moveaxis(out, -1, axis)

    def covariance(self) -> NDArray[np.float64]:
        """The dense covariance matrix (for small sets and tests; pseudo-inverse of W^T W)."""
        w = self.whiten(np.eye(self.n), axis=0)
        return np.linalg.pinv(w.T @ w, rcond=1e-10, hermitian=True)
