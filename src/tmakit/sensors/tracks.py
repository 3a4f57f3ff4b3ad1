"""Sensor tracks: where the listening platform is, and how fast it moves, at any time.

Every track answers :meth:`SensorTrack.states` with ENU positions (m) and velocities (m/s), shape
``(n, 6)``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

SERIES_BELOW = 0.25  # |w s| below this: E1, E2 from their power series (closed form above
#                       loses at most eps / 0.25^2 ~ 4e-15 relative to cancellation)
SERIES_TERMS = 17    # 0.25**17 / 17! ~ 2e-25: far below rounding
E1_COEFF = [1.0 / math.factorial(n + 1) for n in range(SERIES_TERMS)]
E2_COEFF = [1.0 / (math.factorial(n) * (n + 2)) for n in range(SERIES_TERMS)]


def _turn_factors(z: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], ...]:
    """``E1(z) = (e^z - 1) / z`` and ``E2(z) = (e^z (z - 1) + 1) / z^2``, stable at 0."""
    shape = np.shape(z)
    z = np.atleast_1d(z)
    e1 = np.empty_like(z)
    e2 = np.empty_like(z)
    small = np.abs(z) < SERIES_BELOW
    every = bool(small.all())
    if every or small.any():                    # Horner on the power series
        zs = z if every else z[small]
        s1 = np.full_like(zs, E1_COEFF[-1])
        s2 = np.full_like(zs, E2_COEFF[-1])
        for c1, c2 in zip(E1_COEFF[-2::-1], E2_COEFF[-2::-1], strict=True):
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
                            acceleration: ArrayLike, dt: ArrayLike) -> NDArray[np.float64]:
    """Return sensor states (..., 6) after ``dt`` s at constant turn rate and acceleration."""
    pos = np.asarray(position, dtype=float)
    if pos.ndim == 0 or pos.shape[-1] not in (2, 3):
        raise ValueError(f"position must end in 2 or 3 ENU coordinates (m), got {pos.shape}")
    if pos.shape[-1] == 2:
        pos = np.concatenate([pos, np.zeros((*pos.shape[:-1], 1))], axis=-1)
    # no broadcast_arrays: the arithmetic broadcasts (the same values, fewer array views)
    psi0, v0, c, w, a, s = (np.asarray(q, dtype=float) for q in (
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


def _as_times(t: ArrayLike) -> NDArray[np.float64]:
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1:
        raise ValueError(f"times must be a 1-D array, got shape {t.shape}")
    return t


def _as_point(p: ArrayLike, what: str) -> NDArray[np.float64]:
    p = np.asarray(p, dtype=float).ravel()
    if p.shape[0] == 2:
        p = np.append(p, 0.0)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{what} must be 2 or 3 finite coordinates (m), got {p.tolist()}")
    return p


class SensorTrack(ABC):
    """A sensor whose position and velocity are known at every time (abstract).

    Subclasses implement :meth:`states`.
    """

    @abstractmethod
    def states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the sensor's ENU position and velocity at times ``t``.

        Parameters
        ----------
        t : array_like
            Times (s), scalar or 1-D.

        Returns
        -------
        numpy.ndarray
            ``[x, y, z, vx, vy, vz]`` ``(n, 6)`` (m, m/s).

        Raises
        ------
        ValueError
            If ``t`` is not 1-D (or, for a recorded track, outside the record).
        """


