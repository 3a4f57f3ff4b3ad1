"""The ``numba`` kernels behind :mod:`tmakit.motion.curvilinear_compiled` (imported from there).

The closed form of one curvilinear segment and its derivatives, written out per sample (the
formulas, branches and series of :mod:`tmakit.motion.curvilinear_closed`, which derives
them), and the forward chaining of :class:`tmakit.motion.curvilinear_batch.ForwardPiecewise`:
the change-over states with their derivatives, the samples' values and position/velocity
partials, and the chain rule to the parameters.  In NumPy every intermediate term is an
array written to memory and read back; here one compiled loop keeps them in registers.

Importing this module imports ``numba`` (an optional extra).  Every kernel works in float64
and writes into arrays it is given; no ``fastmath`` (the results agree with the NumPy path
to rounding, ``tests/test_curvilinear_kernel.py``).

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

import cmath
import math

import numba
import numpy as np

from ..arrays import Array

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

_SERIES_BELOW = 1e-3     # as curvilinear_closed: |g| + |r| below which F comes from its series
_SERIES_TERMS = 6
_L_SERIES_BELOW = 1e-3   # |r| below which L(r), L'(r) come from their series
_L_TERMS = 6
_INV_FACTORIAL = tuple(1.0 / math.factorial(n + 1) for n in range(_SERIES_TERMS))


@_inline
def _log1p_over(r: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """Give ``L(r) = log1p(r) / r`` and ``L'(r)`` (the branches of the NumPy path)."""
    if r == 0.0:
        return 1.0, -0.5
    if abs(r) < _L_SERIES_BELOW:
        ser = 0.0
        ser_d = 0.0
        power = 1.0
        for k in range(_L_TERMS):
            sign = -1.0 if k % 2 else 1.0
            ser += sign * power / (k + 1)
            ser_d -= sign * (k + 1) * power / (k + 2)
            power = power * r
        return ser, ser_d
    lg = math.log1p(r)
    return lg / r, (r / (1.0 + r) - lg) / (r * r)


@_inline
def _f_terms(g: complex, r: float, L: float, dL: float, E: complex
             ) -> tuple[complex, complex, complex]:  # pragma: no cover - compiled
    """Give ``F``, ``dF/dg``, ``dF/dr`` of the closed form (series near zero)."""
    if abs(g) + abs(r) >= _SERIES_BELOW:
        inv = 1.0 / (g + r)  # one complex division, not three
        F = ((1.0 + r) * E - 1.0) * inv
        return F, ((1.0 + r) * L * E - F) * inv, (E + (1.0 + r) * g * dL * E - F) * inv
    if g == 0.0 and r == 0.0:
        return 1.0 + 0.0j, 0.5 + 0.0j, 0.0j
    F = 0.0j
    Fg = 0.0j
    Fr = 0.0j
    T = 1.0 + 0.0j
    Tg = 0.0j
    Tr = 0.0j
    for n in range(_SERIES_TERMS):
        f = _INV_FACTORIAL[n]
        F, Fg, Fr = F + T * f, Fg + Tg * f, Fr + Tr * f
        factor = g - n * r
        T, Tg, Tr = T * factor, Tg * factor + T, Tr * factor - n * T
    return F, Fg, Fr


