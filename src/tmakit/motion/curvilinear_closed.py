"""The closed form of one curvilinear segment and its derivatives, vectorised.

:func:`propagate_with_partials` gives every value and derivative of a segment; the compiled
twin per sample is :mod:`tmakit.motion.curvilinear_compiled`.

References
----------
Hörst & Oispuu (2010), §2.1, eq. 1.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array

_SERIES_BELOW = 1e-3     # |g| + |r| below which F and its derivatives come from the series
_SERIES_TERMS = 6        # term n is below size^n / (n+1)!: < 1e-20 at the switch
_L_SERIES_BELOW = 1e-3   # |r| below which L(r) and L'(r) come from their power series
_L_TERMS = 6


def _log1p_over(r: Array) -> tuple[Array, Array]:
    """Compute ``L(r) = log1p(r) / r`` and ``L'(r)``, accurate for all ``r > -1``."""
    if not r.any():  # no tangential acceleration (often held at zero): the series' first terms
        return np.ones_like(r), np.full_like(r, -0.5)
    small = np.abs(r) < _L_SERIES_BELOW
    safe = np.where(small, 0.5, r)
    lg = np.log1p(safe)
    value = lg / safe
    deriv = (safe / (1.0 + safe) - lg) / (safe * safe)
    if np.any(small):
        zero = small & (r == 0.0)
        value[zero], deriv[zero] = 1.0, -0.5
        small &= ~zero
    if np.any(small):
        rs = r[small]
        # log1p(r)/r = sum_k (-r)^k / (k + 1);  derivative sum_{k>=1} k (-1)^k r^(k-1) / (k+1)
        ser = np.zeros_like(rs)
        ser_d = np.zeros_like(rs)
        power = np.ones_like(rs)  # r^k
        for k in range(_L_TERMS):
            sign = -1.0 if k % 2 else 1.0
            ser += sign * power / (k + 1)
            ser_d -= sign * (k + 1) * power / (k + 2)
            power = power * rs
        value[small], deriv[small] = ser, ser_d
    return value, deriv


def _f_series(g: NDArray[np.complex128], r: Array
              ) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
    """Sum ``F``, ``dF/dg``, ``dF/dr`` from ``F = sum_n prod_{j<n} (g - j r) / (n + 1)!``."""
    F = np.zeros_like(g)
    Fg = np.zeros_like(g)
    Fr = np.zeros_like(g)
    T = np.ones_like(g)
    Tg = np.zeros_like(g)
    Tr = np.zeros_like(g)
    for n in range(_SERIES_TERMS):
        f = 1.0 / math.factorial(n + 1)
        F, Fg, Fr = F + T * f, Fg + Tg * f, Fr + Tr * f
        factor = g - n * r
        T, Tg, Tr = T * factor, Tg * factor + T, Tr * factor - n * T
    return F, Fg, Fr


def segment_terms(v0: Array, a_t: Array, a_n: Array, s: Array, partials: bool
                  ) -> tuple[NDArray[np.bool_], dict[str, Array]]:
    """Compute the intermediate terms of the closed form for flat inputs."""
    with np.errstate(invalid="ignore"):
        valid = (v0 > 0) & (v0 + a_t * s > 0)
    if not valid.all():
        v0 = np.where(valid, v0, 1.0)
        a_t = np.where(valid, a_t, 0.0)
        a_n = np.where(valid, a_n, 0.0)
        s = np.where(valid, s, 0.0)
    sv = s / v0
    r = a_t * sv
    c = np.asarray(a_t + 1j * a_n, dtype=np.complex128)
    g = c * sv
    L, dL = _log1p_over(r)
    E = np.exp(g * L)
    use_series = (np.abs(g) + np.abs(r)) < _SERIES_BELOW
    denom = np.where(use_series, 1.0, g + r)
    F = ((1.0 + r) * E - 1.0) / denom
    terms = dict(v0=v0, a_t=a_t, a_n=a_n, s=s, sv=sv, r=r, c=c, g=g, L=L, dL=dL, E=E, F=F)
    if partials:
        terms["Fg"] = ((1.0 + r) * L * E - F) / denom
        terms["Fr"] = (E + (1.0 + r) * g * dL * E - F) / denom
    if np.any(use_series):
        # no acceleration at all (held at zero): the series is 1, its derivatives 1/2 and 0
        still = use_series & (g == 0.0) & (r == 0.0)
        F[still] = 1.0
        if partials:
            terms["Fg"][still], terms["Fr"][still] = 0.5, 0.0
        use_series &= ~still
    if np.any(use_series):
        F_s, Fg_s, Fr_s = _f_series(g[use_series], r[use_series])
        F[use_series] = F_s
        if partials:
            terms["Fg"][use_series], terms["Fr"][use_series] = Fg_s, Fr_s
    return valid, terms


