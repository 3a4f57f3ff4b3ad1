"""``J'J`` and ``J'r`` from the motion model itself, where it can sum them without ``J``.

For a motion model that is not affine (piecewise curvilinear motion), the general
linearisation gives the predictions' derivatives by the ENU state ``(B, n, 6)`` and the motion
model's chain rule makes the Jacobian ``(B, n, p)``; the solver then whitens it and forms
``J'J``.  A model with ``normal_equations`` (:meth:`tmakit.motion.curvilinear_batch.
ForwardPiecewise.normal_equations`) sums ``J'J`` and ``J'r`` by segments instead, the Jacobian
never written.  Used by :class:`tmakit.batch.varpro.VarProProblem` where nothing else enters
the Jacobian: no nuisance, no reference samples, independent noise.
"""

from __future__ import annotations

from typing import Any

from ..arrays import Array
from ..observation import Linearisation

__all__ = ["motion_normal"]


def motion_normal(obs: Any, lin: Linearisation, residual: Array, weights: Array | None
                  ) -> tuple[Array, Array] | None:
    """Give ``J'J`` and ``J'r`` of the whitened Jacobian from the motion model, or None.

    Parameters
    ----------
    obs : ObservationModel
        The observation model linearised.
    lin : Linearisation
        Its linearisation at the batch's parameters, with derivatives.
    residual : ndarray
        ``(B, n)`` whitened residuals.
    weights : ndarray or None
        ``(n,)`` inverse standard deviations of independent rows (None: correlated noise).

    Returns
    -------
    (ndarray, ndarray) or None
        ``(B, p, p)`` and ``(B, p)``; None where the motion model cannot, or something besides
        the relative states enters the Jacobian (the caller forms it).
    """
    normal = getattr(obs.motion, "normal_equations", None)
    if (normal is None or weights is None or lin.fused is not None or lin.d_h0 is None
            or lin.d_a or lin.d_h0_ref is not None or lin.theta.ndim != 2):
        return None
    return normal(lin.d_h0, residual, weights, lin.theta, obs._time)
