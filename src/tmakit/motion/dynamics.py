"""Nearly-constant-velocity target dynamics for the recursive filters.

State ``[x, y, (z), vx, vy, (vz)]``, ENU m and m/s (Chen & Sun, §2.1).  Process noise: a white
acceleration held over each step, std ``q`` (m/s^2, Chen & Sun, §2.1), and/or a continuous one
of density ``q_density`` (m^2/s^3, Bar-Shalom, Li & Kirubarajan (2001), eq. 6.2.2-12); they add.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array

#: The largest process noise (acceleration std, m/s^2) a track takes: 1000 g.  Beyond it
#: the filter ignores its own motion model and the number is a unit mistake or garbage.
MAX_ACCELERATION = 1e4
#: The fastest coordinated turn a model may take (rad/s): a full turn a second, beyond any
#: craft's; also the largest random walk of an estimated turn rate (rad/s per sqrt(s)).
MAX_TURN_RATE = 2.0 * math.pi


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
    """Give the transition matrix ``Phi(dt) = [[I, dt I], [0, I]]`` (Chen & Sun, §2.1).

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
        Per-axis acceleration std, m/s^2 (a scalar for every axis; Chen & Sun, §2.1).
    dim : int
        2 or 3.
    density : array_like, optional
        Per-axis spectral density, m^2/s^3 (Bar-Shalom, Li & Kirubarajan (2001), eq. 6.2.2-12).

    Returns
    -------
    ndarray
        ``(2 dim, 2 dim)``.

    Raises
    ------
    ValueError
        For a negative or non-finite ``q`` or ``density``.
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
        """Give ``Phi(dt)`` for a step ``dt``.

        Parameters
        ----------
        dt : float
            s, any sign.

        Returns
        -------
        ndarray, shape (2 dim, 2 dim)
        """
        return transition_matrix(dt, self.dim)

    def noise(self, dt: float) -> Array:
        """Give ``Q_k`` for a step ``dt``: m^2, m^2/s, m^2/s^2.

        Parameters
        ----------
        dt : float
            s.

        Returns
        -------
        ndarray, shape (2 dim, 2 dim)
        """
        return process_noise(dt, self.q, self.dim, self.q_density)

    def propagate(self, mean: Array, dt: float) -> tuple[Array, Array]:
        """Give the mean moved by ``dt`` and the transition's Jacobian there.

        Parameters
        ----------
        mean : ndarray, shape (n_state,)
        dt : float
            s.

        Returns
        -------
        mean, jacobian : ndarray
            ``Phi(dt) mean`` and ``Phi(dt)``: the model is linear.
        """
        phi = self.transition(dt)
        return phi @ mean, phi


@dataclass(frozen=True)
class CoordinatedTurn(NearlyConstantVelocity):
    """Nearly-coordinated-turn dynamics at a known turn rate, for the IMM filter's models.

    The turn rate (rad/s, not 0) is counter-clockwise positive in ENU; height moves at
    constant velocity.

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


def _turn_terms(w: float, dt: float) -> tuple[float, float, float, float]:
    """Give ``sin(w dt)/w``, ``(1 - cos(w dt))/w`` and their ``w``-derivatives (Taylor near 0)."""
    a = w * dt
    if abs(a) < 1e-3:
        return (dt * (1.0 - a * a / 6.0), dt * a * (0.5 - a * a / 24.0),
                -dt**2 * a * (1.0 / 3.0 - a * a / 30.0), dt**2 * (0.5 - a * a / 8.0))
    s, c = math.sin(a), math.cos(a)
    return s / w, (1.0 - c) / w, (dt * c - s / w) / w, (dt * s - (1.0 - c) / w) / w


@dataclass(frozen=True)
class UnknownRateTurn(NearlyConstantVelocity):
    """Nearly-coordinated turn whose rate is part of the state, for the IMM filter's models.

    State ``[x, y, (z), vx, vy, (vz), omega]``: the horizontal velocity turns at the rate
    ``omega`` (rad/s, counter-clockwise positive in ENU), which walks at random; height moves
    at constant velocity.

    Parameters
    ----------
    dim, q, q_density
        As for :class:`NearlyConstantVelocity` (the position and velocity's noise).
    rate_noise : float
        Std of the turn rate's random walk over one second, rad/s per sqrt(s): the rate's
        variance grows by ``rate_noise**2 * dt`` over a step of ``dt`` s.

    Raises
    ------
    ValueError
        A ``rate_noise`` that is negative or not finite, or what the parent refuses.

    References
    ----------
    Li & Jilkov (2003), "Survey of maneuvering target tracking. Part I: Dynamic models",
    IEEE Trans. AES 39(4), §V.B (the coordinated turn with unknown turn rate); Bar-Shalom, Li &
    Kirubarajan (2001), §11.7.2.
    """

    rate_noise: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a bad ``rate_noise``, and what the parent refuses."""
        super().__post_init__()
        if not 0 <= self.rate_noise <= MAX_TURN_RATE:
            raise ValueError(f"the turn rate's noise must be within [0, {MAX_TURN_RATE:.4g}] "
                             f"(rad/s per sqrt(s)); got {self.rate_noise}")

    @property
    def n_state(self) -> int:
        """State dimension ``2 dim + 1`` (the turn rate last)."""
        return 2 * self.dim + 1

    def transition(self, dt: float) -> Array:
        """Refuse: the motion depends on the state's turn rate (use :meth:`propagate`)."""
        raise TypeError("an unknown-rate turn has no transition matrix of its own; its "
                        "motion depends on the turn rate in the state (use propagate)")

    def noise(self, dt: float) -> Array:
        """Give ``Q_k`` of a step ``dt`` (s): the parent's, then ``rate_noise**2 |dt|``."""
        n = 2 * self.dim
        out = np.zeros((n + 1, n + 1))
        out[:n, :n] = process_noise(dt, self.q, self.dim, self.q_density)
        out[n, n] = self.rate_noise**2 * abs(float(dt))
        return out

    def propagate(self, mean: Array, dt: float) -> tuple[Array, Array]:
        """Give the mean moved exactly by ``dt`` (s) at its own turn rate, and the Jacobian."""
        d, w = self.dim, float(mean[-1])
        a, b, da, db = _turn_terms(w, dt)
        s, c = math.sin(w * dt), math.cos(w * dt)
        vx, vy = float(mean[d]), float(mean[d + 1])
        jac = np.eye(2 * d + 1)
        jac[:d, d:2 * d] = dt * np.eye(d)
        jac[0, d:d + 2] = (a, -b)
        jac[1, d:d + 2] = (b, a)
        jac[d:d + 2, d:d + 2] = ((c, -s), (s, c))
        jac[:2, -1] = (da * vx - db * vy, db * vx + da * vy)
        jac[d:d + 2, -1] = (-dt * (s * vx + c * vy), dt * (c * vx - s * vy))
        moved = jac[:-1, :-1] @ mean[:-1]
        return np.append(moved, w), jac
