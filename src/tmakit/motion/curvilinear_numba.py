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
from numpy.typing import NDArray

from ..arrays import Array, IntArray

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
    # abs(g) + abs(r) >= _SERIES_BELOW, decided without the hypotenuse where its bounds do
    ar, ai, ar_ = abs(g.real), abs(g.imag), abs(r)
    if (max(ar, ai) + ar_ >= _SERIES_BELOW
            or (ar + ai + ar_ >= _SERIES_BELOW and abs(g) + ar_ >= _SERIES_BELOW)):
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


_NAN_C = complex(np.nan, np.nan)


@_inline
def _over(z: complex, d: float) -> complex:  # pragma: no cover - compiled
    """Give ``z / d`` for a real ``d > 0``: complex division's result with two divisions.

    Complex division (CPython's algorithm, numba's too) by ``d + 0i`` forms ``(Re z + Im z *
    0) / d`` and ``(Im z - Re z * 0) / d``: the same values for finite ``z``.
    """
    return complex(z.real / d, z.imag / d)


@_inline
def _straight(x: float, y: float, v0: float, phi0: float, V0: complex, s: float
              ) -> tuple:  # pragma: no cover - compiled
    """Give :func:`_segment`'s result for a straight segment (``a_t = a_n = 0``).

    The closed form with ``F = E = 1``, ``dF/dg = 1/2``, ``dF/dr = 0``, every product that
    is left formed as there: the same values without the logarithm, the exponential and the
    division (held accelerations are common in the selection's fits).
    """
    sv = s / v0
    disp = V0 * s
    q = V0 * sv
    return (True, (x + disp.imag, y + disp.real, v0, phi0, V0.imag, V0.real),
            (q, 1j * disp, q * s * 0.5, 1j * q * s * 0.5, V0),
            (_over(V0, v0), 1j * V0, q, 1j * q, 0.0j), (0.0, 0.0, 0.0, 0.0))


@_inline
def _segment(x: float, y: float, v0: float, phi0: float, V0: complex, a_t: float,
             a_n: float, s: float, state_rows: bool) -> tuple:  # pragma: no cover - compiled
    """Propagate one segment (``ok`` False, NaN everywhere, if the speed dies).

    Give ``(ok, vals, dz, dv, st)``: ``vals`` is ``(x, y, speed, course, vx, vy)``; ``dz``
    and ``dv`` the derivatives of the position and of the velocity, each as the complex
    ``North + i East``, with respect to ``(v0, phi0, a_t, a_n, s)`` (with respect to the
    start position they are the unit matrix and zero); ``st`` (with ``state_rows``) the
    course's derivatives with respect to ``(v0, a_t, a_n, s)``.  ``V0`` is the start
    velocity ``v0 exp(i phi0)``.  Scalars are returned, not written into arrays: an array
    handed to an inner function costs numba more per sample than the closed form itself.
    """
    if not (v0 > 0.0 and v0 + a_t * s > 0.0):
        nan, nc = np.nan, _NAN_C
        return (False, (nan, nan, nan, nan, nan, nan), (nc, nc, nc, nc, nc),
                (nc, nc, nc, nc, nc), (nan, nan, nan, nan))
    if a_t == 0.0 and a_n == 0.0 and not state_rows:
        return _straight(x, y, v0, phi0, V0, s)
    sv = s / v0
    r = a_t * sv
    c = complex(a_t, a_n)
    g = c * sv
    L, dL = _log1p_over(r)
    E = cmath.exp(g * L)
    F, Fg, Fr = _f_terms(g, r, L, dL, E)
    disp = V0 * s * F
    V = V0 * E
    vals = (x + disp.imag, y + disp.real, v0 + a_t * s, phi0 + a_n * sv * L, V.imag, V.real)
    q = V0 * sv
    dz = (q * (F - g * Fg - r * Fr), 1j * disp, q * s * (Fg + Fr), 1j * q * s * Fg, V)
    inv1r = 1.0 / (1.0 + r)
    if state_rows:
        an_v = a_n / v0 * inv1r
        return (True, vals, dz, dz, (-an_v * sv, a_n * sv * sv * dL, sv * L, an_v))
    Vsv = V * sv
    Vc = V * c
    dv = (_over(V, v0) * (1.0 - g * inv1r), 1j * V, Vsv * (L + g * dL), 1j * Vsv * L,
          _over(Vc, v0) * inv1r)
    return (True, vals, dz, dv, (0.0, 0.0, 0.0, 0.0))


