"""``J'J`` and ``J'r`` from the motion model itself, where it can sum them without ``J``.

For a model with ``normal_equations`` (piecewise curvilinear) and no nuisance, reference
samples or correlated noise; the sums are made when first read (:class:`DeferredNormal`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from ..observation import Linearisation

__all__ = ["DeferredNormal", "motion_normal"]


class DeferredNormal:
    """``J'J`` and ``J'r`` of a batch, summed when first read, for the runs read.

    Read as the pair ``(J'J, J'r)`` (indexing, unpacking): the whole is then summed once and
    kept.  :meth:`take` and :meth:`runs` sum only some runs.  Every run's sums are the same
    bits however they are asked for.

    Parameters
    ----------
    make : callable
        ``make(runs)`` gives ``(R, p, p)`` and ``(R, p)`` for the rows ``runs`` of the batch
        it was made for (None: all).
    size : int
        The number of runs of that batch.
    rows : ndarray of int, optional
        The runs this object stands for, rows of that batch (default all).
    """

    def __init__(self, make: Callable[[NDArray[np.int64] | None], tuple[Array, Array]],
                 size: int, rows: NDArray[np.int64] | None = None) -> None:
        self._make, self._size, self._rows = make, size, rows
        self._value: tuple[Array, Array] | None = None

    def _whole(self) -> tuple[Array, Array]:
        if self._value is None:
            self._value = self._make(self._rows)
        return self._value

    def __getitem__(self, i: int) -> Array:
        """Give ``J'J`` (0) or ``J'r`` (1) of every run, summing them if not yet done."""
        return self._whole()[i]

    def __iter__(self) -> Iterator[Array]:
        """Give ``J'J`` then ``J'r``."""
        return iter(self._whole())

    def __len__(self) -> int:
        """Two: ``J'J`` and ``J'r``."""
        return 2

    def runs(self, which: NDArray[np.bool_] | NDArray[np.int64] | slice) -> tuple[Array, Array]:
        """Give the sums of the runs ``which`` (indices into this object's runs)."""
        if self._value is not None:
            return self._value[0][which], self._value[1][which]
        own = np.arange(self._size) if self._rows is None else self._rows
        return self._make(own[which])

    def take(self, which: NDArray[np.bool_] | NDArray[np.int64] | slice
             ) -> DeferredNormal | tuple[Array, Array]:
        """Stand for the runs ``which`` only (their sums still deferred, or copied if made)."""
        if self._value is not None:
            return self._value[0][which], self._value[1][which]
        own = np.arange(self._size) if self._rows is None else self._rows
        return DeferredNormal(self._make, self._size, own[which])


def motion_normal(obs: Any, lin: Linearisation, residual: Array, weights: Array | None
                  ) -> DeferredNormal | None:
    """Give ``J'J`` and ``J'r`` of the whitened Jacobian from the motion model, or None."""
    normal = getattr(obs.motion, "normal_equations_later", None)
    if (normal is None or weights is None or lin.planar_jacobian is not None or lin.d_h0 is None
            or lin.d_a or lin.d_h0_ref is not None or lin.theta.ndim != 2):
        return None
    make = normal(lin.d_h0, residual, weights, lin.theta, obs._time)
    return None if make is None else DeferredNormal(make, residual.shape[0])
