"""Steerable sensor platforms: a platform state, actions, and exact turn-and-accelerate steps.

A :class:`PlatformState` holds ENU position (m), heading (rad, clockwise from North as every bearing
in tmakit: ``atan2(v_east, v_north)``), horizontal speed (m/s), climb rate (m/s, up) and time (s); a
2-D platform is a 3-D one at constant altitude (``z = 0``, climb rate 0).

References
----------
Hurtado, M. and Nehorai, A. (2008), "Adaptive path design of a moving radar", section 5.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.frames import wrap_angle
from .tracks import SensorTrack, propagate_constant_turn

Index = int | slice | Sequence[int] | NDArray[np.integer] | NDArray[np.bool_]

_LIMIT_TOL = 1e-9     # relative: a clip smaller than this is rounding, not a limit
_TIME_TOL = 1e-9      # relative tolerance on times at the ends of a step or track


def _arr(a: ArrayLike) -> Array:
    return np.asarray(a, dtype=float)


def _set(state: PlatformState, position: Array, heading: Array, speed: Array,
         climb_rate: Array, time: float) -> None:
    """Set the fields of a frozen state as given (time as a float)."""
    setattr_ = object.__setattr__
    setattr_(state, "position", position)
    setattr_(state, "heading", heading)
    setattr_(state, "speed", speed)
    setattr_(state, "climb_rate", climb_rate)
    setattr_(state, "time", float(time))


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
        _set(self, p, wrap_angle(fields[0]), fields[1], fields[2], time)

    @classmethod
    def trusted(cls, position: Array, heading: Array, speed: Array, climb_rate: Array,
                time: float, as_given: bool = False) -> PlatformState:
        """Make a state from fields derived from checked ones: copied, heading wrapped, no check.

        Parameters
        ----------
        position, heading, speed, climb_rate, time
            As for the constructor, of one batch shape (``position`` ``(*shape, 3)``).
        as_given : bool, optional
            Hold the arrays themselves: no copy and no wrap (the heading already in
            ``(-pi, pi]``).

        Returns
        -------
        PlatformState
        """
        state = object.__new__(cls)
        if not as_given:
            position, heading = np.array(position, dtype=float), np.array(heading, dtype=float)
            speed, climb_rate = np.array(speed, dtype=float), np.array(climb_rate, dtype=float)
            heading = wrap_angle(heading)
        _set(state, position, heading, speed, climb_rate, time)
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


def _differs(applied: Array, commanded: Array) -> NDArray[np.bool_]:
    """Where a limit changed a commanded value by more than rounding."""
    return np.abs(applied - commanded) > _LIMIT_TOL * np.maximum(1.0, np.abs(commanded))


@dataclass(frozen=True, eq=False)
class Step:
    """Candidate steps of one decision interval: what was flown and which limits acted.

    Made by :meth:`PlatformKinematics.step`; every field has the batch shape :attr:`shape`.

    Attributes
    ----------
    start, end : PlatformState
        States at the start and at the end of the step.
    turn_rate, acceleration, climb_rate : ndarray
        Applied constant turn rate (rad/s, positive clockwise), tangential acceleration
        (m/s^2) and climb rate (m/s).
    interval : float
        Length of the step (s).
    speed_limited, turn_limited, acceleration_limited, climb_limited : ndarray of bool
        Where the speed range, the turn-rate limit, the acceleration limit, or the
        climb-rate limit / altitude band clipped the commanded action.
    """

    start: PlatformState
    end: PlatformState
    turn_rate: Array
    acceleration: Array
    climb_rate: Array
    interval: float
    speed_limited: NDArray[np.bool_]
    turn_limited: NDArray[np.bool_]
    acceleration_limited: NDArray[np.bool_]
    climb_limited: NDArray[np.bool_]

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape of the candidates."""
        return self.turn_rate.shape

    @property
    def clipped(self) -> NDArray[np.bool_]:
        """Where any limit clipped the commanded action."""
        return (self.speed_limited | self.turn_limited | self.acceleration_limited
                | self.climb_limited)

    @property
    def end_time(self) -> float:
        """Time at the end of the step (s)."""
        return self.start.time + self.interval

    def sensor_states(self, times: ArrayLike) -> Array:
        """Sensor states of every candidate at times inside the step.

        Parameters
        ----------
        times : array_like, shape (n,)
            Times (s, the clock of :attr:`PlatformState.time`) in ``[start, end]``.

        Returns
        -------
        ndarray, shape (*shape, n, 6)
            ``[x, y, z, vx, vy, vz]`` (m, m/s).

        Raises
        ------
        ValueError
            If a time lies outside the step.
        """
        t0 = self.start.time
        s = np.atleast_1d(_arr(times)) - t0
        tol = _TIME_TOL * max(1.0, abs(t0), self.interval)
        if s.ndim != 1 or np.any((s < -tol) | (s > self.interval + tol)):
            raise ValueError(f"times must be a 1-D array inside the step [{t0:g}, "
                             f"{self.end_time:g}] s")
        s = np.clip(s, 0.0, self.interval)
        st = self.start
        return propagate_constant_turn(
            st.position[..., None, :], st.heading[..., None], st.speed[..., None],
            self.climb_rate[..., None], self.turn_rate[..., None],
            self.acceleration[..., None], s)

    def __getitem__(self, index: Index) -> Step:
        """Select the candidates ``index`` (numpy indexing); ``step[k]`` is one flown step."""
        return Step(self.start[index], self.end[index], self.turn_rate[index],
                    self.acceleration[index], self.climb_rate[index], self.interval,
                    self.speed_limited[index], self.turn_limited[index],
                    self.acceleration_limited[index], self.climb_limited[index])