@_inline
def _write(out: tuple, vals: Array, par: Array, b: int, i: int, partials: bool,
           state_rows: bool, s: float, a_t: float) -> None:  # pragma: no cover - compiled
    """Write :func:`_segment`'s result into ``vals[b, i]`` (6,) and ``par[b, i]`` (4, 7).

    ``par`` (if ``partials``): the derivatives with respect to ``(x0, y0, v0, phi0, a_t,
    a_n, s)`` of ``x, y, speed, course`` (``state_rows``) or of ``x, y, vx, vy``.
    """
    ok, v6, dz, dv, st = out
    for k in range(6):
        vals[b, i, k] = v6[k]
    if not partials:
        return
    if not ok:
        for k in range(4):
            for j in range(7):
                par[b, i, k, j] = np.nan
        return
    par[b, i, 0, 0] = par[b, i, 1, 1] = 1.0
    par[b, i, 0, 1] = par[b, i, 1, 0] = 0.0
    for k in range(5):
        par[b, i, 0, 2 + k] = dz[k].imag
        par[b, i, 1, 2 + k] = dz[k].real
    par[b, i, 2, 0] = par[b, i, 2, 1] = par[b, i, 3, 0] = par[b, i, 3, 1] = 0.0
    if state_rows:
        par[b, i, 2, 3] = par[b, i, 2, 5] = 0.0
        par[b, i, 2, 2] = 1.0
        par[b, i, 2, 4] = s
        par[b, i, 2, 6] = a_t
        par[b, i, 3, 2] = st[0]
        par[b, i, 3, 3] = 1.0
        par[b, i, 3, 4] = st[1]
        par[b, i, 3, 5] = st[2]
        par[b, i, 3, 6] = st[3]
        return
    for k in range(5):
        par[b, i, 2, 2 + k] = dv[k].imag
        par[b, i, 3, 2 + k] = dv[k].real


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
             anchors: Array, v_start: NDArray[np.complex128], starts: Array,
             d_anchor: Array) -> None:  # pragma: no cover - compiled
    """Chain one parameter vector's segment start states forwards (NaN outside the domain).

    Writes ``anchors`` (M + 1, 4), their start velocities ``v_start`` (complex), the start
    times ``starts`` (M + 1,) and, if ``partials``, ``d_anchor`` (M + 1, 4, p).
    """
    k0 = 6 + 2 * M
    v6 = np.empty((1, 1, 6))
    p47 = np.empty((1, 1, 4, 7))
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
        dt = starts[m] - starts[m - 1]
        a_t = theta[2 + 2 * m]
        out = _segment(anchors[m - 1, 0], anchors[m - 1, 1], anchors[m - 1, 2],
                       anchors[m - 1, 3], v_start[m - 1], a_t, theta[3 + 2 * m], dt, True)
        _write(out, v6, p47, 0, 0, partials, True, dt, a_t)
        anchors[m, :] = v6[0, 0, :4]
        v_start[m] = anchors[m, 2] * cmath.exp(1j * anchors[m, 3])
        if partials:
            _derive_anchor(p47[0, 0], d_anchor[m - 1], m, k0, d_anchor[m])
    if not valid:
        anchors[:, :] = np.nan


