"""What a filter's updates saw, and the collector of a run's per-update outputs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from .kernels import KernelRun


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



class Recorder:
    """Collects a filter's per-update outputs (single updates and kernel blocks).

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

    def add_block(self, block: KernelRun) -> None:
        """Record the updates of a kernel or general-path run."""
        self._flush()
        k = block.states.shape[0]
        dof = np.ones(k, dtype=np.int64) if block.dof is None else block.dof
        self.blocks.append((block.times, block.states, block.covariances, block.nis, dof,
                            block.log_likelihoods))

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