def propagate_with_partials(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
                            a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike,
                            partials: bool = True) -> tuple[Array, Array | None]:
    """Propagate one curvilinear segment by ``dt`` seconds (any sign), with derivatives.

    References
    ----------
    Hörst & Oispuu (2010), eq. 1 (the closed form: see :mod:`tmakit.motion.curvilinear`).
    """
    x, y, v0, phi0, a_t, a_n, s = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, y, speed, course, a_t, a_n, dt)))
    shape = s.shape
    x, y, v0, phi0, a_t, a_n, s = (a.reshape(-1) for a in (x, y, v0, phi0, a_t, a_n, s))
    valid, parts = segment_terms(v0, a_t, a_n, s, partials)
    values = _values(x, y, phi0, valid, parts)
    values = values.reshape(*shape, 6)
    if not partials:
        return values, None
    out = _partials(parts)
    if not np.all(valid):
        out[~valid] = np.nan
    return values, out.reshape(*shape, 6, 7)


def _values(x: Array, y: Array, phi0: Array, valid: NDArray[np.bool_],
            parts: dict[str, Array]) -> Array:
    """Give ``(n, 6)`` ``(x, y, speed, course, vx, vy)``; store ``V0, disp, V`` in ``parts``."""
    v0, s, sv = parts["v0"], parts["s"], parts["sv"]
    V0 = v0 * np.exp(1j * phi0)
    disp = V0 * s * parts["F"]
    V = V0 * parts["E"]
    parts.update(V0=V0, disp=disp, V=V)
    values = np.stack([x + disp.imag, y + disp.real, v0 + parts["a_t"] * s,
                       phi0 + parts["a_n"] * sv * parts["L"], V.imag, V.real], axis=-1)
    if not valid.all():
        values += np.where(valid, 0.0, np.nan)[..., None]
    return values


def _complex_partials(parts: dict[str, Array]) -> tuple[Array, Array]:
    """Give ``d(Z, V) / d(v0, phi0, a_t, a_n, s)``, complex ``(n, 5)`` each."""
    v0, s, sv, r, c, g, L, dL, F, Fg, Fr, V0, disp, V = (
        parts[k] for k in ("v0", "s", "sv", "r", "c", "g", "L", "dL", "F", "Fg", "Fr", "V0",
                           "disp", "V"))
    q = V0 * sv
    dZ = np.stack([q * (F - g * Fg - r * Fr), 1j * disp, q * s * (Fg + Fr), 1j * q * s * Fg,
                   V], axis=-1)
    inv1r = 1.0 / (1.0 + r)  # = L + r L'
    Vsv = V * sv
    dV = np.stack([V / v0 * (1.0 - g * inv1r), 1j * V, Vsv * (L + g * dL), 1j * Vsv * L,
                   V * c / v0 * inv1r], axis=-1)
    return dZ, dV


def _partials(parts: dict[str, Array]) -> Array:
    """Assemble the ``(n, 6, 7)`` derivatives of one segment."""
    dZ, dV = _complex_partials(parts)
    v0, a_t, a_n, s, sv, L, dL = (parts[k] for k in ("v0", "a_t", "a_n", "s", "sv", "L", "dL"))
    inv1r = 1.0 / (1.0 + parts["r"])
    zero = np.zeros_like(s)
    one = np.ones_like(s)
    out = np.empty((s.size, 6, 7))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = one, zero, zero, one
    out[:, 0, 2:], out[:, 1, 2:] = dZ.imag, dZ.real
    out[:, 4:, :2] = 0.0
    out[:, 4, 2:], out[:, 5, 2:] = dV.imag, dV.real
    out[:, 2] = np.stack([zero, zero, one, zero, s, zero, a_t], axis=-1)
    an_v = a_n / v0 * inv1r
    out[:, 3] = np.stack([zero, zero, -an_v * sv, one, a_n * sv * sv * dL, sv * L, an_v],
                         axis=-1)
    return out
