"""Curvilinear propagation, its chain rule and its normal equations, compiled.

One segment's closed form and derivatives (:func:`propagate_with_partials`), the chaining of
change-over states (:func:`piecewise`) and :class:`~tmakit.motion.curvilinear.ForwardPiecewise`'s
chain rule and ``J'J`` by segments.  float64, no ``fastmath``, sums in a fixed order.

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

import cmath
import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array, IntArray

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
# Inlined into the loops over the samples (as a call, every array argument's reference count
# would change twice per sample: more than the arithmetic).
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

_SERIES_BELOW = 1e-3     # |g| + |r| below which F comes from its series
_SERIES_TERMS = 6
_L_SERIES_BELOW = 1e-3   # |r| below which L(r), L'(r) come from their series
_L_TERMS = 6
_INV_FACTORIAL = tuple(1.0 / math.factorial(n + 1) for n in range(_SERIES_TERMS))


@_inline
def _log1p_over(r: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """Give ``L(r) = log1p(r) / r`` and ``L'(r)`` (a power series near 0)."""
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
    """Give ``z / d`` for a real ``d > 0``: complex division's result with two divisions."""
    return complex(z.real / d, z.imag / d)


@_inline
def _straight(x: float, y: float, v0: float, phi0: float, V0: complex, s: float
              ) -> tuple:  # pragma: no cover - compiled
    """Give :func:`_segment`'s result for a straight segment (``a_t = a_n = 0``)."""
    sv = s / v0
    disp = V0 * s
    q = V0 * sv
    return (True, (x + disp.imag, y + disp.real, v0, phi0, V0.imag, V0.real),
            (q, 1j * disp, q * s * 0.5, 1j * q * s * 0.5, V0),
            (_over(V0, v0), 1j * V0, q, 1j * q, 0.0j), (0.0, 0.0, 0.0, 0.0))


@_inline
def _segment(x: float, y: float, v0: float, phi0: float, V0: complex, a_t: float,
             a_n: float, s: float, state_rows: bool) -> tuple:  # pragma: no cover - compiled
    """Propagate one segment (``ok`` False, NaN everywhere, if the speed dies)."""
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
    """Write :func:`_segment`'s result into ``vals[b, i]`` (6,) and ``par[b, i]`` (4, 7)."""
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
def _derive_anchor(p47: Array, prev: Array, seg_acc: int, t_to: int, t_from: int, d: Array
                   ) -> None:  # pragma: no cover - compiled
    """Write into ``d`` (4, p) the derivatives of an anchor moved from ``prev``'s."""
    for i in range(4):
        for c in range(d.shape[1]):
            acc = 0.0
            for j in range(4):
                acc += p47[i, j] * prev[j, c]
            d[i, c] = acc
        d[i, 4 + 2 * seg_acc] += p47[i, 4]
        d[i, 5 + 2 * seg_acc] += p47[i, 5]
        d[i, t_to] += p47[i, 6]
        if t_from >= 0:
            d[i, t_from] -= p47[i, 6]


@_jit
def _link(theta: Array, frm: int, to: int, seg_acc: int, t_to: int, t_from: int,
          partials: bool, anchors: Array, v_start: NDArray[np.complex128], starts: Array,
          d_anchor: Array, v6: Array, p47: Array) -> None:  # pragma: no cover - compiled
    """Set anchor ``to``: anchor ``frm`` moved to ``theta[t_to]`` by segment ``seg_acc``."""
    dt = theta[t_to] - starts[frm]
    a_t = theta[4 + 2 * seg_acc]
    out = _segment(anchors[frm, 0], anchors[frm, 1], anchors[frm, 2], anchors[frm, 3],
                   v_start[frm], a_t, theta[5 + 2 * seg_acc], dt, True)
    _write(out, v6, p47, 0, 0, partials, True, dt, a_t)
    starts[to] = theta[t_to]
    for j in range(4):  # (element by element: no array assignment's shape check to compile)
        anchors[to, j] = v6[0, 0, j]
    v_start[to] = anchors[to, 2] * cmath.exp(1j * anchors[to, 3])
    if partials:
        _derive_anchor(p47[0, 0], d_anchor[frm], seg_acc, t_to, t_from, d_anchor[to])


