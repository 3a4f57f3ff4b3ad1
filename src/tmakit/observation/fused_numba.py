"""The ``numba`` kernel behind :mod:`tmakit.observation.fused_compiled` (imported from there).

One pass over the rows of a bearings-only problem under affine motion: from the relative
east and north positions and the predicted bearings it forms the whitened residual (wrapped
to one turn), each row's whitened Jacobian (the bearing's gradient ``(dy, -dx) / r^2``, rad/m,
through the affine map's coefficients) and sums ``J'J`` and ``J'r`` in blocks of rows, without
writing the ``(n, p)`` Jacobian.  Importing this module imports ``numba`` (an optional extra).
The sums may be reassociated (no other ``fastmath`` flag): the results agree with the NumPy
path to rounding
(``tests/test_fused_kernel.py``).
"""

from __future__ import annotations

import math

import numba

from ..arrays import Array

# Sums may be reassociated (vectorised: 1.7x faster here); NaN and infinities are kept.
_jit = numba.njit(cache=True, nogil=True, error_model="numpy",
                  fastmath={"reassoc", "contract", "arcp"})

_BLOCK = 256  # rows summed apart before being added to the totals (smaller rounding)


@_jit
def _wrapped(e: float) -> float:  # pragma: no cover - compiled
    """Give :func:`~tmakit.frames.wrap_angle` of ``e`` within a turn of (-pi, pi] (rad).

    ``e`` itself in the interval, else shifted by a turn (exact, as the NumPy path's: the
    caller checks the turn with :func:`_beyond`), by selections (no branch: the loop is
    vectorised).
    """
    two_pi = 2.0 * math.pi
    out = e - two_pi if e > math.pi else e
    return out + two_pi if e <= -math.pi else out


@_jit
def _beyond(e: float) -> int:  # pragma: no cover - compiled
    """Give 1 where ``e`` lies more than a turn outside (-pi, pi], else 0 (NaN: 0, kept)."""
    two_pi = 2.0 * math.pi
    return 1 if (e - two_pi > math.pi or e + two_pi <= -math.pi) else 0


@_jit
def _add_block(jtj: Array, jtr: Array, velocity: bool, s00: float, s01: float, s11: float,
               s02: float, s03: float, s12: float, s13: float, s22: float, s23: float,
               s33: float, g0: float, g1: float, g2: float, g3: float
               ) -> None:  # pragma: no cover - compiled
    """Add one block's sums to the upper triangle of ``J'J`` and to ``J'r``."""
    jtj[0, 0] += s00
    jtj[0, 1] += s01
    jtj[1, 1] += s11
    jtr[0] += g0
    jtr[1] += g1
    if velocity:
        jtj[0, 2] += s02
        jtj[0, 3] += s03
        jtj[1, 2] += s12
        jtj[1, 3] += s13
        jtj[2, 2] += s22
        jtj[2, 3] += s23
        jtj[3, 3] += s33
        jtr[2] += g2
        jtr[3] += g3


@_jit
def bearing_normal(dx: Array, dy: Array, h: Array, u: Array, inv_sigma: Array, coef: Array,
                   velocity: bool, r: Array, jtj: Array, jtr: Array
                   ) -> int:  # pragma: no cover - compiled
    """Write the whitened residual ``r`` and add ``J'J`` and ``J'r`` of bearings.

    The parameters are the east and north position, then (with ``velocity``) the east and
    north velocity: the affine map ``(x + vx c, y + vy c)``.

    Parameters
    ----------
    dx, dy : ndarray
        ``(n,)`` relative east and north positions (m).
    h : ndarray
        ``(n,)`` predicted bearings ``atan2(dx, dy)`` (rad).
    u : ndarray
        ``(n,)`` measured bearings (rad).
    inv_sigma : ndarray
        ``(n,)`` inverse standard deviations (1/rad).
    coef : ndarray
        ``(n,)`` the velocities' coefficient (time since the reference, s).
    velocity : bool
        Whether there are four parameters (position and velocity) or two (position).
    r : ndarray
        ``(n,)`` written with the whitened residuals (dimensionless).
    jtj, jtr : ndarray
        ``(p, p)`` and ``(p,)`` zeros on entry, the sums on return.

    Returns
    -------
    int
        The rows whose residual lies more than a turn outside ``[-pi, pi)`` (not wrapped:
        the caller then takes the NumPy path).
    """
    n = dx.shape[0]
    bad = 0
    for lo in range(0, n, _BLOCK):
        s00 = s01 = s11 = s02 = s03 = s12 = s13 = s22 = s23 = s33 = 0.0
        g0 = g1 = g2 = g3 = 0.0
        for k in range(lo, min(n, lo + _BLOCK)):
            x, y = dx[k], dy[k]
            rho2 = x * x + y * y
            q = inv_sigma[k] / rho2
            a, b = y * q, -(x * q)
            e = u[k] - h[k]
            bad += _beyond(e)
            rk = _wrapped(e) * inv_sigma[k]
            r[k] = rk
            s00 += a * a
            s01 += a * b
            s11 += b * b
            g0 += a * rk
            g1 += b * rk
            if velocity:
                c = coef[k]
                ac, bc = a * c, b * c
                s02 += a * ac
                s03 += a * bc
                s12 += b * ac
                s13 += b * bc
                s22 += ac * ac
                s23 += ac * bc
                s33 += bc * bc
                g2 += ac * rk
                g3 += bc * rk
        _add_block(jtj, jtr, velocity, s00, s01, s11, s02, s03, s12, s13, s22, s23, s33,
                   g0, g1, g2, g3)
    p = jtj.shape[0]
    for i in range(p):
        for j in range(i):
            jtj[i, j] = jtj[j, i]
    return bad