@_inline
def _segment(x: float, y: float, v0: float, phi0: float, V0: complex, a_t: float,
             a_n: float, s: float, vals: Array, par: Array, state_rows: bool,
             partials: bool) -> None:  # pragma: no cover - compiled
    """Propagate one segment: write ``vals`` (6,) and ``par`` (4, 7) (NaN if the speed dies).

    ``V0`` is the start velocity ``v0 exp(i phi0)`` (North + i East).  ``vals`` are ``(x, y,
    speed, course, vx, vy)``; ``par`` (if ``partials``) the derivatives with respect to
    ``(x0, y0, v0, phi0, a_t, a_n, s)`` of ``x, y, speed, course`` (``state_rows``) or of
    ``x, y, vx, vy``.
    """
    if not (v0 > 0.0 and v0 + a_t * s > 0.0):
        vals[:] = np.nan
        if partials:
            par[:, :] = np.nan
        return
    sv = s / v0
    r = a_t * sv
    c = complex(a_t, a_n)
    g = c * sv
    L, dL = _log1p_over(r)
    E = cmath.exp(g * L)
    F, Fg, Fr = _f_terms(g, r, L, dL, E)
    disp = V0 * s * F
    V = V0 * E
    vals[0] = x + disp.imag
    vals[1] = y + disp.real
    vals[2] = v0 + a_t * s
    vals[3] = phi0 + a_n * sv * L
    vals[4] = V.imag
    vals[5] = V.real
    if not partials:
        return
    q = V0 * sv
    dz = (q * (F - g * Fg - r * Fr), 1j * disp, q * s * (Fg + Fr), 1j * q * s * Fg, V)
    par[0, 0] = 1.0
    par[0, 1] = 0.0
    par[1, 0] = 0.0
    par[1, 1] = 1.0
    for k in range(5):
        par[0, 2 + k] = dz[k].imag
        par[1, 2 + k] = dz[k].real
    inv1r = 1.0 / (1.0 + r)
    if state_rows:
        an_v = a_n / v0 * inv1r
        par[2, 0] = par[2, 1] = par[2, 3] = par[2, 5] = 0.0
        par[2, 2] = 1.0
        par[2, 4] = s
        par[2, 6] = a_t
        par[3, 0] = par[3, 1] = 0.0
        par[3, 2] = -an_v * sv
        par[3, 3] = 1.0
        par[3, 4] = a_n * sv * sv * dL
        par[3, 5] = sv * L
        par[3, 6] = an_v
        return
    Vsv = V * sv
    dv = (V / v0 * (1.0 - g * inv1r), 1j * V, Vsv * (L + g * dL), 1j * Vsv * L,
          V * c / v0 * inv1r)
    par[2, 0] = par[2, 1] = par[3, 0] = par[3, 1] = 0.0
    for k in range(5):
        par[2, 2 + k] = dv[k].imag
        par[3, 2 + k] = dv[k].real


@_jit
def _derive_anchor(p47: Array, prev: Array, m: int, k0: int, d: Array) -> None:  # pragma: no cover
    """Write into ``d`` (4, p) the derivatives of segment ``m``'s start state.

    From the previous start state's ``prev`` (4, p) and the segment partials ``p47``.
    """
    for i in range(4):
        for c in range(d.shape[1]):
            acc = 0.0
            for j in range(4):
                acc += p47[i, j] * prev[j, c]
            d[i, c] = acc
        d[i, 2 + 2 * m] += p47[i, 4]
        d[i, 3 + 2 * m] += p47[i, 5]
        d[i, k0 + m - 1] += p47[i, 6]
        if m >= 2:
            d[i, k0 + m - 2] -= p47[i, 6]


@_jit
def _anchors(theta: Array, M: int, ref_time: float, end_time: float, partials: bool,
             anchors: Array, v_start: Array, starts: Array,
             d_anchor: Array) -> None:  # pragma: no cover - compiled
    """Chain one parameter vector's segment start states forwards (NaN outside the domain).

    Writes ``anchors`` (M + 1, 4), their start velocities ``v_start`` (complex), the start
    times ``starts`` (M + 1,) and, if ``partials``, ``d_anchor`` (M + 1, 4, p).
    """
    k0 = 6 + 2 * M
    v6 = np.empty(6)
    p47 = np.empty((4, 7))
    starts[0] = ref_time
    valid = True
    for m in range(1, M + 1):
        starts[m] = theta[k0 + m - 1]
        valid = valid and starts[m] > starts[m - 1]
    if M and not starts[M] < end_time:
        valid = False
    anchors[0, :] = theta[:4]
    if partials:
        d_anchor[0, :, :] = 0.0
        for j in range(4):
            d_anchor[0, j, j] = 1.0
    v_start[0] = anchors[0, 2] * cmath.exp(1j * anchors[0, 3])
    for m in range(1, M + 1):
        _segment(anchors[m - 1, 0], anchors[m - 1, 1], anchors[m - 1, 2], anchors[m - 1, 3],
                 v_start[m - 1], theta[2 + 2 * m], theta[3 + 2 * m], starts[m] - starts[m - 1],
                 v6, p47, True, partials)
        anchors[m, :] = v6[:4]
        v_start[m] = anchors[m, 2] * cmath.exp(1j * anchors[m, 3])
        if partials:
            _derive_anchor(p47, d_anchor[m - 1], m, k0, d_anchor[m])
    if not valid:
        anchors[:, :] = np.nan


