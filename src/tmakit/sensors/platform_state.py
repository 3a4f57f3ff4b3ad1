"""Platform state, candidate actions and the exact constant-turn, constant-acceleration step.

The building blocks of :mod:`tmakit.sensors.platform` (read its docstring for the model, the
limits and an example): :func:`propagate_constant_turn` (the closed form),
:class:`PlatformState` (where platforms are and how they move) and :class:`Actions` (what a
decision may ask for).  Headings are bearings: radians clockwise from North,
``atan2(v_east, v_north)``; a positive turn rate turns clockwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.frames import wrap_angle

Index = int | slice | Sequence[int] | NDArray[np.integer] | NDArray[np.bool_]

_SERIES_BELOW = 0.25  # |w s| below this: E1, E2 from their power series (closed form above
#                       loses at most eps / 0.25^2 ~ 4e-15 relative to cancellation)
_SERIES_TERMS = 17    # 0.25**17 / 17! ~ 2e-25: far below rounding
_E1_COEFF = [1.0 / math.factorial(n + 1) for n in range(_SERIES_TERMS)]
_E2_COEFF = [1.0 / (math.factorial(n) * (n + 2)) for n in range(_SERIES_TERMS)]


def _arr(a: ArrayLike) -> Array:
    return np.asarray(a, dtype=float)


def _turn_factors(z: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], ...]:
    """``E1(z) = (e^z - 1) / z`` and ``E2(z) = (e^z (z - 1) + 1) / z^2``, stable at 0."""
    shape = np.shape(z)
    z = np.atleast_1d(z)
    e1 = np.empty_like(z)
    e2 = np.empty_like(z)
    small = np.abs(z) < _SERIES_BELOW
    every = bool(small.all())
    if every or small.any():                    # Horner on the power series
        zs = z if every else z[small]
        s1 = np.full_like(zs, _E1_COEFF[-1])
        s2 = np.full_like(zs, _E2_COEFF[-1])
        for c1, c2 in zip(_E1_COEFF[-2::-1], _E2_COEFF[-2::-1], strict=True):
            s1 *= zs    # in place: the same values as s1 * zs + c1, no temporaries
            s1 += c1
            s2 *= zs
            s2 += c2
        if every:
            return s1.reshape(shape), s2.reshape(shape)
        e1[small], e2[small] = s1, s2
    if not every:
        large = ~small
        zl = z[large]
        ez = np.exp(zl)
        e1[large] = (ez - 1.0) / zl
        e2[large] = (ez * (zl - 1.0) + 1.0) / zl**2
    return e1.reshape(shape), e2.reshape(shape)


def propagate_constant_turn(position: ArrayLike, heading: ArrayLike, speed: ArrayLike,
                            climb_rate: ArrayLike, turn_rate: ArrayLike,
                            acceleration: ArrayLike, dt: ArrayLike) -> Array:
    """Sensor states after ``dt`` seconds of constant turn rate and constant acceleration.

    The closed form of the module docstring (exact, no time stepping); all inputs broadcast.

    Parameters
    ----------
    position : array_like, shape (..., 2) or (..., 3)
        ENU start position (m); two coordinates mean altitude 0.
    heading : array_like
        Start heading (rad, clockwise from North).
    speed : array_like
        Start horizontal speed (m/s); ``speed + acceleration * dt`` should stay >= 0.
    climb_rate : array_like
        Vertical speed (m/s, up positive), constant over ``dt``.
    turn_rate : array_like
        Constant turn rate (rad/s, positive turns clockwise, to starboard).
    acceleration : array_like
        Constant tangential acceleration (m/s^2).
    dt : array_like
        Elapsed time (s), any sign.

    Returns
    -------
    ndarray, shape (..., 6)
        ``[x, y, z, vx, vy, vz]`` (m, m/s) at ``dt``.

    Raises
    ------
    ValueError
        If ``position`` does not end in 2 or 3 coordinates.
    """
    pos = _arr(position)
    if pos.ndim == 0 or pos.shape[-1] not in (2, 3):
        raise ValueError(f"position must end in 2 or 3 ENU coordinates (m), got {pos.shape}")
    if pos.shape[-1] == 2:
        pos = np.concatenate([pos, np.zeros((*pos.shape[:-1], 1))], axis=-1)
    # no broadcast_arrays: the arithmetic broadcasts (the same values, fewer array views)
    psi0, v0, c, w, a, s = (_arr(q) for q in (
        heading, speed, climb_rate, turn_rate, acceleration, dt))
    e1, e2 = _turn_factors(np.asarray(1j * w * s, dtype=np.complex128))
    rot0 = np.exp(1j * psi0)
    disp = rot0 * s * (v0 * e1 + a * s * e2)
    vel = (v0 + a * s) * np.exp(1j * (psi0 + w * s))
    shape = np.broadcast_shapes(pos.shape[:-1], *(q.shape for q in (psi0, v0, c, w, a, s)))
    out = np.empty((*shape, 6))
    out[..., 0] = pos[..., 0] + disp.imag
    out[..., 1] = pos[..., 1] + disp.real
    out[..., 2] = pos[..., 2] + c * s
    out[..., 3] = vel.imag
    out[..., 4] = vel.real
    out[..., 5] = c
    return out


@dataclass(frozen=True, eq=False)
class PlatformState:
    """Where a steerable platform is and how it moves, for one or many platforms at once.

    Parameters
    ----------
    position : array_like, shape (..., 2) or (..., 3)
        ENU position (m); two coordinates mean altitude 0.
    heading : array_like
        Heading (rad, clockwise from North); stored wrapped to (-pi, pi].
    speed : array_like
        Horizontal speed (m/s), >= 0.
    climb_rate : array_like, optional
        Vertical speed (m/s, up positive); 0 for a 2-D platform.
    time : float, optional
        Time of the state (s); one time for every platform of the batch.

    Raises
    ------
    ValueError
        If a value is not finite, a speed is negative or the shapes do not broadcast.

    Notes
    -----
    All fields broadcast to one batch shape :attr:`shape`; ``position`` is ``(*shape, 3)``.
    """

    position: Array
    heading: Array
    speed: Array
    climb_rate: Array
    time: float

    def __init__(self, position: ArrayLike, heading: ArrayLike, speed: ArrayLike,
                 climb_rate: ArrayLike = 0.0, time: float = 0.0) -> None:
        p = _arr(position)
        if p.ndim == 0 or p.shape[-1] not in (2, 3):
            raise ValueError(f"platform position must end in 2 or 3 ENU coordinates (m), got "
                             f"shape {p.shape}")
        if p.shape[-1] == 2:
            p = np.concatenate([p, np.zeros((*p.shape[:-1], 1))], axis=-1)
        try:
            shape = np.broadcast_shapes(p.shape[:-1], *(np.shape(q) for q in (
                heading, speed, climb_rate)))
        except ValueError:
            raise ValueError("platform position, heading, speed and climb rate do not "
                             "broadcast to one batch shape") from None
        fields = [np.broadcast_to(_arr(q), shape).copy() for q in (heading, speed,
                                                                   climb_rate)]
        p = np.broadcast_to(p, (*shape, 3)).copy()
        if not all(np.all(np.isfinite(q)) for q in (p, *fields)) or not math.isfinite(time):
            raise ValueError("platform position, heading, speed, climb rate and time must "
                             "be finite")
        if np.any(fields[1] < 0):
            raise ValueError(f"platform speed must be >= 0 m/s, got {fields[1].min():g}")
        object.__setattr__(self, "position", p)
        object.__setattr__(self, "heading", wrap_angle(fields[0]))
        object.__setattr__(self, "speed", fields[1])
        object.__setattr__(self, "climb_rate", fields[2])
        object.__setattr__(self, "time", float(time))

    @classmethod
    def trusted(cls, position: Array, heading: Array, speed: Array, climb_rate: Array,
                time: float) -> PlatformState:
        """Make a state from fields already checked, without checking them again (fast path).

        For code that derives a state from checked states (a kinematic step): no broadcasting,
        no finiteness or sign checks; the heading is wrapped to ``(-pi, pi]`` as by the
        constructor and every field is copied as a float array.

        Parameters
        ----------
        position : ndarray, shape (*shape, 3)
            ENU position (m).
        heading, speed, climb_rate : ndarray, shape shape
            Heading (rad clockwise from North), speed (m/s, >= 0), climb rate (m/s), all of
            the batch shape ``shape`` of ``position[..., 0]``.
        time : float
            Time (s).

        Returns
        -------
        PlatformState
        """
        state = object.__new__(cls)
        object.__setattr__(state, "position", np.array(position, dtype=float))
        object.__setattr__(state, "heading", wrap_angle(np.array(heading, dtype=float)))
        object.__setattr__(state, "speed", np.array(speed, dtype=float))
        object.__setattr__(state, "climb_rate", np.array(climb_rate, dtype=float))
        object.__setattr__(state, "time", float(time))
        return state

    @classmethod
    def view(cls, position: Array, heading: Array, speed: Array, climb_rate: Array,
             time: float) -> PlatformState:
        """Make a state holding the given arrays as they are: no copy, no check, no wrap.

        For compiled kinematics that write every field into one buffer (already wrapped and
        derived from checked states).

        Parameters
        ----------
        position : ndarray, shape (*shape, 3)
            ENU position (m).
        heading, speed, climb_rate : ndarray, shape shape
            Heading (rad clockwise from North, in ``(-pi, pi]``), speed (m/s, >= 0), climb
            rate (m/s).
        time : float
            Time (s).

        Returns
        -------
        PlatformState
        """
        state = object.__new__(cls)
        setattr_ = object.__setattr__
        setattr_(state, "position", position)
        setattr_(state, "heading", heading)
        setattr_(state, "speed", speed)
        setattr_(state, "climb_rate", climb_rate)
        object.__setattr__(state, "time", float(time))
        return state

    @classmethod
    def from_velocity(cls, position: ArrayLike, velocity: ArrayLike,
                      time: float = 0.0) -> PlatformState:
        """Make the state of a platform at ``position`` moving with ENU ``velocity``.

        Parameters
        ----------
        position : array_like, shape (..., 2) or (..., 3)
            ENU position (m).
        velocity : array_like, shape (..., 2) or (..., 3)
            ENU velocity (m/s); heading = ``atan2(v_east, v_north)`` (0 when not moving).
        time : float, optional
            Time of the state (s).

        Returns
        -------
        PlatformState
        """
        v = _arr(velocity)
        climb = v[..., 2] if v.shape[-1] == 3 else 0.0
        return cls(position, np.arctan2(v[..., 0], v[..., 1]), np.hypot(v[..., 0], v[..., 1]),
                   climb, time)

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape (one entry per platform or candidate)."""
        return self.speed.shape

    @property
    def velocity(self) -> Array:
        """ENU velocity ``(*shape, 3)`` (m/s)."""
        return np.stack([self.speed * np.sin(self.heading), self.speed * np.cos(self.heading),
                         self.climb_rate], axis=-1)

    @property
    def sensor_state(self) -> Array:
        """``[x, y, z, vx, vy, vz]`` ``(*shape, 6)`` (m, m/s), as ``SensorTrack.states``."""
        return np.concatenate([self.position, self.velocity], axis=-1)

    def __getitem__(self, index: Index) -> PlatformState:
        """Select the platforms ``index`` of the batch (numpy indexing)."""
        return PlatformState(self.position[index], self.heading[index], self.speed[index],
                             self.climb_rate[index], self.time)


