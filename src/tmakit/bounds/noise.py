"""The measurement noise covariance of a measurement set, and whitening by it.

Most rows are independent with their own sigma.  Range differences of one sensor that share
pulse intervals are correlated (003_e5155d4fe60daef8.txt eq. 1: one noise term per interval); their
block is dense and whitened with its Cholesky factor.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cholesky, solve_triangular

from ..data import MeasurementSet
from ..measurements import range_difference_covariance


class NoiseModel:
    """Whitening ``x -> L^{-1} x`` with ``R = L L^T`` the noise covariance (SI units)."""

    def __init__(self, meas: MeasurementSet) -> None:
        sigma = meas.sigma_si
        self.n = len(meas)
        self.inv_sigma = 1.0 / sigma
        self.blocks: list[tuple[NDArray[np.int64], NDArray[np.float64]]] = []
        rd = meas.kind == "range_difference"
        for s in np.unique(meas.sensor[rd]):
            rows = np.flatnonzero(rd & (meas.sensor == s))
            cov = range_difference_covariance(meas.time[rows], meas.time_ref[rows],
                                              sigma[rows])
            if np.count_nonzero(cov - np.diag(np.diag(cov))) == 0:
                continue  # no shared intervals: the diagonal is exact
            chol = cholesky(cov, lower=True)
            inv = solve_triangular(chol, np.eye(rows.size), lower=True)
            self.blocks.append((rows, inv))
        self.correlated = bool(self.blocks)
        logdet = 2.0 * np.sum(np.log(sigma))
        for rows, inv in self.blocks:
            logdet += -2.0 * np.sum(np.log(np.diag(inv))) - 2.0 * np.sum(np.log(sigma[rows]))
        self.log_det = float(logdet)

    def whiten(self, x: NDArray[np.float64], axis: int = -1) -> NDArray[np.float64]:
        """``L^{-1} x`` along ``axis`` (the measurement axis) of ``x``."""
        x = np.moveaxis(np.asarray(x, dtype=float), axis, -1)
        out = x * self.inv_sigma
        for rows, inv in self.blocks:
            out[..., rows] = np.einsum("ij,...j->...i", inv, x[..., rows])
        return np.moveaxis(out, -1, axis)

    def covariance(self) -> NDArray[np.float64]:
        """The dense covariance matrix (for small sets and tests)."""
        winv = self.whiten(np.eye(self.n), axis=0)
        return np.linalg.inv(winv.T @ winv)