@_jit
def _anchors(theta: Array, M: int, ref_time: float, end_time: float, anywhere: bool,
             partials: bool, anchors: Array, v_start: NDArray[np.complex128], starts: Array,
             d_anchor: Array) -> None:  # pragma: no cover - compiled
    """Chain one parameter vector's anchors (NaN outside the domain)."""
    k0 = 6 + 2 * M
    v6 = np.empty((1, 1, 6))
    p47 = np.empty((1, 1, 4, 7))
    valid = True
    ref = 0
    for m in range(1, M + 1):
        if m > 1:
            valid = valid and theta[k0 + m - 1] > theta[k0 + m - 2]
        if anywhere:
            valid = valid and math.isfinite(theta[k0 + m - 1])
            if theta[k0 + m - 1] < ref_time:
                ref += 1
    if not anywhere and M:
        valid = valid and ref_time < theta[k0] and theta[k0 + M - 1] < end_time
    starts[ref] = ref_time
    for j in range(4):
        anchors[ref, j] = theta[j]
    if partials:
        d_anchor[ref, :, :] = 0.0
        for j in range(4):
            d_anchor[ref, j, j] = 1.0
    v_start[ref] = anchors[ref, 2] * cmath.exp(1j * anchors[ref, 3])
    for m in range(ref + 1, M + 1):  # forwards: t_m starts segment m
        _link(theta, m - 1, m, m - 1, k0 + m - 1, k0 + m - 2 if m - 1 > ref else -1,
              partials, anchors, v_start, starts, d_anchor, v6, p47)
    for m in range(ref - 1, -1, -1):  # backwards: t_{m+1} ends segment m
        _link(theta, m + 1, m, m + 1, k0 + m, k0 + m + 1 if m + 1 < ref else -1,
              partials, anchors, v_start, starts, d_anchor, v6, p47)
    if not valid:
        anchors[:, :] = np.nan


@_jit
def _piecewise_kernel(theta: Array, t: Array, manoeuvres: int, ref_time: float,
                      end_time: float, anywhere: bool, partials: bool, seg: IntArray,
                      vals: Array, par: Array, d_anchor: Array
                      ) -> None:  # pragma: no cover - compiled
    """Write every sample's segment, values and partials (:func:`piecewise`)."""
    M = manoeuvres
    k0 = 6 + 2 * M
    anchors = np.empty((M + 1, 4))
    v_start = np.empty(M + 1, dtype=np.complex128)
    starts = np.empty(M + 1)
    for b in range(theta.shape[0]):
        _anchors(theta[b], M, ref_time, end_time, anywhere, partials, anchors, v_start,
                 starts, d_anchor[b] if partials else d_anchor[0])
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
def _column_runs(cols: IntArray, M: int) -> tuple:  # pragma: no cover - compiled
    """Give, per segment of a row, where :func:`_chain_columns_kernel` writes what."""
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
def _chain_columns_kernel(ds: Array, par: Array, seg: IntArray, idx: IntArray,
                          d_anchor: Array, manoeuvres: int, cols: IntArray, out: Array
                          ) -> None:  # pragma: no cover - compiled
    """Write ``d value / d theta``, columns ``cols``, into ``out`` ``(q, B, n)`` (:func:`chain`)."""
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
def _scatter_kernel(vals: Array, inv: Array, sensor: Array, out: Array
                    ) -> None:  # pragma: no cover - compiled
    """Write ``(x, y, 0, vx, vy, 0)`` of every row minus ``sensor`` (zeros NaN where ``x`` is)."""
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


@_inline
def _inputs(ds: Array, par: Array, d_anchor: Array, b: int, i: int, u: int, sg: int,
            own: int, w: float, v: Array) -> None:  # pragma: no cover - compiled
    """Write row ``i``'s whitened derivatives by its segment's inputs into ``v``."""
    d0, d1, d3, d4 = ds[b, i, 0] * w, ds[b, i, 1] * w, ds[b, i, 3] * w, ds[b, i, 4] * w
    v[0] = d0
    v[1] = d1
    for k in range(2, 7):
        v[k] = d0 * par[b, u, 0, k] + d1 * par[b, u, 1, k] + d3 * par[b, u, 2, k] \
            + d4 * par[b, u, 3, k]
    if own >= 0:
        v[6] = (d0 * d_anchor[b, sg, 0, own] + d1 * d_anchor[b, sg, 1, own]
                + v[2] * d_anchor[b, sg, 2, own] + v[3] * d_anchor[b, sg, 3, own]) - v[6]
    else:
        v[6] = 0.0