@dataclass(frozen=True)
class PlatformKinematics:
    """Constant-turn, constant-acceleration kinematics of a steerable platform, with limits.

    Parameters
    ----------
    min_speed, max_speed : float, optional
        Horizontal speed range (m/s) at the end of every step.
    max_turn_rate, max_acceleration, max_climb_rate : float, optional
        Largest turn rate (rad/s), tangential acceleration or deceleration (m/s^2), and climb or
        descent rate (m/s).
    min_altitude, max_altitude : float, optional
        Altitude band (m, ENU up) the platform may not leave at the end of a step.
    on_limit : {"clip", "raise"}, optional
        ``"clip"``: clip to the limits and report it in the :class:`Step` masks; ``"raise"``: raise
        ``ValueError`` when an action would need clipping.

    Raises
    ------
    ValueError
        If the limits are inconsistent (negative, or a minimum above its maximum).

    Notes
    -----
    Order of the limits: the commanded end speed is clipped to the speed range, then the
    acceleration it needs to the acceleration limit; the heading change divided by the
    interval to the turn-rate limit; the climb rate to the altitude band, then to the
    climb-rate limit (so a platform outside the band returns at most at that rate).
    """

    min_speed: float = 0.0
    max_speed: float = math.inf
    max_turn_rate: float = math.inf
    max_acceleration: float = math.inf
    max_climb_rate: float = math.inf
    min_altitude: float = -math.inf
    max_altitude: float = math.inf
    on_limit: Literal["clip", "raise"] = "clip"

    def __post_init__(self) -> None:
        """Check the limits (see Raises)."""
        if not 0.0 <= self.min_speed <= self.max_speed:
            raise ValueError(f"speed range must satisfy 0 <= min_speed <= max_speed, got "
                             f"[{self.min_speed:g}, {self.max_speed:g}] m/s")
        for name in ("max_turn_rate", "max_acceleration", "max_climb_rate"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not self.min_altitude <= self.max_altitude:
            raise ValueError(f"altitude band [{self.min_altitude:g}, {self.max_altitude:g}] "
                             "m is empty")
        if self.on_limit not in ("clip", "raise"):
            raise ValueError(f"on_limit must be 'clip' or 'raise', got {self.on_limit!r}")

    def step(self, state: PlatformState, actions: Actions, interval: float) -> Step:
        """Fly every action from every state for one decision interval (vectorised).

        Parameters
        ----------
        state : PlatformState
            Start state(s); its batch shape broadcasts with that of ``actions``.
        actions : Actions
            Candidate actions.
        interval : float
            Decision interval (s), > 0.

        Returns
        -------
        Step
            Batch shape ``broadcast(state.shape, actions.shape)``.

        Raises
        ------
        ValueError
            If ``interval`` is not positive, or with ``on_limit="raise"`` when a limit acts.
        """
        T = float(interval)
        if not (math.isfinite(T) and T > 0):
            raise ValueError(f"decision interval must be positive, got {interval} s")
        shape = np.broadcast_shapes(state.shape, actions.shape)
        v0 = np.broadcast_to(state.speed, shape)
        z0 = np.broadcast_to(state.position[..., 2], shape)
        target = v0 * actions.speed_factor + actions.speed_change
        v1 = np.clip(target, self.min_speed, self.max_speed)
        acc_cmd = (v1 - v0) / T
        acc = np.clip(acc_cmd, -self.max_acceleration, self.max_acceleration)
        w_cmd = np.broadcast_to(actions.heading_change / T, shape)
        w = np.clip(w_cmd, -self.max_turn_rate, self.max_turn_rate)
        c_cmd = np.broadcast_to(state.climb_rate if actions.climb_rate is None
                                else actions.climb_rate, shape)
        c = np.clip(c_cmd, (self.min_altitude - z0) / T, (self.max_altitude - z0) / T)
        c = np.clip(c, -self.max_climb_rate, self.max_climb_rate)
        flags = {"speed range": _differs(v1, target),
                 "acceleration limit": _differs(acc, acc_cmd),
                 "turn-rate limit": _differs(w, w_cmd),
                 "climb-rate limit or altitude band": _differs(c, c_cmd)}
        if self.on_limit == "raise":
            for name, flag in flags.items():
                if np.any(flag):
                    first = tuple(int(i) for i in np.argwhere(flag)[0])
                    raise ValueError(f"action {first} of the step from t = {state.time:g} s "
                                     f"exceeds the platform's {name}")
        v_end = np.where(flags["acceleration limit"], np.maximum(v0 + acc * T, 0.0), v1)
        pos = np.broadcast_to(state.position, (*shape, 3))
        psi0 = np.broadcast_to(state.heading, shape)
        moved = propagate_constant_turn(pos, psi0, v0, c, w, acc, T)
        trusted = PlatformState.trusted     # every field derived from checked ones
        end = trusted(moved[..., :3], psi0 + w * T, v_end, c, state.time + T)
        return Step(trusted(pos, psi0, v0, np.broadcast_to(state.climb_rate, shape), state.time),
                    end, w, acc, c, T, flags["speed range"], flags["turn-rate limit"],
                    flags["acceleration limit"], flags["climb-rate limit or altitude band"])

    def fly(self, start: PlatformState, actions: Actions, interval: float) -> PlatformTrack:
        """Fly ``K`` actions one after another from one start state.

        Parameters
        ----------
        start : PlatformState
            One state (batch shape ``()``).
        actions : Actions, shape (K,)
            The actions, in order.
        interval : float
            Decision interval (s).

        Returns
        -------
        PlatformTrack
            The flown path, from ``start.time`` to ``start.time + K * interval``.

        Raises
        ------
        ValueError
            If ``start`` is not one state or ``actions`` is not 1-D and non-empty.
        """
        if start.shape != () or len(actions.shape) != 1 or not actions.shape[0]:
            raise ValueError("fly() takes one start state and a 1-D sequence of actions")
        steps = []
        state = start
        for k in range(len(actions)):
            steps.append(self.step(state, actions[k], interval))
            state = steps[-1].end
        return PlatformTrack(steps)


class PlatformTrack(SensorTrack):
    """A flown path: consecutive one-candidate :class:`Step` s, exact at every time.

    Parameters
    ----------
    steps : sequence of Step
        Steps of batch shape ``()``, each starting where and when the previous one ended.

    Raises
    ------
    ValueError
        If there is no step, a step holds several candidates, or the steps do not join.

    Notes
    -----
    At a step boundary the later step is used: horizontal velocity is continuous there, the
    climb rate may change.  Times outside the path are refused, as by ``RecordedTrack``.
    """

    def __init__(self, steps: Sequence[Step]) -> None:
        self.steps = tuple(steps)
        if not self.steps:
            raise ValueError("a platform track needs at least one step")
        for k, step in enumerate(self.steps):
            if step.shape != ():
                raise ValueError(f"step {k}: holds candidates of shape {step.shape}; select "
                                 "one with step[index]")
            if k:
                prev = self.steps[k - 1]
                scale = max(1.0, abs(prev.end_time))
                gap = float(np.max(np.abs(step.start.position - prev.end.position)))
                if (abs(step.start.time - prev.end_time) > _TIME_TOL * scale
                        or gap > 1e-6 * max(1.0, float(np.max(np.abs(prev.end.position))))):
                    raise ValueError(f"step {k} does not start where and when step {k - 1} "
                                     "ended")
        s = self.steps
        self._t0 = np.array([st.start.time for st in s])
        self._pos = np.array([st.start.position for st in s])
        self._rates = np.array([[st.start.heading, st.start.speed, st.climb_rate, st.turn_rate,
                                 st.acceleration, st.interval] for st in s])

    @property
    def start_time(self) -> float:
        """First time of the path (s)."""
        return float(self._t0[0])

    @property
    def end_time(self) -> float:
        """Last time of the path (s)."""
        return self.steps[-1].end_time

    @property
    def end(self) -> PlatformState:
        """State at the end of the path."""
        return self.steps[-1].end

    def states(self, t: ArrayLike) -> Array:
        """Return the ENU position and velocity at times ``t``.

        Parameters
        ----------
        t : array_like, shape (n,)
            Times (s) inside the path.

        Returns
        -------
        ndarray, shape (n, 6)
            ``[x, y, z, vx, vy, vz]`` (m, m/s).

        Raises
        ------
        ValueError
            If a time lies outside ``[start_time, end_time]``.
        """
        t = np.atleast_1d(_arr(t))
        tol = _TIME_TOL * max(1.0, abs(self.start_time), abs(self.end_time))
        if t.ndim != 1 or np.any((t < self.start_time - tol) | (t > self.end_time + tol)):
            raise ValueError(f"times must be a 1-D array inside the flown path "
                             f"[{self.start_time:g}, {self.end_time:g}] s")
        k = np.clip(np.searchsorted(self._t0, t, side="right") - 1, 0, len(self.steps) - 1)
        psi, v, c, w, a, T = self._rates[k].T
        s = np.clip(t - self._t0[k], 0.0, T)
        return propagate_constant_turn(self._pos[k], psi, v, c, w, a, s)


@dataclass(frozen=True, eq=False)
class PlatformConfiguration:
    """A named platform: its kinematics, its action set and its decision interval.

    Attributes
    ----------
    name : str
        Name for :func:`platform_configuration`.
    kinematics : PlatformKinematics
        Limits of the platform.
    actions : Actions
        Candidate actions of every decision.
    interval : float
        Decision interval (s).
    source : str
        Where it comes from (author-year, section).
    """

    name: str
    kinematics: PlatformKinematics
    actions: Actions
    interval: float
    source: str


HURTADO_NEHORAI_2008 = PlatformConfiguration(
    name="hurtado_nehorai_2008",
    kinematics=PlatformKinematics(min_speed=50.0, max_speed=200.0,
                                  max_turn_rate=math.radians(10.0) / 0.5),
    actions=Actions.grid(np.radians([-10.0, -5.0, 0.0, 5.0, 10.0]),
                         speed_factors=[0.9, 1.0, 1.1]),
    interval=0.5,
    source="Hurtado & Nehorai (2008), section 5, example 1: speed x0.9 / x1 / x1.1 kept in "
           "[50, 200] m/s, heading -10..+10 degrees in 5-degree steps, one step per 0.5 s "
           "pulse repetition interval",
)
"""The 15 actions of Hurtado & Nehorai (2008), section 5, example 1: index ``5 * f + h``.

Speed factor ``(0.9, 1.0, 1.1)[f]`` (clipped to [50, 200] m/s), heading change
``(-10, -5, 0, +5, +10)[h]`` degrees (20 deg/s at most), no acceleration limit (the paper
states none); a heading change is flown as a constant turn rate and acceleration."""

PLATFORM_CONFIGURATIONS: dict[str, PlatformConfiguration] = {
    HURTADO_NEHORAI_2008.name: HURTADO_NEHORAI_2008,
}


def platform_configuration(name: str) -> PlatformConfiguration:
    """Look up a named platform configuration (see :data:`PLATFORM_CONFIGURATIONS`).

    Parameters
    ----------
    name : str
        ``"hurtado_nehorai_2008"``.

    Returns
    -------
    PlatformConfiguration
        The configuration (interval in s, limits in m/s, rad/s, m/s^2).

    Raises
    ------
    ValueError
        If the name is unknown.

    References
    ----------
    Hurtado & Nehorai (2008), section 5.
    """
    key = name.strip().lower()
    if key not in PLATFORM_CONFIGURATIONS:
        raise ValueError(f"unknown platform configuration {name!r}; expected one of "
                         f"{', '.join(PLATFORM_CONFIGURATIONS)}")
    return PLATFORM_CONFIGURATIONS[key]
