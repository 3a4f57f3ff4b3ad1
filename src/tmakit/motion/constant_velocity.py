"""Constant-velocity and stationary target motion.

Constant velocity (Gu et al. (2007), eq. 1; the Doppler-tracking lecture notes' trajectory
model): ``p(t) = p_ref + v (t - t_ref)``, parameterised by the position at any
reference time ``t_ref`` (the initial time as in Gu et al. (2007), the final sample time as in
the Doppler-tracking lecture notes).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import zeros_broadcast
from .base import MotionModel


class ConstantVelocity(MotionModel):
    """Straight-line motion at constant velocity: ``(x, y, (z), vx, vy, (vz))`` at ``ref_time``.

    Parameters
    ----------
    dim : int
        2 (plane z = 0) or 3.
    ref_time : float
        s.

    Raises
    ------
    ValueError
        For ``dim`` other than 2 or 3.

    References
    ----------
    Gu et al. (2007), eq. 1; Doppler-tracking lecture notes (the trajectory model).
    """

    affine = velocity_fixed = True

    def __init__(self, dim: int = 2, ref_time: float = 0.0) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.dim = dim
        self.ref_time = float(ref_time)
        axes = ("x", "y", "z")[:dim]
        self.param_names = (*axes, *(f"v{a}" for a in axes))
        self.name = f"cv{dim}d"

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ENU states ``(..., n, 6)`` (m, m/s) at times ``t`` (s)."""
        theta = self.check_theta(theta)
        dt = np.asarray(t, dtype=float) - self.ref_time
        d = self.dim
        out = np.zeros((*theta.shape[:-1], dt.shape[0], 6))
        pos = theta[..., None, :d]
        vel = theta[..., None, d:]
        out[..., :d] = pos + vel * dt[:, None]
        out[..., 3:3 + d] = vel
        return out

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ``d state / d theta`` ``(..., n, 6, p)``: ``[[I, dt I], [0, I]]``."""
        theta = self.check_theta(theta)
        dt = np.asarray(t, dtype=float) - self.ref_time
        d = self.dim
        jac = np.zeros((dt.shape[0], 6, 2 * d))
        for i in range(d):
            jac[:, i, i] = 1.0
            jac[:, i, d + i] = dt
            jac[:, 3 + i, d + i] = 1.0
        return np.broadcast_to(jac, (*theta.shape[:-1], *jac.shape)).copy()

    def component_terms(self, t: ArrayLike
                        ) -> tuple[list[tuple[int, int, NDArray[np.float64] | None]],
                                   NDArray[np.float64]] | None:
        """Give the non-zero terms of the affine map: position ``i`` from ``i`` and ``dt v_i``."""
        dt = np.asarray(t, dtype=float)
        if self.ref_time != 0.0:  # (t - 0 is t: no pass over the rows)
            dt = dt - self.ref_time
        d = self.dim
        terms: list[tuple[int, int, NDArray[np.float64] | None]] = []
        for i in range(d):
            terms += [(i, i, None), (d + i, i, dt), (d + i, 3 + i, None)]
        # The offset is zero: a read-only broadcast, no memory per row.
        return terms, zeros_broadcast((6, dt.shape[0]))

    def chain(self, d_state: NDArray[np.float64], theta: ArrayLike, t: ArrayLike
              ) -> NDArray[np.float64]:
        """Apply the chain rule through ``[[I, dt I], [0, I]]`` without a tensor product."""
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
        """Give the parameters ``(..., p)`` of the straight line through ``state`` at ``t``."""
        state = np.asarray(state, dtype=float)
        d = self.dim
        vel = state[..., 3:3 + d]
        pos = state[..., :d] - vel * (float(t) - self.ref_time)
        return np.concatenate([pos, vel], axis=-1)

    def __repr__(self) -> str:
        """Name the class, dimension and reference time."""
        return f"ConstantVelocity(dim={self.dim}, ref_time={self.ref_time})"


class Stationary(MotionModel):
    """A fixed emitter: the parameters are its ENU position ``(x, y)`` or ``(x, y, z)`` (m).

    Parameters
    ----------
    dim : int
        2 (plane z = 0) or 3.

    Raises
    ------
    ValueError
        For ``dim`` other than 2 or 3.
    """

    affine = velocity_fixed = True

    def __init__(self, dim: int = 2) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.dim = dim
        self.param_names = ("x", "y", "z")[:dim]
        self.name = f"static{dim}d"

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ENU states ``(..., n, 6)`` (m; velocity 0) at times ``t`` (s)."""
        theta = self.check_theta(theta)
        n = np.asarray(t, dtype=float).shape[0]
        out = np.zeros((*theta.shape[:-1], n, 6))
        out[..., : self.dim] = theta[..., None, :]
        return out

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ``d state / d theta`` ``(..., n, 6, p)``: the identity on the position."""
        theta = self.check_theta(theta)
        n = np.asarray(t, dtype=float).shape[0]
        jac = np.zeros((n, 6, self.dim))
        for i in range(self.dim):
            jac[:, i, i] = 1.0
        return np.broadcast_to(jac, (*theta.shape[:-1], *jac.shape)).copy()

    def chain(self, d_state: NDArray[np.float64], theta: ArrayLike, t: ArrayLike
              ) -> NDArray[np.float64]:
        """Apply the chain rule: the position columns of ``d_state``."""
        return d_state[..., : self.dim].copy()

    def from_state(self, state: ArrayLike, t: float) -> NDArray[np.float64]:
        """Give the position ``(..., dim)`` (m) of ``state``."""
        return np.asarray(state, dtype=float)[..., : self.dim].copy()

    def __repr__(self) -> str:
        """Name the class and dimension."""
        return f"Stationary(dim={self.dim})"