@_jit
def piecewise(theta: Array, t: Array, manoeuvres: int, ref_time: float, end_time: float,
              partials: bool, seg: Array, vals: Array, par: Array,
              d_anchor: Array) -> None:  # pragma: no cover - compiled
    """Propagate every sample of a batch from the start of its segment, chained forwards.

    Parameters
    ----------
    theta : ndarray
        ``(B, p)`` parameters (``x, y, speed, course, at_0, an_0, ..., t_1, ...``, SI).
    t : ndarray
        ``(n,)`` sample times (s).
    manoeuvres : int
        ``M``.
    ref_time, end_time : float
        The reference time and the end of the admissible change-over times (s).
    partials : bool
        Whether to write ``par`` and ``d_anchor``.
    seg : ndarray of int
        ``(B, n)`` written with every sample's segment.
    vals : ndarray
        ``(B, n, 6)`` written with ``(x, y, speed, course, vx, vy)`` (NaN: outside the
        domain).
    par : ndarray
        ``(B, n, 4, 7)`` written with ``d (x, y, vx, vy) / d (segment start x, y, speed,
        course, a_t, a_n, time since its start)`` (if ``partials``).
    d_anchor : ndarray
        ``(B, M + 1, 4, p)`` written with the derivatives of every segment's start state (if
        ``partials``).
    """
    M = manoeuvres
    k0 = 6 + 2 * M
    anchors = np.empty((M + 1, 4))
    v_start = np.empty(M + 1, dtype=np.complex128)
    starts = np.empty(M + 1)
    p47 = np.empty((4, 7))
    for b in range(theta.shape[0]):
        _anchors(theta[b], M, ref_time, end_time, partials, anchors, v_start, starts,
                 d_anchor[b] if partials else d_anchor[0])
        for i in range(t.shape[0]):
            sg = 0
            for m in range(M):
                if t[i] > theta[b, k0 + m]:
                    sg += 1
            seg[b, i] = sg
            _segment(anchors[sg, 0], anchors[sg, 1], anchors[sg, 2], anchors[sg, 3],
                     v_start[sg], theta[b, 4 + 2 * sg], theta[b, 5 + 2 * sg],
                     t[i] - starts[sg], vals[b, i], par[b, i] if partials else p47, False,
                     partials)


@_jit
def chain(ds: Array, par: Array, seg: Array, idx: Array, d_anchor: Array, manoeuvres: int,
          out: Array) -> None:  # pragma: no cover - compiled
    """Apply the chain rule: write ``d value / d theta`` ``(B, n, p)`` into ``out``.

    Parameters
    ----------
    ds : ndarray
        ``(B, n, 6)`` derivatives of the values with respect to the state.
    par, seg, d_anchor : ndarray
        As written by :func:`piecewise` at the unique times (``(B, nu, 4, 7)``,
        ``(B, nu)``, ``(B, M + 1, 4, p)``).
    idx : ndarray of int
        ``(n,)`` every row's unique time.
    manoeuvres : int
        ``M``.
    out : ndarray
        ``(B, n, p)``.
    """
    M = manoeuvres
    b_count, n, p = out.shape
    w = np.empty(7)
    for b in range(b_count):
        for i in range(n):
            u = idx[i]
            sg = seg[b, u]
            d0, d1, d3, d4 = ds[b, i, 0], ds[b, i, 1], ds[b, i, 3], ds[b, i, 4]
            w[0] = d0
            w[1] = d1
            for k in range(2, 7):
                w[k] = (d0 * par[b, u, 0, k] + d1 * par[b, u, 1, k] + d3 * par[b, u, 2, k]
                        + d4 * par[b, u, 3, k])
            for c in range(p):
                out[b, i, c] = (w[0] * d_anchor[b, sg, 0, c] + w[1] * d_anchor[b, sg, 1, c]
                                + w[2] * d_anchor[b, sg, 2, c] + w[3] * d_anchor[b, sg, 3, c])
            out[b, i, 4 + 2 * sg] += w[4]
            out[b, i, 5 + 2 * sg] += w[5]
            if sg >= 1:
                out[b, i, 5 + 2 * M + sg] -= w[6]


@_jit
def scatter_states(vals: Array, inv: Array, out: Array) -> None:  # pragma: no cover - compiled
    """Write ENU states ``(B, n, 6)`` of the rows from the values at the unique times.

    Parameters
    ----------
    vals : ndarray
        ``(B, nu, 6)`` ``(x, y, speed, course, vx, vy)`` at the unique times.
    inv : ndarray of int
        ``(n,)`` every row's unique time.
    out : ndarray
        ``(B, n, 6)`` written with ``(x, y, 0, vx, vy, 0)`` (the zeros NaN where ``x`` is).
    """
    for b in range(out.shape[0]):
        for i in range(out.shape[1]):
            u = inv[i]
            x = vals[b, u, 0]
            zero = x - x  # NaN where the state is
            out[b, i, 0] = x
            out[b, i, 1] = vals[b, u, 1]
            out[b, i, 2] = zero
            out[b, i, 3] = vals[b, u, 4]
            out[b, i, 4] = vals[b, u, 5]
            out[b, i, 5] = zero
