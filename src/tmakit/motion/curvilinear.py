"""Exact curvilinear motion: constant tangential and normal acceleration
(002_e7269ad11b825346.txt §2.1).

State ``(x, y, v, phi)``: ENU position (m), speed (m/s) and course phi (radians, clockwise from
North).  The tangential acceleration ``a_t`` changes the speed, the normal acceleration ``a_n``
turns the course at rate ``a_n / v`` (positive ``a_n`` turns clockwise, to starboard).

Closed form.  Write the horizontal velocity as the complex number ``V = v e^{i phi}`` (real part
North, imaginary part East).  Then ``dV/ds = (a_t + i a_n) V / v`` with ``v(s) = v0 + a_t s``, so
with ``g = (a_t + i a_n) s / v0`` and ``r = a_t s / v0``::

    V(s) = V0 exp(g * log1p(r) / r)                      (-> V0 exp(g) as r -> 0)
    P(s) - P0 = V0 s F(g, r),  F = ((1 + r) V(s)/V0 - 1) / (g + r)

and near zero acceleration ``F = sum_n prod_{j<n} (g - j r) / (n + 1)!``, which avoids the
cancellation in the closed form.  Both a_t = 0 (circular arc) and a_t != 0 are covered, and
propagation works backwards in time (s < 0) as well.  No ODE solver is involved.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .base import MotionModel, numerical_jacobian

_SERIES_BELOW = 1e-3
_SERIES_TERMS = 8


def _log1p_over(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """log1p(r) / r, continuous at r = 0."""
    small = np.abs(r) < 1e-8
    safe = np.where(small, 1.0, r)
    return np.where(small, 1.0 - r / 2.0 + r * r / 3.0, np.log1p(safe) / safe)


def _displacement_factor(g: NDArray[np.complex128], r: NDArray[np.float64],
                         growth: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """F(g, r) of the module docstring; ``growth`` is V(s)/V0."""
    size = np.abs(g) + np.abs(r)
    series = np.zeros_like(g)
    term = np.ones_like(g)
    for n in range(_SERIES_TERMS):
        series = series + term / math.factorial(n + 1)
        term = term * (g - n * r)
    denom = g + r
    use_series = size < _SERIES_BELOW
    safe_denom = np.where(use_series, 1.0, denom)
    closed = ((1.0 + r) * growth - 1.0) / safe_denom
    return np.where(use_series, series, closed)


def propagate_curvilinear(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
                          a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike
                          ) -> tuple[NDArray[np.float64], ...]:
    """Propagate curvilinear states by ``dt`` seconds (any sign); all inputs broadcast.

    Returns ``(x, y, speed, course, vx, vy)``.  Where the speed would reach zero or below
    before ``dt`` the result is NaN (the model does not describe a target that stops).
    """
    x, y, v0, phi0, a_t, a_n, dt = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, y, speed, course, a_t, a_n, dt))
    )
    valid = (v0 > 0) & (v0 + a_t * dt > 0)
    v0s = np.where(valid, v0, 1.0)
    r = np.where(valid, a_t * dt / v0s, 0.0)
    g = (a_t + 1j * a_n) * dt / v0s
    g = np.where(valid, g, 0.0)
    growth = np.exp(g * _log1p_over(r))
    factor = _displacement_factor(g, r, growth)
    V0 = v0s * np.exp(1j * phi0)
    disp = V0 * dt * factor
    vel = V0 * growth
    nan = np.where(valid, 0.0, np.nan)
    speed_out = v0s * (1.0 + r) + nan
    course_out = phi0 + np.imag(g * _log1p_over(r)) + nan
    return (x + disp.imag + nan, y + disp.real + nan, speed_out, course_out,
            vel.imag + nan, vel.real + nan)


class PiecewiseCurvilinear(MotionModel):
    """Piecewise curvilinear motion with ``M`` manoeuvres (002_e7269ad11b825346.txt eqs. 1-4).

    Parameters: ``x, y, speed, course`` (m, m, m/s, rad) at ``ref_time``; the accelerations
    ``at_0, an_0, ..., at_M, an_M`` (m/s^2) of the ``M + 1`` segments; the change-over times
    ``t_1 < ... < t_M`` (s).  Segment ``m`` covers ``(t_m, t_{m+1}]`` (a sample exactly at a
    change-over time belongs to the earlier segment); segment 0 extends to -infinity and
    segment M to +infinity.  Motion is planar (z = 0).

    ``d state / d theta`` is a central finite difference (the chained closed form is long);
    the issue on manoeuvring targets replaces it where accuracy demands.
    """

    dim = 2

    def __init__(self, manoeuvres: int = 0, ref_time: float = 0.0) -> None:
        if manoeuvres < 0:
            raise ValueError("the number of manoeuvres must be >= 0")
        self.manoeuvres = int(manoeuvres)
        self.ref_time = float(ref_time)
        accel = []
        for m in range(self.manoeuvres + 1):
            accel += [f"at_{m}", f"an_{m}"]
        times = [f"t_{m}" for m in range(1, self.manoeuvres + 1)]
        self.param_names = ("x", "y", "speed", "course", *accel, *times)
        self.name = f"curvilinear:{self.manoeuvres}"

    def _states_one(self, theta: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray:
        M = self.manoeuvres
        acc = theta[4:6 + 2 * M].reshape(M + 1, 2)
        cot = theta[6 + 2 * M:]
        out = np.full((t.shape[0], 6), np.nan)
        if M and np.any(np.diff(cot) <= 0):
            return out  # change-over times out of order: no trajectory
        bounds = np.concatenate([[-np.inf], cot, [np.inf]])
        seg_of = np.searchsorted(cot, t, side="left")  # t == t_m -> earlier segment
        seg_ref = int(np.searchsorted(cot, self.ref_time, side="left"))
        # Curvilinear state at every change-over time, chained outwards from the reference.
        anchor = {seg_ref: (self.ref_time, theta[:4])}
        state_at_bound: dict[int, NDArray] = {}
        prev_t, prev_s = self.ref_time, theta[:4]
        for m in range(seg_ref + 1, M + 1):  # boundaries above: t_m is the start of segment m
            at, an = acc[m - 1]
            s = propagate_curvilinear(*prev_s, at, an, bounds[m] - prev_t)[:4]
            state_at_bound[m] = np.array(s)
            prev_t, prev_s = bounds[m], state_at_bound[m]
            anchor[m] = (prev_t, prev_s)
        prev_t, prev_s = self.ref_time, theta[:4]
        for m in range(seg_ref, 0, -1):  # boundaries below: t_m is the end of segment m - 1
            at, an = acc[m]
            s = propagate_curvilinear(*prev_s, at, an, bounds[m] - prev_t)[:4]
            prev_t, prev_s = bounds[m], np.array(s)
            anchor[m - 1] = (prev_t, prev_s)
        for m in range(M + 1):
            sel = seg_of == m
            if not np.any(sel):
                continue
            t0, s0 = anchor[m]
            x, y, _, _, vx, vy = propagate_curvilinear(*s0, acc[m, 0], acc[m, 1], t[sel] - t0)
            out[sel, 0], out[sel, 1], out[sel, 2] = x, y, 0.0
            out[sel, 3], out[sel, 4], out[sel, 5] = vx, vy, 0.0
        return out

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        theta = self._check_theta(theta)
        t = np.asarray(t, dtype=float)
        flat = theta.reshape(-1, self.n_params)
        out = np.stack([self._states_one(th, t) for th in flat])
        return out.reshape(*theta.shape[:-1], t.shape[0], 6)

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        return numerical_jacobian(self, theta, t)

    def __repr__(self) -> str:
        return f"PiecewiseCurvilinear(manoeuvres={self.manoeuvres}, ref_time={self.ref_time})"
