"""The evaluations of a batch of parameter vectors that the least-squares solver steps from.

:class:`Evaluation` holds, per parameter vector, the whitened residuals with the nuisance
projected out, the cost and what a Gauss–Newton step needs (the Jacobian, or ``J'J`` and
``J'r``); :class:`~tmakit.batch.varpro.VarProProblem` makes them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from .varpro_normal import DeferredNormal

__all__ = ["Evaluation", "normal_of"]


@dataclass
class Evaluation:
    """Reduced residuals and what a step needs, for a batch of parameter vectors.

    Parameters
    ----------
    theta : ndarray
        ``(B, p)``, SI.
    nuisance : ndarray
        ``(B, k)`` eliminated or fixed, SI.
    residual : ndarray
        ``(B, n)`` whitened, nuisance projected out.
    cost : ndarray
        ``(B,)`` half the squared residual (inf: no prediction).
    jacobian : ndarray, optional
        ``(B, n, p)`` whitened, projected.
    normal : (ndarray, ndarray), optional
        ``J'J`` ``(B, p, p)`` and ``J'r`` ``(B, p)`` in place of the Jacobian.
    """

    theta: Array      # (B, p)
    nuisance: Array   # (B, k) eliminated (or fixed) nuisance values
    residual: Array   # (B, n) whitened, nuisance projected out
    cost: Array       # (B,)  half the squared whitened residual
    jacobian: Array | None = None  # (B, n, p) whitened, projected
    # (B, p, p) J'J and (B, p) J'r: by chunks, or summed when first read (DeferredNormal)
    normal: tuple[Array, Array] | DeferredNormal | None = None

    def take(self, rows: NDArray[np.bool_] | NDArray[np.int64]) -> Evaluation:
        """Copy the evaluations of ``rows``."""
        normal = self.normal
        if isinstance(normal, DeferredNormal):
            normal = normal.take(rows)  # (still deferred unless already summed)
        elif normal is not None:
            normal = (normal[0][rows], normal[1][rows])
        return Evaluation(self.theta[rows], self.nuisance[rows], self.residual[rows],
                          self.cost[rows], None if self.jacobian is None
                          else self.jacobian[rows], normal)

    def put(self, rows: NDArray[np.bool_] | NDArray[np.int64], other: Evaluation,
            which: NDArray[np.bool_] | NDArray[np.int64] | slice = slice(None)) -> None:
        """Overwrite ``rows`` with ``other``'s evaluations ``which``, in place."""
        if isinstance(self.normal, DeferredNormal):  # written into: summed first, as it was
            self.normal = (self.normal[0], self.normal[1])
        if (self.jacobian is None) != (other.jacobian is None):
            # One holds its Jacobian, the other only J'J and J'r (summed by chunks of rows, or
            # by the compiled batch kernel): both as normal equations.
            self.normal, self.jacobian = normal_of(self), None
            other = Evaluation(other.theta, other.nuisance, other.residual, other.cost, None,
                               normal_of(other))
        self.theta[rows] = other.theta[which]
        self.nuisance[rows] = other.nuisance[which]
        self.residual[rows] = other.residual[which]
        self.cost[rows] = other.cost[which]
        if self.jacobian is not None and other.jacobian is not None:
            self.jacobian[rows] = other.jacobian[which]
        if self.normal is not None and other.normal is not None:
            got = (other.normal.runs(which) if isinstance(other.normal, DeferredNormal)
                   else (other.normal[0][which], other.normal[1][which]))
            self.normal[0][rows], self.normal[1][rows] = got


def normal_of(ev: Evaluation) -> tuple[Array, Array] | DeferredNormal | None:
    """Give ``J'J`` ``(B, p, p)`` and ``J'r`` ``(B, p)`` of ``ev`` (its own when it has them)."""
    if ev.normal is not None or ev.jacobian is None:
        return ev.normal
    jt = ev.jacobian.swapaxes(1, 2)
    return jt @ ev.jacobian, (jt @ ev.residual[:, :, None])[..., 0]
