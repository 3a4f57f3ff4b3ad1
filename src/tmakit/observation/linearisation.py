"""The linearised predictions of an observation model at a batch of motion parameters.

Made by :meth:`tmakit.observation.ObservationModel.linearisation`; the solvers form the
Jacobian at any nuisance value from it (:meth:`Linearisation.jacobian`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.arrays import Array

__all__ = ["Linearisation"]


class Linearisation:
    """The predictions ``h0 + (A_const + A_var) @ nu`` of an :class:`ObservationModel`, linearised.

    Grouped order, with ``d_h0`` ``(..., n, 6)`` (``d_h0_ref`` at reference samples) and per
    geometry-dependent kind ``(kind, dA, dA_ref)``.

    Parameters
    ----------
    obs : ObservationModel
    theta : ndarray
        ``(..., p)``, SI.
    h0, a_var : ndarray
        ``(..., n)`` and ``(..., n, k)``, SI.
    """

    def __init__(self, obs: Any, theta: Array, h0: Array, a_var: Array) -> None:
        self.obs = obs
        self.theta = theta
        self.h0 = h0
        self.a_var = a_var
        self.d_h0: Array | None = None
        self.d_h0_ref: Array | None = None
        self.d_a: list[tuple[str, Array | None, Array | None]] = []
        #: The Jacobian ``(..., n, p)`` made by the planar path (:mod:`.planar`), or None,
        #: handed over on the first call of :meth:`jacobian` (the caller may scale it), then
        #: made again by ``planar_again``.
        self.planar_jacobian: Array | None = None
        self.planar_again: Callable[[], Array] | None = None
        self._planar_given = False
        #: Whether the planar Jacobian is already whitened (made with the noise's weights).
        self.whitened = False

    def jacobian(self, nuisance: Array, with_h0: bool = True) -> Array:
        """Return ``d predictions / d theta`` ``(..., n, p)`` at nuisance values.

        Parameters
        ----------
        nuisance : ndarray
            ``(..., k)``.
        with_h0 : bool
            False leaves out the derivative of ``h0``.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            When made without derivatives.
        """
        if self.planar_jacobian is not None:  # no nuisance: the Jacobian itself, a new array once
            if not with_h0:
                return np.zeros_like(self.planar_jacobian)
            if self._planar_given and self.planar_again is not None:
                return self.planar_again()
            self._planar_given = True
            return self.planar_jacobian
        if self.d_h0 is None:
            raise ValueError("this linearisation was made without derivatives")
        obs = self.obs
        if with_h0 and not self.d_a and self.d_h0_ref is None:
            # Nothing is added to d h0: the chain rule reads it (writes a new array).
            return obs.motion.chain(self.d_h0, self.theta, obs._time)
        nu = np.asarray(nuisance, dtype=float)
        d = self.d_h0.copy(order="K") if with_h0 else np.zeros_like(self.d_h0)
        d_ref = None
        if self.d_h0_ref is not None:
            d_ref = (self.d_h0_ref.copy(order="K") if with_h0
                     else np.zeros_like(self.d_h0_ref))
        for kind, da, da_ref in self.d_a:
            sl, ns = obs.slices[kind], obs.nuisance_slices[kind]
            for j in range(ns.stop - ns.start):
                w = nu[..., ns.start + j, None, None]
                if da is not None:
                    d[..., sl, :] += da[..., j, :] * w
                if da_ref is not None and d_ref is not None:
                    d_ref[..., obs.row_model.reference_rows(kind), :] += da_ref[..., j, :] * w
        motion = obs.motion
        jac = motion.chain(d, self.theta, obs._time)
        if d_ref is not None:
            sl = obs._ref
            jac[..., sl, :] += motion.chain(d_ref, self.theta, obs.grouped.time_ref[sl])
        return jac