@_jit
def bearing_residual(h: Array, u: Array, inv_sigma: Array, r: Array
                     ) -> tuple[float, int]:  # pragma: no cover - compiled
    """Write the whitened residual ``r`` of bearings and give half its squared norm.

    Parameters
    ----------
    h, u : ndarray
        ``(n,)`` predicted and measured bearings (rad).
    inv_sigma : ndarray
        ``(n,)`` inverse standard deviations (1/rad).
    r : ndarray
        ``(n,)`` written with ``wrap(u - h) / sigma`` (dimensionless).

    Returns
    -------
    (float, int)
        Half the sum of ``r**2``, and the rows whose residual lies more than a turn outside
        ``[-pi, pi)`` (not wrapped: the caller then takes the NumPy path).
    """
    bad = 0
    total = 0.0
    for k in range(h.shape[0]):
        e = u[k] - h[k]
        bad += _beyond(e)
        rk = _wrapped(e) * inv_sigma[k]
        r[k] = rk
        total += rk * rk
    return 0.5 * total, bad


_exact = numba.njit(cache=True, nogil=True, error_model="numpy")  # no fastmath: same bits


@_exact
def relative_east_north(base: Array, sensor: Array, lazy: bool, theta: Array, coef: Array,
                        velocity: bool, out: Array, head: Array
                        ) -> None:  # pragma: no cover - compiled
    """Write the relative east and north positions of the affine map (m), one pass.

    ``out[c] = (theta[2 + c] coef + theta[c]) + (base[c] - sensor[:, c])`` (``lazy``) or
    ``+ base[c]`` (``base`` is then the offset itself), the velocity term only with
    ``velocity``: the operations of :meth:`tmakit.observation.affine_rows.AffineRows.single`
    in its order (the same bits).

    Parameters
    ----------
    base : ndarray
        ``(>= 2, n)`` the target's offset (``lazy``) or the relative offset (m).
    sensor : ndarray
        ``(n, 6)`` sensor states subtracted from ``base`` when ``lazy`` (m, m/s).
    lazy : bool
        Whether ``sensor`` is subtracted.
    theta : ndarray
        ``(2,)`` or ``(4,)`` the parameters (m, m/s).
    coef : ndarray
        ``(n,)`` the velocities' coefficient (s).
    velocity : bool
        Whether ``theta`` has the velocities.
    out : ndarray
        ``(2, n)`` written (m).
    head : ndarray
        ``(2, n)`` written with ``base[c] - sensor[:, c]`` when ``lazy`` (m), the offset's
        head for the next passes; not touched otherwise (may be empty).
    """
    n = out.shape[1]
    th0, th1 = theta[0], theta[1]
    tv0, tv1 = (theta[2], theta[3]) if velocity else (0.0, 0.0)
    for k in range(n):
        if lazy:
            head0, head1 = base[0, k] - sensor[k, 0], base[1, k] - sensor[k, 1]
            head[0, k], head[1, k] = head0, head1
        else:
            head0, head1 = base[0, k], base[1, k]
        if velocity:
            c = coef[k]
            out[0, k] = (c * tv0 + th0) + head0
            out[1, k] = (c * tv1 + th1) + head1
        else:
            out[0, k] = th0 + head0
            out[1, k] = th1 + head1