@_jit
def _inputs_by_params(d_anchor: Array, b: int, sg: int, manoeuvres: int, d: Array
                      ) -> None:  # pragma: no cover - compiled
    """Write segment ``sg``'s ``D_s`` ``(7, p)`` into ``d`` (see :func:`_inputs` for row 6)."""
    p = d.shape[1]
    k0 = 6 + 2 * manoeuvres
    d[:, :] = 0.0
    for c in range(p):  # the start state depends on earlier segments' parameters only
        if c < 4 + 2 * sg or k0 <= c < k0 + sg - 1:
            for r in range(4):
                d[r, c] = d_anchor[b, sg, r, c]
    d[4, 4 + 2 * sg] = 1.0
    d[5, 5 + 2 * sg] = 1.0
    if sg >= 1:
        d[6, k0 + sg - 1] = 1.0


@_jit
def _segment_normal_kernel(ds: Array, r: Array, w: Array, par: Array, seg: IntArray,
                           idx: IntArray, d_anchor: Array, manoeuvres: int, runs: IntArray,
                           jtj: Array, jtr: Array) -> None:  # pragma: no cover - compiled
    """Write ``J'J`` and ``J'r`` of the whitened Jacobian of ``runs`` (:func:`segment_normal`)."""
    m1 = manoeuvres + 1
    p = jtj.shape[1]
    k0 = 6 + 2 * manoeuvres
    s = np.empty((m1, 7, 7))
    g = np.empty((m1, 7))
    v = np.empty(7)
    d = np.empty((7, p))
    dv = np.empty((7, p))
    for j in range(runs.shape[0]):
        b = runs[j]
        s[:] = 0.0
        g[:] = 0.0
        for i in range(ds.shape[1]):
            u = idx[i]
            sg = seg[b, u]
            _inputs(ds, par, d_anchor, b, i, u, sg, k0 + sg - 1 if sg else -1, w[i], v)
            ri = r[b, i]
            for k in range(7):
                vk = v[k]
                g[sg, k] += vk * ri
                for m in range(k, 7):
                    s[sg, k, m] += vk * v[m]
        jtj[j] = 0.0
        jtr[j] = 0.0
        for sg in range(m1):
            _inputs_by_params(d_anchor, b, sg, manoeuvres, d)
            _add_segment(s[sg], g[sg], d, dv, jtj[j], jtr[j])


@_jit
def _add_segment(s: Array, g: Array, d: Array, dv: Array, jtj: Array, jtr: Array
                 ) -> None:  # pragma: no cover - compiled
    """Add ``D' S D`` to ``jtj`` and ``D' g`` to ``jtr`` (``S``'s upper triangle summed)."""
    p = d.shape[1]
    for k in range(7):
        for m in range(k + 1, 7):
            s[m, k] = s[k, m]
    dv[:, :] = 0.0
    for k in range(7):  # S D
        for m in range(7):
            skm = s[k, m]
            if skm != 0.0:
                for c in range(p):
                    dv[k, c] += skm * d[m, c]
    for c in range(p):  # D' (S D), D' g
        for k in range(7):
            dkc = d[k, c]
            if dkc != 0.0:
                jtr[c] += dkc * g[k]
                for e in range(p):
                    jtj[c, e] += dkc * dv[k, e]


@_jit
def _segments_kernel(x: Array, y: Array, v0: Array, phi0: Array, a_t: Array, a_n: Array,
                     s: Array, partials: bool, vals: Array,
                     par: Array) -> None:  # pragma: no cover - compiled
    """Write each sample's values ``(1, n, 6)`` and, with ``partials``, its ``(1, n, 6, 7)``."""
    for i in range(x.shape[0]):
        V0 = v0[i] * cmath.exp(1j * phi0[i])
        out = _segment(x[i], y[i], v0[i], phi0[i], V0, a_t[i], a_n[i], s[i], False)
        if partials:  # position, speed and course as the anchors have them, then the velocity
            _write(_segment(x[i], y[i], v0[i], phi0[i], V0, a_t[i], a_n[i], s[i], True), vals,
                   par, 0, i, True, True, s[i], a_t[i])
            dv = out[3]
            for k in range(7):
                par[0, i, 4, k] = 0.0 if k < 2 else dv[k - 2].imag
                par[0, i, 5, k] = 0.0 if k < 2 else dv[k - 2].real
            if not out[0]:
                par[0, i, 4:, :] = np.nan
        _write(out, vals, par, 0, i, False, False, s[i], a_t[i])