@dataclass(frozen=True)
class FixedSensor(SensorTrack):
    """A sensor that does not move (a ground station).

    Parameters
    ----------
    position : array_like
        ENU position, 2 or 3 finite coordinates (m); a 2-D one gets z = 0.

    Raises
    ------
    ValueError
        If the position is not 2 or 3 finite numbers.
    """

    position: tuple[float, float, float]

    def __init__(self, position: ArrayLike) -> None:
        object.__setattr__(self, "position", tuple(_as_point(position, "sensor position")))

    def states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the fixed position and zero velocity at times ``t``."""
        t = _as_times(t)
        out = np.zeros((t.shape[0], 6))
        out[:, :3] = self.position
        return out


@dataclass(frozen=True)
class Leg:
    """One leg of a :class:`LegsTrack`.

    Parameters
    ----------
    duration : float
        Leg duration (s, > 0); ``inf`` only for the last leg.
    turn_rate : float, optional
        Constant turn rate (rad/s, clockwise positive; 0 for a straight leg).
    speed : float or None, optional
        New speed from the start of this leg (m/s); None keeps the previous speed.
    """

    duration: float
    turn_rate: float = 0.0
    speed: float | None = None


class LegsTrack(SensorTrack):
    """Straight legs and constant-rate turns (arcs) flown at constant altitude.

    Before ``start_time`` the first leg is extended backwards; after the last leg ends the track
    continues on it.

    Parameters
    ----------
    start : array_like
        Start position, ENU (m), 2 or 3 coordinates; the altitude stays constant.
    heading : float
        Initial heading (rad, clockwise from North).
    speed : float
        Initial speed (m/s, > 0).
    legs : sequence of Leg
        The legs, at least one.
    start_time : float, optional
        Time at ``start`` (s).

    Raises
    ------
    ValueError
        If there is no leg, the speed, heading, start time or a leg's turn rate is not finite, a
        speed or duration is not positive, or a leg other than the last lasts forever.
    """

    def __init__(self, start: ArrayLike, heading: float, speed: float,
                 legs: Sequence[Leg], start_time: float = 0.0) -> None:
        self.start = _as_point(start, "track start")
        self.heading = float(heading)
        self.speed = float(speed)
        self.start_time = float(start_time)
        self.legs = tuple(legs)
        if not self.legs:
            raise ValueError("a legs track needs at least one leg")
        if not (np.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"sensor speed must be positive and finite, got {self.speed} m/s")
        if not np.isfinite(self.heading):
            raise ValueError(f"sensor heading must be finite, got {self.heading} rad")
        if not np.isfinite(self.start_time):
            raise ValueError(f"start time must be finite, got {self.start_time} s")
        for i, leg in enumerate(self.legs):
            if not leg.duration > 0:
                raise ValueError(f"leg {i + 1}: duration must be positive, got {leg.duration}")
            if leg.speed is not None and not (np.isfinite(leg.speed) and leg.speed > 0):
                raise ValueError(f"leg {i + 1}: speed must be positive and finite, "
                                 f"got {leg.speed}")
            if not np.isfinite(leg.turn_rate):
                raise ValueError(f"leg {i + 1}: turn rate must be finite, got {leg.turn_rate}")
            if not np.isfinite(leg.duration) and i != len(self.legs) - 1:
                raise ValueError(f"leg {i + 1}: only the last leg may last forever")
        # Horizontal state (x, y, speed, course) at the start of every leg.
        starts = []
        x, y, v, c = self.start[0], self.start[1], self.speed, self.heading
        t0 = self.start_time
        for leg in self.legs:
            v = leg.speed if leg.speed is not None else v
            starts.append((t0, x, y, v, c))
            if np.isfinite(leg.duration):
                end = propagate_constant_turn([x, y, 0.0], c, v, 0.0, leg.turn_rate, 0.0,
                                              leg.duration)
                x, y, c = float(end[0]), float(end[1]), c + leg.turn_rate * leg.duration
                t0 += leg.duration
        self._starts = np.array(starts)
        self._rates = np.array([leg.turn_rate for leg in self.legs])

    @property
    def leg_start_times(self) -> NDArray[np.float64]:
        """Start time of every leg (s)."""
        return self._starts[:, 0].copy()

    def states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the ENU states on the legs at times ``t``."""
        t = _as_times(t)
        idx = np.clip(np.searchsorted(self._starts[:, 0], t, side="right") - 1, 0, None)
        t0, x0, y0, v, c = self._starts[idx].T
        position = np.stack([x0, y0, np.full_like(x0, self.start[2])], axis=-1)
        return propagate_constant_turn(position, c, v, 0.0, self._rates[idx], 0.0, t - t0)



