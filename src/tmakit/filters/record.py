"""What a filter's updates saw, and the collector of a run's per-update outputs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array


@dataclass(frozen=True)
class UpdateInfo:
    """What one update saw.

    Parameters
    ----------
    nis : float
        Normalised innovation squared (NaN for a skipped update).
    dof : int
        Its degrees of freedom (measurement rows; 0 when skipped).
    log_likelihood : float
        Log-likelihood of the group given the past (nats).
    """

    nis: float
    dof: int
    log_likelihood: float


@dataclass
class RunBlock:
    """Updates a filter ran in one go: the final estimate and each update's outputs.

    Parameters
    ----------
    stop : int
        Index of the first update not run (the number of updates when all were).
    mean, covariance : numpy.ndarray
        Final state ``(n,)`` (m, m/s) and covariance ``(n, n)``.
    time : float
        Final time (s).
    log_likelihood : float
        Final cumulative log-likelihood (nats).
    times, states, covariances, nis, log_likelihoods, dof : numpy.ndarray
        Per update: times ``(k,)`` (s), states ``(k, n)``, covariances ``(k, n, n)``, NIS
        ``(k,)``, cumulative log-likelihoods ``(k,)`` and degrees of freedom ``(k,)``.
    """

    stop: int
    mean: Array
    covariance: Array
    time: float
    log_likelihood: float
    times: Array
    states: Array
    covariances: Array
    nis: Array
    log_likelihoods: Array
    dof: Array


class Recorder:
    """Collects a filter's per-update outputs (single updates and blocks).

    Parameters
    ----------
    n : int
        State size.
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.blocks: list[tuple[NDArray[Any], ...]] = []
        self.rows: list[tuple[float, Array, Array, float, int, float]] = []

    def add(self, time: float, state: Array, cov: Array, info: UpdateInfo,
            loglik: float) -> None:
        """Record one update."""
        self.rows.append((time, state, cov, info.nis, info.dof, loglik))

    def _flush(self) -> None:
        if self.rows:
            t, x, p, nis, dof, ll = zip(*self.rows, strict=True)
            self.blocks.append((np.array(t, dtype=float), np.array(x, dtype=float),
                                np.array(p, dtype=float), np.array(nis, dtype=float),
                                np.array(dof, dtype=np.int64), np.array(ll, dtype=float)))
            self.rows = []

    def add_block(self, block: RunBlock) -> None:
        """Record the updates of a block."""
        self._flush()
        self.blocks.append((block.times, block.states, block.covariances, block.nis,
                            block.dof, block.log_likelihoods))

    def parts(self) -> list[NDArray[Any]]:
        """Give the stacked outputs of every update recorded."""
        self._flush()
        n = self.n
        if not self.blocks:
            return [np.zeros(0), np.zeros((0, n)), np.zeros((0, n, n)), np.zeros(0),
                    np.zeros(0, dtype=np.int64), np.zeros(0)]
        parts = [np.concatenate([b[i] for b in self.blocks]) for i in range(6)]
        return [parts[0], parts[1].reshape(-1, n), parts[2].reshape(-1, n, n), parts[3],
                parts[4].astype(np.int64), parts[5]]