@dataclass(frozen=True, eq=False)
class Actions:
    """``C`` candidate actions for one decision interval (numpy arrays of one batch shape).

    The commanded speed at the end of the step is ``speed * speed_factor + speed_change``.

    Parameters
    ----------
    heading_change : array_like
        Heading change over the step (rad, positive clockwise).
    speed_factor : array_like, optional
        Factor on the current speed (Hurtado & Nehorai (2008) use 0.9, 1, 1.1).
    speed_change : array_like, optional
        Speed added (m/s).
    climb_rate : array_like or None, optional
        Commanded climb rate over the step (m/s); None keeps each platform's climb rate.

    Raises
    ------
    ValueError
        If a value is not finite or the shapes do not broadcast.
    """

    heading_change: Array
    speed_factor: Array
    speed_change: Array
    climb_rate: Array | None

    def __init__(self, heading_change: ArrayLike, speed_factor: ArrayLike = 1.0,
                 speed_change: ArrayLike = 0.0, climb_rate: ArrayLike | None = None) -> None:
        given = [heading_change, speed_factor, speed_change]
        if climb_rate is not None:
            given.append(climb_rate)
        try:
            arrays = [a.copy() for a in np.broadcast_arrays(*(_arr(q) for q in given))]
        except ValueError:
            raise ValueError("action fields do not broadcast to one shape") from None
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise ValueError("actions must be finite")
        object.__setattr__(self, "heading_change", arrays[0])
        object.__setattr__(self, "speed_factor", arrays[1])
        object.__setattr__(self, "speed_change", arrays[2])
        object.__setattr__(self, "climb_rate", arrays[3] if climb_rate is not None else None)

    @classmethod
    def grid(cls, heading_changes: ArrayLike, speed_factors: ArrayLike = (1.0,),
             climb_rates: ArrayLike | None = None) -> Actions:
        """Every combination of speed factor, heading change (and climb rate), flattened.

        Parameters
        ----------
        heading_changes : array_like, shape (H,)
            Heading changes (rad).
        speed_factors : array_like, shape (F,), optional
            Speed factors.
        climb_rates : array_like, shape (Z,), optional
            Climb rates (m/s); None keeps the platform's.

        Returns
        -------
        Actions, shape (F * H * Z,)
            Speed factor slowest, climb rate fastest: index ``(f * H + h) * Z + z``.
        """
        axes = [np.ravel(_arr(speed_factors)), np.ravel(_arr(heading_changes))]
        if climb_rates is not None:
            axes.append(np.ravel(_arr(climb_rates)))
        mesh = [m.ravel() for m in np.meshgrid(*axes, indexing="ij")]
        return cls(mesh[1], speed_factor=mesh[0],
                   climb_rate=mesh[2] if climb_rates is not None else None)

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape of the candidates."""
        return self.heading_change.shape

    def __len__(self) -> int:
        """Return the number of candidates along the first axis."""
        if not self.shape:
            raise TypeError("len() of a single action (shape ())")
        return self.shape[0]

    def __getitem__(self, index: Index) -> Actions:
        """Select the candidates ``index`` (numpy indexing)."""
        return Actions(self.heading_change[index], self.speed_factor[index],
                       self.speed_change[index],
                       None if self.climb_rate is None else self.climb_rate[index])