class WaypointTrack(SensorTrack):
    """Straight legs between waypoints, flown at constant speed or reached at given times.

    Give either ``speed`` (m/s, with ``start_time``) or ``times`` (s, one per waypoint,
    increasing).  Before the first and after the last waypoint the sensor holds position.

    Parameters
    ----------
    waypoints : array_like
        ENU waypoints ``(n >= 2, 2 or 3)`` (m); 2-D ones get z = 0.
    speed : float or None, optional
        Constant speed (m/s, > 0).
    times : array_like or None, optional
        Time at each waypoint (s, increasing).
    start_time : float, optional
        Time at the first waypoint when ``speed`` is given (s).

    Raises
    ------
    ValueError
        If the waypoints are not a finite ``(n >= 2, 2 or 3)`` array, not exactly one of
        ``speed`` and ``times`` is given, the speed is not positive, the times are not one
        increasing value per waypoint, or ``start_time`` is not finite.
    """

    def __init__(self, waypoints: ArrayLike, speed: float | None = None,
                 times: ArrayLike | None = None, start_time: float = 0.0) -> None:
        pts = np.asarray(waypoints, dtype=float)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.shape[0] < 2:
            raise ValueError("waypoints must be an (n >= 2, 2 or 3) array of ENU positions")
        if not np.all(np.isfinite(pts)):
            raise ValueError("waypoints must be finite")
        if not np.isfinite(start_time):
            raise ValueError(f"start time must be finite, got {start_time}")
        if pts.shape[1] == 2:
            pts = np.column_stack([pts, np.zeros(pts.shape[0])])
        if (speed is None) == (times is None):
            raise ValueError("give a waypoint track either a speed or the waypoint times")
        if times is None:
            if speed is None or not speed > 0:
                raise ValueError(f"speed must be positive, got {speed}")
            lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
            times = float(start_time) + np.concatenate([[0.0], np.cumsum(lengths)]) / speed
        times = np.asarray(times, dtype=float)
        if times.shape != (pts.shape[0],) or np.any(np.diff(times) <= 0):
            raise ValueError("waypoint times must be increasing, one per waypoint")
        self.waypoints = pts
        self.times = times

    def states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the ENU states between the waypoints at times ``t``."""
        t = _as_times(t)
        out = np.zeros((t.shape[0], 6))
        for axis in range(3):
            out[:, axis] = np.interp(t, self.times, self.waypoints[:, axis])
        leg = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0,
                      len(self.times) - 2)
        vel = np.diff(self.waypoints, axis=0) / np.diff(self.times)[:, None]
        inside = (t >= self.times[0]) & (t < self.times[-1])
        out[:, 3:] = np.where(inside[:, None], vel[leg], 0.0)
        return out


class RecordedTrack(SensorTrack):
    """Positions (and optionally velocities) recorded at given times, interpolated between.

    With velocities the interpolation is cubic Hermite (position and velocity both match the
    record); without, a cubic spline whose derivative gives the velocity (linear with only two
    samples).

    Parameters
    ----------
    times : array_like
        Record times (s), increasing, at least two.
    positions : array_like
        ENU positions ``(n, 2 or 3)`` (m), one row per time; 2-D ones get z = 0.
    velocities : array_like or None, optional
        ENU velocities ``(n, 2 or 3)`` (m/s), one row per time.

    Raises
    ------
    ValueError
        If the shapes do not match, the times are not increasing, or a value is not finite.
    """

    def __init__(self, times: ArrayLike, positions: ArrayLike,
                 velocities: ArrayLike | None = None) -> None:
        from scipy.interpolate import CubicHermiteSpline, CubicSpline, make_interp_spline

        t = np.asarray(times, dtype=float)
        p = np.asarray(positions, dtype=float)
        if p.ndim != 2 or p.shape[1] not in (2, 3) or p.shape[0] != t.shape[0]:
            raise ValueError("recorded positions must be (n, 2 or 3) with one row per time")
        if t.shape[0] < 2 or np.any(np.diff(t) <= 0):
            raise ValueError("recorded times must be increasing, at least two of them")
        if not np.all(np.isfinite(p)):
            raise ValueError("recorded positions must be finite")
        if p.shape[1] == 2:
            p = np.column_stack([p, np.zeros(t.shape[0])])
        self.times = t
        if velocities is not None:
            v = np.asarray(velocities, dtype=float)
            if v.ndim != 2 or v.shape[0] != t.shape[0] or v.shape[1] not in (2, 3):
                raise ValueError("recorded velocities must be (n, 2 or 3) with one row per time")
            if v.shape[1] == 2:
                v = np.column_stack([v, np.zeros(t.shape[0])])
            if not np.all(np.isfinite(v)):
                raise ValueError("recorded velocities must be finite")
            self._spline = CubicHermiteSpline(t, p, v, axis=0)
        elif t.shape[0] == 2:
            self._spline = make_interp_spline(t, p, k=1, axis=0)
        else:
            self._spline = CubicSpline(t, p, axis=0)
        self._velocity = self._spline.derivative()

    def states(self, t: ArrayLike) -> NDArray[np.float64]:
        """Give the interpolated ENU states at times ``t`` (as :meth:`SensorTrack.states`).

        Raises
        ------
        ValueError
            If ``t`` is not 1-D or a time is outside the record (beyond a 1e-9 relative tolerance).
        """
        t = _as_times(t)
        tol = 1e-9 * max(1.0, float(np.abs(self.times).max()))
        outside = (t < self.times[0] - tol) | (t > self.times[-1] + tol)
        if np.any(outside):
            bad = t[outside][0]
            raise ValueError(f"time {bad:g} s is outside the recorded sensor track "
                             f"[{self.times[0]:g}, {self.times[-1]:g}] s")
        t = np.clip(t, self.times[0], self.times[-1])
        return np.column_stack([self._spline(t), self._velocity(t)])

    @classmethod
    def from_geodetic(cls, times: ArrayLike, lat: ArrayLike, lon: ArrayLike, alt: ArrayLike,
                      origin: tuple[float, float, float],
                      velocities: ArrayLike | None = None) -> RecordedTrack:
        """Build a track recorded as WGS-84 latitude, longitude and altitude.

        Parameters
        ----------
        times : array_like
            Record times (s), increasing.
        lat, lon : array_like
            Latitude and longitude (deg).
        alt : array_like
            Altitude (m).
        origin : tuple of float
            ``(lat, lon, alt)`` of the ENU frame's origin (deg, deg, m).
        velocities : array_like or None, optional
            ENU velocities (m/s).

        Returns
        -------
        RecordedTrack
            The track in the ENU frame at ``origin``.

        Raises
        ------
        ValueError
            If the origin is out of range or the record is not valid (see the class).
        """
        from ..core.geodesy import geodetic_to_enu

        e, n, u = geodetic_to_enu(lat, lon, alt, origin)
        return cls(times, np.column_stack([e, n, u]), velocities)
