"""Exact curvilinear motion: constant tangential and normal acceleration
(002_e7269ad11b825346.txt §2.1, eq. 1), and piecewise curvilinear manoeuvres (eqs. 2-4).

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

Derivatives.  The same formulas are differentiated in closed form (forward mode: every
intermediate carries its derivatives with respect to ``v0, a_t, a_n, s``; position and course
at the start enter as a translation and a rotation).  :class:`PiecewiseCurvilinear` chains these
one-segment derivatives from the reference state through the change-over times, so its
Jacobian is analytic for every parameter, the change-over times included, and never
differences across a change-over time.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .base import MotionModel

Array = NDArray[np.float64]

# |g| + |r| below this: F from its power series.  Its n-th term is at most
# (|g| + |r|)^n / (n + 1), so 15 terms leave < 1e-20; above the threshold the closed form
# loses at most eps / threshold to cancellation (eps / threshold^2 in its derivatives).
_SERIES_BELOW = 0.05
_SERIES_TERMS = 15
_LOG_SERIES_BELOW = 1e-2  # |r| below this: log1p(r) / r from its power series
_LOG_SERIES_TERMS = 12    # 1e-2 ** 12: far below rounding
_LOG_COEFF = [(-1.0) ** n / (n + 1) for n in range(_LOG_SERIES_TERMS)]


def _log1p_over(r: Array) -> tuple[Array, Array]:
    """``log1p(r) / r`` and its derivative with respect to ``r``, continuous at r = 0."""
    small = np.abs(r) < _LOG_SERIES_BELOW
    safe = np.where(small, 1.0, r)
    closed = np.log1p(safe) / safe
    d_closed = (1.0 / (1.0 + safe) - closed) / safe
    rs = np.where(small, r, 0.0)
    series = np.full_like(rs, _LOG_COEFF[-1])
    d_series = np.zeros_like(rs)
    for c in reversed(_LOG_COEFF[:-1]):  # Horner for the polynomial and its derivative
        d_series = d_series * rs + series
        series = series * rs + c
    return np.where(small, series, closed), np.where(small, d_series, d_closed)


def _propagate(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
               a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike, derivatives: bool = False
               ) -> tuple[tuple[Array, ...], Array | None]:
    """The closed form of the module docstring; optionally with its derivatives.

    Returns ``((x, y, speed, course, vx, vy), D)`` where ``D`` (shape ``(..., 4, 7)``, or
    None) holds ``d (x, y, speed, course) / d (x0, y0, v0, phi0, a_t, a_n, dt)``.
    """
    x, y, v0, phi0, a_t, a_n, dt = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, y, speed, course, a_t, a_n, dt))
    )
    with np.errstate(invalid="ignore"):
        valid = (v0 > 0) & (v0 + a_t * dt > 0)
    v0s = np.where(valid, v0, 1.0)
    ats = np.where(valid, a_t, 0.0)
    acc = ats + 1j * np.where(valid, a_n, 0.0)      # complex acceleration
    dts = np.where(valid, dt, 0.0)
    r = ats * dts / v0s
    g = acc * dts / v0s
    log_over, d_log_over = _log1p_over(r)
    expo = g * log_over                             # log(V(s) / V0)
    growth = np.exp(expo)
    # F(g, r): power series near zero acceleration, closed form elsewhere.
    use_series = (np.abs(g) + np.abs(r)) < _SERIES_BELOW
    den = np.where(use_series, 1.0, g + r)
    closed = ((1.0 + r) * growth - 1.0) / den
    series = np.zeros_like(g)
    term = np.ones_like(g)
    if derivatives:
        zero = np.zeros_like(r)
        one = np.ones_like(r)
        inv = 1.0 / v0s
        # d/d(v0, a_t, a_n, dt) on the last axis
        d_r = np.stack([-r * inv, dts * inv, zero, ats * inv], axis=-1)
        d_g = np.stack([-g * inv, dts * inv + 0j, 1j * dts * inv, acc * inv], axis=-1)
        d_expo = log_over[..., None] * d_g + (g * d_log_over)[..., None] * d_r
        d_growth = growth[..., None] * d_expo
        d_series = np.zeros_like(d_g)
        d_term = np.zeros_like(d_g)
    for n in range(_SERIES_TERMS):
        series = series + term / math.factorial(n + 1)
        step = g - n * r
        if derivatives:
            d_series = d_series + d_term / math.factorial(n + 1)
            d_term = d_term * step[..., None] + term[..., None] * (d_g - n * d_r)
        term = term * step
    factor = np.where(use_series, series, closed)
    e0 = np.exp(1j * phi0)
    V0 = v0s * e0
    disp = V0 * dts * factor
    vel = V0 * growth
    nan = np.where(valid, 0.0, np.nan)
    speed_out = v0s * (1.0 + r) + nan
    course_out = phi0 + np.imag(expo) + nan
    values = (x + disp.imag + nan, y + disp.real + nan, speed_out, course_out,
              vel.imag + nan, vel.real + nan)
    if not derivatives:
        return values, None
    d_closed = (d_r * growth[..., None] + (1.0 + r)[..., None] * d_growth
                - closed[..., None] * (d_g + d_r)) / den[..., None]
    d_factor = np.where(use_series[..., None], d_series, d_closed)
    d_dts = np.stack([zero, zero, zero, one], axis=-1)
    d_v0 = np.stack([e0, 0j * e0, 0j * e0, 0j * e0], axis=-1)
    d_disp = (V0[..., None] * (d_dts * factor[..., None] + dts[..., None] * d_factor)
              + d_v0 * (dts * factor)[..., None])              # (..., 4): v0, a_t, a_n, dt
    rot = 1j * disp                                            # d disp / d phi0
    D = np.zeros((*x.shape, 4, 7))
    D[..., 0, 0] = 1.0
    D[..., 1, 1] = 1.0
    D[..., 0, 3], D[..., 1, 3] = rot.imag, rot.real
    D[..., 0, [2, 4, 5, 6]] = d_disp.imag
    D[..., 1, [2, 4, 5, 6]] = d_disp.real
    D[..., 2, 2], D[..., 2, 4], D[..., 2, 6] = 1.0, dts, ats
    D[..., 3, 3] = 1.0
    D[..., 3, [2, 4, 5, 6]] = d_expo.imag
    D = D + nan[..., None, None]
    return values, D


def propagate_curvilinear(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
                          a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike
                          ) -> tuple[NDArray[np.float64], ...]:
    """Propagate curvilinear states by ``dt`` seconds (any sign); all inputs broadcast.

    Returns ``(x, y, speed, course, vx, vy)`` (m, m, m/s, rad clockwise from North, m/s,
    m/s).  Where the speed would reach zero or below before ``dt`` the result is NaN (the model
    does not describe a target that stops).
    """
    return _propagate(x, y, speed, course, a_t, a_n, dt)[0]


def propagate_curvilinear_derivatives(x: ArrayLike, y: ArrayLike, speed: ArrayLike,
                                      course: ArrayLike, a_t: ArrayLike, a_n: ArrayLike,
                                      dt: ArrayLike
                                      ) -> tuple[tuple[NDArray[np.float64], ...],
                                                 NDArray[np.float64]]:
    """:func:`propagate_curvilinear` and its analytic derivatives.

    Returns ``(states, D)``: ``states`` as :func:`propagate_curvilinear`, ``D`` of shape
    ``(..., 4, 7)`` with ``D[..., i, j] = d out_i / d in_j`` for outputs
    ``(x, y, speed, course)`` and inputs ``(x, y, speed, course, a_t, a_n, dt)``.  NaN where
    the propagation is undefined.
    """
    values, D = _propagate(x, y, speed, course, a_t, a_n, dt, derivatives=True)
    assert D is not None
    return values, D


class PiecewiseCurvilinear(MotionModel):
    """Piecewise curvilinear motion with ``M`` manoeuvres (002_e7269ad11b825346.txt eqs. 1-4).

    Parameters: ``x, y, speed, course`` (m, m, m/s, rad clockwise from North) at ``ref_time``
    (s); the accelerations ``at_0, an_0, ..., at_M, an_M`` (m/s^2) of the ``M + 1``
    segments; the change-over times ``t_1 < ... < t_M`` (s).  Indexing follows the paper's
    simulation section (§4): ``at_m, an_m`` act from ``t_m`` on, so segment ``m`` covers
    ``(t_m, t_{m+1}]``; segment 0 extends to -infinity and segment M to +infinity.

    Conventions: a sample exactly at a change-over time belongs to the earlier segment (and so
    does a reference time exactly at one).  The trajectory is chained outwards from the
    reference state, forwards through later change-over times and backwards through earlier
    ones (eqs. 3-4).  Change-over times out of order (or equal) give NaN states, as does a
    segment whose speed would reach zero.  Motion is planar (z = 0).

    :meth:`jacobian` is analytic (see the module docstring).  At a sample exactly at a
    change-over time ``t_m`` the velocity is not differentiable in ``t_m``; the Jacobian gives
    the derivative for ``t_m`` increasing, the side on which the sample stays in the earlier
    segment (position is differentiable there).  ``states`` and ``jacobian`` take ``theta``
    of shape ``(..., p)`` and are vectorised over the leading axes.
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

    # -- parameter layout ----------------------------------------------------------------
    def accel_index(self, segment: int) -> tuple[int, int]:
        """Indices of ``at_segment`` and ``an_segment`` in ``theta``."""
        return 4 + 2 * segment, 5 + 2 * segment

    def time_index(self, m: int) -> int:
        """Index of the change-over time ``t_m`` (m = 1..M) in ``theta``."""
        return 5 + 2 * self.manoeuvres + m

    # -- evaluation ------------------------------------------------------------------------
    def _evaluate(self, theta: Array, t: Array, derivatives: bool
                  ) -> tuple[Array, Array, Array | None]:
        """For ``theta`` ``(B, p)``: Cartesian states ``(B, n, 6)``, intrinsic states
        ``(B, n, 4)`` (x, y, speed, course) and, if asked, ``d state / d theta``
        ``(B, n, 6, p)``."""
        M, p = self.manoeuvres, self.n_params
        B, n = theta.shape[0], t.shape[0]
        acc = theta[:, 4:6 + 2 * M].reshape(B, M + 1, 2)
        cot = theta[:, 6 + 2 * M:]
        rows = np.arange(B)
        eye = np.eye(p)
        with np.errstate(invalid="ignore"):
            ordered = (np.all(np.diff(cot, axis=1) > 0, axis=1) if M > 1
                       else np.all(np.isfinite(cot), axis=1))
            seg_ref = np.sum(cot < self.ref_time, axis=1)               # (B,)
            seg_of = np.sum(t[None, :, None] > cot[:, None, :], axis=-1)  # (B, n)
        # Anchor of each segment: a time inside or at the edge of it and the state there.
        anc_t = np.full((B, M + 1), np.nan)
        anc_s = np.full((B, M + 1, 4), np.nan)
        anc_t[rows, seg_ref] = self.ref_time
        anc_s[rows, seg_ref] = theta[:, :4]
        if derivatives:
            anc_J = np.zeros((B, M + 1, 4, p))      # d anchor state / d theta
            anc_dT = np.zeros((B, M + 1, p))        # d anchor time / d theta
            anc_J[rows, seg_ref, :, :4] = np.eye(4)

        def link(frm: int, to: int, seg_acc: int, m: int, mask: Array) -> None:
            """Anchor ``to`` = state at change-over time ``t_m`` propagated from anchor
            ``frm`` with the accelerations of segment ``seg_acc``."""
            if not np.any(mask):
                return
            a = acc[:, seg_acc]
            dt = cot[:, m - 1] - anc_t[:, frm]
            vals, D = _propagate(*anc_s[:, frm].T, a[:, 0], a[:, 1], dt, derivatives)
            anc_t[mask, to] = cot[mask, m - 1]
            anc_s[mask, to] = np.stack(vals[:4], axis=-1)[mask]
            if derivatives:
                assert D is not None
                i_at, i_an = self.accel_index(seg_acc)
                d_dt = eye[self.time_index(m)] - anc_dT[:, frm]             # (B, p)
                J = (D[:, :, :4] @ anc_J[:, frm] + D[:, :, 4:5] * eye[i_at]
                     + D[:, :, 5:6] * eye[i_an] + D[:, :, 6:7] * d_dt[:, None, :])
                anc_J[mask, to] = J[mask]
                anc_dT[mask, to] = eye[self.time_index(m)]

        with np.errstate(invalid="ignore"):
            for j in range(1, M + 1):        # forwards: t_j starts segment j
                link(j - 1, j, j - 1, j, j > seg_ref)
            for j in range(M - 1, -1, -1):   # backwards: t_{j+1} ends segment j
                link(j + 1, j, j + 1, j + 1, j < seg_ref)

            r2 = rows[:, None]
            a = acc[r2, seg_of]                                             # (B, n, 2)
            vals, D = _propagate(*np.moveaxis(anc_s[r2, seg_of], -1, 0), a[..., 0], a[..., 1],
                                 t[None, :] - anc_t[r2, seg_of], derivatives)
        x, y, speed, course, vx, vy = vals
        bad = np.where(ordered, 0.0, np.nan)[:, None]
        zeros = np.zeros_like(x)
        cart = np.stack([x, y, zeros, vx, vy, zeros], axis=-1) + bad[..., None]
        intrinsic = np.stack([x, y, speed, course], axis=-1) + bad[..., None]
        if not derivatives:
            return cart, intrinsic, None
        assert D is not None
        i_at = 4 + 2 * seg_of
        J = (D[..., :4] @ anc_J[r2, seg_of] + D[..., 4:5] * eye[i_at][..., None, :]
             + D[..., 5:6] * eye[i_at + 1][..., None, :]
             - D[..., 6:7] * anc_dT[r2, seg_of][..., None, :])
        jac = np.zeros((B, n, 6, p))
        jac[:, :, 0] = J[:, :, 0]
        jac[:, :, 1] = J[:, :, 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            sin_c, cos_c = (vx / speed)[..., None], (vy / speed)[..., None]
        jac[:, :, 3] = sin_c * J[:, :, 2] + vy[..., None] * J[:, :, 3]
        jac[:, :, 4] = cos_c * J[:, :, 2] - vx[..., None] * J[:, :, 3]
        jac = jac + bad[..., None, None]
        return cart, intrinsic, jac

    def _flat(self, theta: ArrayLike, t: ArrayLike) -> tuple[Array, Array, tuple[int, ...]]:
        theta = self._check_theta(theta)
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"sample times must be one-dimensional; got shape {t.shape}")
        return theta.reshape(-1, self.n_params), t, theta.shape[:-1]

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """ENU states ``(..., n, 6)`` (m, m/s) at times ``t`` (s)."""
        flat, t, lead = self._flat(theta, t)
        cart = self._evaluate(flat, t, derivatives=False)[0]
        return cart.reshape(*lead, t.shape[0], 6)

    def intrinsic_states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """``(x, y, speed, course)`` ``(..., n, 4)`` at times ``t`` (m, m, m/s, rad clockwise
        from North; the course is continuous along the track, not wrapped)."""
        flat, t, lead = self._flat(theta, t)
        intrinsic = self._evaluate(flat, t, derivatives=False)[1]
        return intrinsic.reshape(*lead, t.shape[0], 4)

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Analytic ``d state / d theta`` ``(..., n, 6, p)`` at times ``t``."""
        flat, t, lead = self._flat(theta, t)
        jac = self._evaluate(flat, t, derivatives=True)[2]
        assert jac is not None
        return jac.reshape(*lead, t.shape[0], 6, self.n_params)

    def rereferenced(self, theta: ArrayLike, ref_time: float, manoeuvres: int | None = None
                     ) -> tuple[PiecewiseCurvilinear, NDArray[np.float64]]:
        """The same trajectory as a model referenced at ``ref_time`` (s), keeping only the
        first ``manoeuvres`` change-over times (default: all): ``(model, theta)``.

        With fewer manoeuvres the trajectory agrees with the original only up to the first
        dropped change-over time; use it for data before that time.
        """
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (self.n_params,):
            raise ValueError(f"expected {self.n_params} parameters "
                             f"({', '.join(self.param_names)}), got shape {theta.shape}")
        keep = self.manoeuvres if manoeuvres is None else int(manoeuvres)
        if not 0 <= keep <= self.manoeuvres:
            raise ValueError(f"manoeuvres must be between 0 and {self.manoeuvres}; got {keep}")
        state = self.intrinsic_states(theta, [ref_time])[0]
        acc = theta[4:6 + 2 * keep]
        cot = theta[6 + 2 * self.manoeuvres:6 + 2 * self.manoeuvres + keep]
        return PiecewiseCurvilinear(keep, ref_time), np.concatenate([state, acc, cot])

    def __repr__(self) -> str:
        return f"PiecewiseCurvilinear(manoeuvres={self.manoeuvres}, ref_time={self.ref_time})"