def propagate_with_partials(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
                            a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike,
                            partials: bool = True) -> tuple[Array, Array | None]:
    """Propagate one curvilinear segment by ``dt`` s (any sign; eq. 1); the inputs broadcast."""
    args = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                 for a in (x, y, speed, course, a_t, a_n, dt)))
    shape = args[0].shape
    x0, y0, v0, phi0, at, an, s = (np.ascontiguousarray(a.reshape(-1)) for a in args)
    vals = np.empty((1, s.shape[0], 6))
    par = np.empty((1, s.shape[0], 6, 7)) if partials else np.empty((1, 1, 6, 7))
    _segments_kernel(x0, y0, v0, phi0, at, an, s, partials, vals, par)
    return vals.reshape(*shape, 6), (par.reshape(*shape, 6, 7) if partials else None)


def piecewise(theta: Array, t: Array, manoeuvres: int, ref_time: float, end_time: float,
              partials: bool, anywhere: bool = False
              ) -> tuple[IntArray, Array, Array | None, Array | None]:
    """Propagate a batch of piecewise curvilinear trajectories to the times ``t``."""
    theta = np.ascontiguousarray(theta, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    b, p = theta.shape
    seg = np.empty((b, t.size), dtype=np.int64)
    vals = np.empty((b, t.size, 6))
    par = np.empty((b, t.size, 4, 7)) if partials else np.empty((1, 1, 4, 7))
    d_anchor = np.empty((b, manoeuvres + 1, 4, p)) if partials else np.empty((1, 1, 4, p))
    _piecewise_kernel(theta, t, manoeuvres, ref_time, end_time, anywhere, partials, seg, vals,
                      par, d_anchor)
    return seg, vals, (par if partials else None), (d_anchor if partials else None)


def _rows(ds: Array, idx: IntArray | None) -> tuple[int, int, IntArray]:
    """Give the batch size, the rows and every row's unique time."""
    b, n = ds.shape[:2]
    return b, n, (np.arange(n) if idx is None else np.ascontiguousarray(idx, dtype=np.int64))


def chain(ds: Array, par: Array, seg: IntArray, idx: IntArray | None, d_anchor: Array,
          manoeuvres: int, columns: NDArray[np.int64] | None = None) -> Array:
    """Give ``d value / d theta`` ``(B, n, p)`` (or its ``columns``) from ``d value / d state``."""
    b, n, rows = _rows(ds, idx)
    cols = (np.arange(d_anchor.shape[-1]) if columns is None
            else np.ascontiguousarray(columns, dtype=np.int64))
    # each column contiguous over the rows: the layout of a column selection of the whole
    # (``jac[:, :, free]``), which the solver's J'J then reads as it is
    out = np.empty((cols.size, b, n))
    _chain_columns_kernel(np.asarray(ds, dtype=float), par, seg, rows, d_anchor, manoeuvres,
                          cols, out)
    return out.transpose(1, 2, 0)


def segment_normal(ds: Array, r: Array, w: Array, par: Array, seg: IntArray,
                   idx: IntArray | None, d_anchor: Array, manoeuvres: int,
                   runs: NDArray[np.int64] | None = None
                   ) -> tuple[Array, Array]:
    """Give ``J'J`` and ``J'r`` of the whitened Jacobian by segments, the Jacobian not formed."""
    b, _, rows = _rows(ds, idx)
    runs = np.arange(b) if runs is None else np.ascontiguousarray(runs, dtype=np.int64)
    p = d_anchor.shape[-1]
    jtj, jtr = np.empty((runs.size, p, p)), np.empty((runs.size, p))
    # (ds read in its own layout: the observation model's is component-major, no copy made)
    _segment_normal_kernel(np.asarray(ds, dtype=float), np.ascontiguousarray(r),
                           np.ascontiguousarray(w, dtype=float), par, seg, rows, d_anchor,
                           manoeuvres, runs, jtj, jtr)
    return jtj, jtr


def scatter_states(vals: Array, inv: IntArray, sensor: Array | None = None) -> Array:
    """Give ENU states ``(B, n, 6)`` of the rows from the values at the unique times."""
    out = np.empty((vals.shape[0], inv.shape[0], 6))
    # (minus zeros: the same bits, -0.0 and NaN included)
    sensor = np.zeros((inv.shape[0], 6)) if sensor is None else sensor
    _scatter_kernel(vals, np.ascontiguousarray(inv, dtype=np.int64),
                    np.ascontiguousarray(sensor, dtype=float), out)
    return out
