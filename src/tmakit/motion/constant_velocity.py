"""Constant-velocity and stationary target motion.

Constant velocity (000_bc54bd8c50e47249.txt eq. 1, 001_ba171c940b7f4701.txt's trajectory model):
``p(t) = p_ref + v (t - t_ref)``, parameterised by the position at any reference time
``t_ref`` (the initial time as in 000_bc54bd8c50e47249.txt, the final sample time as in
001_ba171c940b7f4701.txt).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .base import MotionModel


class ConstantVelocity(MotionModel):
    """Straight-line motion at constant velocity in 2-D (z = 0) or 3-D.

    Parameters are ``(x, y, vx, vy)`` or ``(x, y, z, vx, vy, vz)``: the ENU position (m) at
    ``ref_time`` (s) and the velocity (m/s).
    """

    affine = True

    def __init__(self, dim: int = 2, ref_time: float = 0.0) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.dim = dim
        self.ref_time = float(ref_time)
        axes = ("x", "y", "z")[:dim]
        self.param_names = (*axes, *(f"v{a}" for a in axes))
        self.name = f"cv{dim}d"

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        theta = self._check_theta(theta)
        dt = np.asarray(t, dtype=float) - self.ref_time
        d = self.dim
        out = np.zeros((*theta.shape[:-1], dt.shape[0], 6))
        pos = theta[..., None, :d]
        vel = theta[..., None, d:]
        out[..., :d] = pos + vel * dt[:, None]
        out[..., 3:3 + d] = vel
        return out

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        theta = self._check_theta(theta)
        dt = np.asarray(t, dtype=float) - self.ref_time
        d = self.dim
        jac = np.zeros((dt.shape[0], 6, 2 * d))
        for i in range(d):
            jac[:, i, i] = 1.0
            jac[:, i, d + i] = dt
            jac[:, 3 + i, d + i] = 1.0
        return np.broadcast_to(jac, (*theta.shape[:-1], *jac.shape)).copy()

    def chain(self, d_state: NDArray[np.float64], theta: ArrayLike, t: ArrayLike
              ) -> NDArray[np.float64]:
        # d state / d theta is [[I, dt I], [0, I]]: no tensor contraction needed.  Worked
        # parameter by parameter along the rows; the result is a (..., n, p) view whose rows
        # are contiguous for each parameter.
        d = self.dim
        dt = np.asarray(t, dtype=float) - self.ref_time
        rows = d_state.swapaxes(-1, -2)  # (..., 6, n)
        out = np.empty((*rows.shape[:-2], 2 * d, rows.shape[-1]))
        out[..., :d, :] = rows[..., :d, :]
        np.multiply(rows[..., :d, :], dt, out=out[..., d:, :])
        out[..., d:, :] += rows[..., 3:3 + d, :]
        return out.swapaxes(-1, -2)

    def from_state(self, state: ArrayLike, t: float) -> NDArray[np.float64]:
        state = np.asarray(state, dtype=float)
        d = self.dim
        vel = state[..., 3:3 + d]
        pos = state[..., :d] - vel * (float(t) - self.ref_time)
        return np.concatenate([pos, vel], axis=-1)

    def at_reference_time(self, theta: ArrayLike, new_ref_time: float) -> NDArray[np.float64]:
        """The same trajectory's parameters referenced at ``new_ref_time``."""
        theta = self._check_theta(theta).copy()
        d = self.dim
        theta[..., :d] += theta[..., d:] * (new_ref_time - self.ref_time)
        return theta

    def __repr__(self) -> str:
        return f"ConstantVelocity(dim={self.dim}, ref_time={self.ref_time})"


class Stationary(MotionModel):
    """A fixed emitter: parameters are its ENU position ``(x, y)`` or ``(x, y, z)`` in metres."""

    affine = True

    def __init__(self, dim: int = 2) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.dim = dim
        self.param_names = ("x", "y", "z")[:dim]
        self.name = f"static{dim}d"

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        theta = self._check_theta(theta)
        n = np.asarray(t, dtype=float).shape[0]
        out = np.zeros((*theta.shape[:-1], n, 6))
        out[..., : self.dim] = theta[..., None, :]
        return out

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        theta = self._check_theta(theta)
        n = np.asarray(t, dtype=float).shape[0]
        jac = np.zeros((n, 6, self.dim))
        for i in range(self.dim):
            jac[:, i, i] = 1.0
        return np.broadcast_to(jac, (*theta.shape[:-1], *jac.shape)).copy()

    def chain(self, d_state: NDArray[np.float64], theta: ArrayLike, t: ArrayLike
              ) -> NDArray[np.float64]:
        return d_state[..., : self.dim].copy()

    def from_state(self, state: ArrayLike, t: float) -> NDArray[np.float64]:
        return np.asarray(state, dtype=float)[..., : self.dim].copy()

    def __repr__(self) -> str:
        return f"Stationary(dim={self.dim})"