@_jit
def piecewise(theta: Array, t: Array, manoeuvres: int, ref_time: float, end_time: float,
              partials: bool, seg: IntArray, vals: Array, par: Array,
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
    for b in range(theta.shape[0]):
        _anchors(theta[b], M, ref_time, end_time, partials, anchors, v_start, starts,
                 d_anchor[b] if partials else d_anchor[0])
        for i in range(t.shape[0]):
            sg = 0
            for m in range(M):
                if t[i] > theta[b, k0 + m]:
                    sg += 1
            seg[b, i] = sg
            dt = t[i] - starts[sg]
            a_t = theta[b, 4 + 2 * sg]
            out = _segment(anchors[sg, 0], anchors[sg, 1], anchors[sg, 2], anchors[sg, 3],
                           v_start[sg], a_t, theta[b, 5 + 2 * sg], dt, False)
            _write(out, vals, par, b, i, partials, False, dt, a_t)


@_jit
def chain(ds: Array, par: Array, seg: IntArray, idx: IntArray, d_anchor: Array, manoeuvres: int,
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
    k0 = 6 + 2 * M
    for b in range(b_count):
        da = d_anchor[b]
        for i in range(n):
            u = idx[i]
            sg = seg[b, u]
            d0, d1, d3, d4 = ds[b, i, 0], ds[b, i, 1], ds[b, i, 3], ds[b, i, 4]
            pu = (par[b, u, 0, 2], par[b, u, 1, 2], par[b, u, 2, 2], par[b, u, 3, 2],
                  par[b, u, 0, 3], par[b, u, 1, 3], par[b, u, 2, 3], par[b, u, 3, 3],
                  par[b, u, 0, 4], par[b, u, 1, 4], par[b, u, 2, 4], par[b, u, 3, 4],
                  par[b, u, 0, 5], par[b, u, 1, 5], par[b, u, 2, 5], par[b, u, 3, 5],
                  par[b, u, 0, 6], par[b, u, 1, 6], par[b, u, 2, 6], par[b, u, 3, 6])
            w = (d0 * pu[0] + d1 * pu[1] + d3 * pu[2] + d4 * pu[3],
                 d0 * pu[4] + d1 * pu[5] + d3 * pu[6] + d4 * pu[7],
                 d0 * pu[8] + d1 * pu[9] + d3 * pu[10] + d4 * pu[11],
                 d0 * pu[12] + d1 * pu[13] + d3 * pu[14] + d4 * pu[15],
                 d0 * pu[16] + d1 * pu[17] + d3 * pu[18] + d4 * pu[19])
            # a segment's start state depends on (x, y, speed, course), the accelerations
            # and change-over times before it only: the other columns are 0
            for c in range(4 + 2 * sg):
                out[b, i, c] = (d0 * da[sg, 0, c] + d1 * da[sg, 1, c]
                                + w[0] * da[sg, 2, c] + w[1] * da[sg, 3, c])
            for c in range(4 + 2 * sg, k0):
                out[b, i, c] = 0.0
            for c in range(k0, k0 + sg):
                out[b, i, c] = (d0 * da[sg, 0, c] + d1 * da[sg, 1, c]
                                + w[0] * da[sg, 2, c] + w[1] * da[sg, 3, c])
            for c in range(k0 + sg, p):
                out[b, i, c] = 0.0
            out[b, i, 4 + 2 * sg] += w[2]
            out[b, i, 5 + 2 * sg] += w[3]
            if sg >= 1:
                out[b, i, 5 + 2 * M + sg] -= w[4]


@_jit
def _column_runs(cols: IntArray, M: int) -> tuple:  # pragma: no cover - compiled
    """Give, per segment of a row, where :func:`chain_columns` writes what.

    ``cols`` increase, so the output columns of the parameters a segment's start state
    depends on are two runs, ``[0, lo)`` and ``[mid, hi)``, the others are 0; ``own`` are the
    columns of the segment's own ``a_t``, ``a_n`` and change-over time (-1: not wanted).
    """
    k0 = 6 + 2 * M
    lo = np.zeros(M + 1, dtype=np.int64)
    mid = np.zeros(M + 1, dtype=np.int64)
    hi = np.zeros(M + 1, dtype=np.int64)
    own = np.full((M + 1, 3), -1, dtype=np.int64)
    for sg in range(M + 1):
        for j in range(cols.size):
            c = cols[j]
            lo[sg] += c < 4 + 2 * sg
            mid[sg] += c < k0
            hi[sg] += c < k0 + sg
            for k, ck in enumerate((4 + 2 * sg, 5 + 2 * sg, k0 + sg - 1 if sg else -1)):
                if c == ck:
                    own[sg, k] = j
    return lo, mid, hi, own


@_jit
def chain_columns(ds: Array, par: Array, seg: IntArray, idx: IntArray, d_anchor: Array,
                  manoeuvres: int, cols: IntArray, out: Array) -> None:  # pragma: no cover
    """Apply the chain rule for the parameters ``cols`` only, into ``out`` ``(q, B, n)``.

    Column ``j`` is :func:`chain`'s column ``cols[j]``, the same operations in the same order
    (the same bits); the others (parameters held by a fit) are not formed.

    Parameters
    ----------
    ds, par, seg, idx, d_anchor : ndarray
        As for :func:`chain`.
    manoeuvres : int
        ``M``.
    cols : ndarray of int
        ``(q,)`` the parameters, increasing.
    out : ndarray
        ``(q, B, n)`` (column-major over the rows: each parameter's column contiguous).
    """
    M = manoeuvres
    q, b_count, n = out.shape
    lo, mid, hi, own = _column_runs(cols, M)
    sel = np.empty((M + 1, 4, q))
    for b in range(b_count):
        for sg in range(M + 1):  # the start states' derivatives, free columns only
            for r in range(4):
                for j in range(q):
                    sel[sg, r, j] = d_anchor[b, sg, r, cols[j]]
        for i in range(n):
            u = idx[i]
            sg = seg[b, u]
            d0, d1, d3, d4 = ds[b, i, 0], ds[b, i, 1], ds[b, i, 3], ds[b, i, 4]
            w0 = d0 * par[b, u, 0, 2] + d1 * par[b, u, 1, 2] + d3 * par[b, u, 2, 2] \
                + d4 * par[b, u, 3, 2]
            w1 = d0 * par[b, u, 0, 3] + d1 * par[b, u, 1, 3] + d3 * par[b, u, 2, 3] \
                + d4 * par[b, u, 3, 3]
            j0, j1, j2 = lo[sg], mid[sg], hi[sg]
            for j in range(j0):
                out[j, b, i] = (d0 * sel[sg, 0, j] + d1 * sel[sg, 1, j]
                                + w0 * sel[sg, 2, j] + w1 * sel[sg, 3, j])
            for j in range(j0, j1):
                out[j, b, i] = 0.0
            for j in range(j1, j2):
                out[j, b, i] = (d0 * sel[sg, 0, j] + d1 * sel[sg, 1, j]
                                + w0 * sel[sg, 2, j] + w1 * sel[sg, 3, j])
            for j in range(j2, q):
                out[j, b, i] = 0.0
            j = own[sg, 0]
            if j >= 0:
                out[j, b, i] += (d0 * par[b, u, 0, 4] + d1 * par[b, u, 1, 4]
                                 + d3 * par[b, u, 2, 4] + d4 * par[b, u, 3, 4])
            j = own[sg, 1]
            if j >= 0:
                out[j, b, i] += (d0 * par[b, u, 0, 5] + d1 * par[b, u, 1, 5]
                                 + d3 * par[b, u, 2, 5] + d4 * par[b, u, 3, 5])
            j = own[sg, 2]
            if j >= 0:
                out[j, b, i] -= (d0 * par[b, u, 0, 6] + d1 * par[b, u, 1, 6]
                                 + d3 * par[b, u, 2, 6] + d4 * par[b, u, 3, 6])


@_jit
def scatter_states(vals: Array, inv: IntArray, out: Array) -> None:  # pragma: no cover - compiled
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


@_jit
def scatter_relative(vals: Array, inv: IntArray, sensor: Array, out: Array
                     ) -> None:  # pragma: no cover - compiled
    """Write :func:`scatter_states`' states minus ``sensor`` (the same bits as after).

    Parameters
    ----------
    vals, inv : ndarray
        As for :func:`scatter_states`.
    sensor : ndarray
        ``(n, 6)`` the sensor's states at the rows (m, m/s).
    out : ndarray
        ``(B, n, 6)`` written with the relative states.
    """
    for b in range(out.shape[0]):
        for i in range(out.shape[1]):
            u = inv[i]
            x = vals[b, u, 0]
            zero = x - x
            out[b, i, 0] = x - sensor[i, 0]
            out[b, i, 1] = vals[b, u, 1] - sensor[i, 1]
            out[b, i, 2] = zero - sensor[i, 2]
            out[b, i, 3] = vals[b, u, 4] - sensor[i, 3]
            out[b, i, 4] = vals[b, u, 5] - sensor[i, 4]
            out[b, i, 5] = zero - sensor[i, 5]
