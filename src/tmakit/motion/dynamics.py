"""Nearly-constant-velocity target dynamics for the recursive filters.

State ``[x, y, (z), vx, vy, (vz)]``, ENU m and m/s (Chen & Sun, §2.1).  Process noise: a white
acceleration held over each step, std ``q`` (m/s^2, Chen & Sun, §2.1), and/or a continuous one
of density ``q_density`` (m^2/s^3, Bar-Shalom, Li & Kirubarajan (2001), eq. 6.2.2-12); they add.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array


def state_names(dim: int) -> tuple[str, ...]:
    """Name the filter state components.

    Parameters
    ----------
    dim : int
        2 or 3.

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        For ``dim`` other than 2 or 3.
    """
    if dim == 2:
        return ("x", "y", "vx", "vy")
    if dim == 3:
        return ("x", "y", "z", "vx", "vy", "vz")
    raise ValueError(f"the filter state is 2-D or 3-D; got dim={dim}")


def transition_matrix(dt: float, dim: int) -> Array:
    """Give the transition matrix ``Phi(dt) = [[I, dt I], [0, I]]``.

    Parameters
    ----------
    dt : float
        s, any sign.
    dim : int
        2 or 3.

    Returns
    -------
    ndarray
        ``(2 dim, 2 dim)``.

    References
    ----------
    Chen & Sun, §2.1.
    """
    phi = np.eye(2 * dim)
    phi[:dim, dim:] = dt * np.eye(dim)
    return phi


def process_noise(dt: float, q: ArrayLike, dim: int, density: ArrayLike = 0.0) -> Array:
    """Give the process noise covariance ``Q_k`` of one step (m^2, m^2/s, m^2/s^2).

    Parameters
    ----------
    dt : float
        s; its sign does not matter.
    q : array_like
        Per-axis acceleration std, m/s^2 (a scalar for every axis).
    dim : int
        2 or 3.
    density : array_like, optional
        Per-axis spectral density, m^2/s^3.

    Returns
    -------
    ndarray
        ``(2 dim, 2 dim)``.

    Raises
    ------
    ValueError
        For a negative or non-finite ``q`` or ``density``.

    References
    ----------
    Chen & Sun, §2.1 (``q``); Bar-Shalom, Li & Kirubarajan (2001), eq. 6.2.2-12 (``density``).
    """
    q = np.broadcast_to(np.asarray(q, dtype=float), (dim,))
    if np.any(q < 0) or not np.all(np.isfinite(q)):
        raise ValueError(f"process noise q must be finite and >= 0 m/s^2; got {q.tolist()}")
    qd = np.broadcast_to(np.asarray(density, dtype=float), (dim,))
    if np.any(qd < 0) or not np.all(np.isfinite(qd)):
        raise ValueError("process noise density must be finite and >= 0 m^2/s^3; got "
                         f"{qd.tolist()}")
    dt = abs(float(dt))
    out = np.zeros((2 * dim, 2 * dim))
    q2 = q**2
    idx = np.arange(dim)
    out[idx, idx] = dt**4 / 4 * q2 + dt**3 / 3 * qd
    out[idx, idx + dim] = out[idx + dim, idx] = dt**3 / 2 * q2 + dt**2 / 2 * qd
    out[idx + dim, idx + dim] = dt**2 * q2 + dt * qd
    return out


@dataclass(frozen=True)
class NearlyConstantVelocity:
    """Linear-Gaussian dynamics ``x_{k+1} = Phi x_k + w_k``, ``w_k ~ N(0, Q_k)``.

    Parameters
    ----------
    dim : int
        2 or 3.
    q : float or tuple of float
        Per-axis acceleration noise, m/s^2.
    q_density : float or tuple of float
        Per-axis spectral density, m^2/s^3.

    Raises
    ------
    ValueError
        For a bad ``dim`` or ``q``.

    References
    ----------
    Chen & Sun, §2.1.
    """

    dim: int = 2
    q: float | tuple[float, ...] = 0.0
    q_density: float | tuple[float, ...] = 0.0

    def __post_init__(self) -> None:
        """Refuse a bad ``dim``, ``q`` or ``q_density``."""
        state_names(self.dim)
        process_noise(1.0, self.q, self.dim, self.q_density)  # validates both

    def axes(self) -> tuple[Array, Array]:
        """Give ``q`` (m/s^2) and ``q_density`` (m^2/s^3) per axis.

        Returns
        -------
        q, q_density : ndarray, shape (dim,)
        """
        return (np.broadcast_to(np.asarray(self.q, dtype=float), (self.dim,)).copy(),
                np.broadcast_to(np.asarray(self.q_density, dtype=float), (self.dim,)).copy())

    @property
    def n_state(self) -> int:
        """State dimension ``2 dim``."""
        return 2 * self.dim

    def transition(self, dt: float) -> Array:
        """Give ``Phi(dt)`` for a step ``dt`` (s, any sign).

        Parameters
        ----------
        dt : float

        Returns
        -------
        ndarray, shape (2 dim, 2 dim)
        """
        return transition_matrix(dt, self.dim)

    def noise(self, dt: float) -> Array:
        """Give ``Q_k`` for a step ``dt`` (s): m^2, m^2/s, m^2/s^2.

        Parameters
        ----------
        dt : float

        Returns
        -------
        ndarray, shape (2 dim, 2 dim)

        References
        ----------
        Chen & Sun (1993), §2.1; Bar-Shalom, Li & Kirubarajan (2001), eq. 6.2.2-12 (density form).
        """
        return process_noise(dt, self.q, self.dim, self.q_density)


@dataclass(frozen=True)
class CoordinatedTurn(NearlyConstantVelocity):
    """Nearly-coordinated-turn dynamics at a known turn rate, for the IMM filter's models.

    The horizontal velocity turns counter-clockwise positive in ENU (a right turn is negative);
    height moves at constant velocity.

    Parameters
    ----------
    dim, q, q_density
        As for :class:`NearlyConstantVelocity`.
    turn_rate : float
        rad/s, not 0.

    References
    ----------
    Bar-Shalom, Li & Kirubarajan (2001), §11.7.1, eq. 11.7.1-4 (the known-rate turn).
    """

    turn_rate: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a zero or non-finite turn rate, and what the parent refuses."""
        super().__post_init__()
        if not (np.isfinite(self.turn_rate) and self.turn_rate != 0):
            raise ValueError(f"a coordinated turn needs a finite turn rate != 0 rad/s; got "
                             f"{self.turn_rate}")

    def transition(self, dt: float) -> Array:
        """Give ``Phi(dt)`` of the turn (eq. 11.7.1-4; height at constant velocity in 3-D)."""
        d, w = self.dim, float(self.turn_rate)
        s, c = np.sin(w * dt), np.cos(w * dt)
        phi = transition_matrix(dt, d)
        phi[0, d:d + 2] = (s / w, -(1.0 - c) / w)
        phi[1, d:d + 2] = ((1.0 - c) / w, s / w)
        phi[d:d + 2, d:d + 2] = ((c, -s), (s, c))
        return phi
