"""Compiled batch evaluation of the point kinds under affine motion (``numba``).

For point-kind rows under constant-velocity or stationary motion, with independent noise and
at most one nuisance per kind, one call gives per parameter vector the residuals, the nuisance
eliminated in closed form (Golub & Pereyra (1973)), the cost and the projected ``J'J``, ``J'r``
(Kaufman (1975)), without writing the Jacobian.  Sums in a fixed order, no ``fastmath``.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from ..core.arrays import Array, BoolArray, IntArray
from ..measurements.bearing import Bearing, bearing_row
from ..measurements.elevation import Elevation, elevation_row
from ..measurements.frequency import Frequency
from ..measurements.power import Power
from ..measurements.range import Range, range_row
from ..measurements.range_rate import RangeRate, range_rate_row

__all__ = ["BatchPlan", "evaluate_batch", "plan_for"]

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

#: Kind codes of the kernel.
BEARING, ELEVATION, RANGE, RANGE_RATE, FREQUENCY, POWER = 0, 1, 2, 3, 4, 5
_CODES: dict[type, int] = {Bearing: BEARING, Elevation: ELEVATION, Range: RANGE,
                           RangeRate: RANGE_RATE, Frequency: FREQUENCY, Power: POWER}

_TEN_OVER_LN10 = 10.0 / math.log(10.0)
#: The kinds :func:`geometric_row` differentiates (the codes above), by the kinds' own rows.
GEOMETRIC_CODES = {"bearing": BEARING, "elevation": ELEVATION, "range": RANGE,
                   "range_rate": RANGE_RATE}
_bearing_row, _elevation_row, _range_row, _range_rate_row = (
    _jit(f) for f in (bearing_row, elevation_row, range_row, range_rate_row))


@_jit
def geometric_row(code: int, rel: tuple[float, ...]) -> tuple[float, ...]:
    """Give the kind's ``row_gradient`` (value, then its derivatives by ``rel``)."""
    if code == BEARING:
        return _bearing_row(rel)
    if code == ELEVATION:
        return _elevation_row(rel)
    if code == RANGE:
        return _range_row(rel)
    return _range_rate_row(rel)


@_jit
def _values(code: int, param: float, lo: int, hi: int, rel: Array, h: Array, a: Array
            ) -> None:  # pragma: no cover - compiled
    """Write ``h0`` and the design ``a`` of rows ``lo:hi`` of one kind."""
    if code == POWER:  # h0 = -10 n log10 R; a = 1 (the constant's column)
        k = -0.5 * _TEN_OVER_LN10 * param
        for j in range(lo, hi):
            x, y, z = rel[0, j], rel[1, j], rel[2, j]
            h[j] = math.log(x * x + y * y + z * z) * k
            a[j] = 1.0
    else:  # the kinds' own rows; a frequency: h0 = 0, a = -rdot / c (times the carrier)
        frequency = code == FREQUENCY
        scale = -1.0 / param if frequency else 1.0
        for j in range(lo, hi):
            value = geometric_row(RANGE_RATE if frequency else code,
                                  (rel[0, j], rel[1, j], rel[2, j], rel[3, j], rel[4, j],
                                   rel[5, j]))[0]
            h[j] = 0.0 if frequency else value
            a[j] = value * scale if frequency else 0.0


@_jit
def _gradient(code: int, param: float, lo: int, hi: int, rel: Array, w: Array, nu: float,
              g: Array) -> None:  # pragma: no cover - compiled
    """Write the whitened derivatives of rows ``lo:hi``'s predictions by the relative state."""
    if code <= RANGE_RATE:
        # the components that can be non-zero (writing the others cost 12 %)
        live = 2 if code == BEARING else 6 if code == RANGE_RATE else 3
        for j in range(lo, hi):
            row = geometric_row(code, (rel[0, j], rel[1, j], rel[2, j], rel[3, j], rel[4, j],
                                       rel[5, j]))
            for c in range(live):
                g[c, j] = row[1 + c] * w[j]
    elif code == POWER:
        k = -_TEN_OVER_LN10 * param
        for j in range(lo, hi):
            x, y, z = rel[0, j], rel[1, j], rel[2, j]
            s = k / (x * x + y * y + z * z) * w[j]
            g[0, j] = x * s
            g[1, j] = y * s
            g[2, j] = z * s
    else:  # a frequency: the range rate's derivatives times -nu / c
        scale = -nu / param
        for j in range(lo, hi):
            row = _range_rate_row((rel[0, j], rel[1, j], rel[2, j], rel[3, j], rel[4, j],
                                   rel[5, j]))
            s = scale * w[j]
            for c in range(6):
                g[c, j] = row[1 + c] * s


@_jit
def _relative(theta: Array, offset: Array, t_par: IntArray, t_comp: IntArray, t_coef: Array,
              t_one: BoolArray, rel: Array) -> None:  # pragma: no cover - compiled
    """Write the relative states ``(6, n)`` at ``theta`` ``(p,)`` through the affine map."""
    n = rel.shape[1]
    for c in range(6):
        for j in range(n):
            rel[c, j] = offset[c, j]
    for t in range(t_par.shape[0]):
        th, c = theta[t_par[t]], t_comp[t]
        if t_one[t]:
            for j in range(n):
                rel[c, j] += th
        else:
            for j in range(n):
                rel[c, j] += th * t_coef[t, j]


@_jit
def _residuals(u: Array, nu_star: Array, blocks: IntArray, block_param: Array, const: Array,
               angle: BoolArray, w: Array, eliminate: bool, rel: Array, h: Array, a: Array,
               q: Array, r: Array, nu: Array) -> float:  # pragma: no cover - compiled
    """Write one parameter vector's projected residuals, nuisance and unit columns."""
    two_pi = 2.0 * math.pi
    half = 0.0
    for blk in range(blocks.shape[0]):
        lo, hi, code, col = blocks[blk, 0], blocks[blk, 1], blocks[blk, 2], blocks[blk, 3]
        _values(code, block_param[blk], lo, hi, rel, h, a)
        ref = nu_star[col] if col >= 0 else 0.0
        for j in range(lo, hi):
            e = u[j] - h[j] - a[j] * ref
            if angle[j]:
                if e > math.pi:
                    e -= two_pi
                elif e <= -math.pi:
                    e += two_pi
                if e > math.pi or e <= -math.pi:
                    return math.inf
            r[j] = w[j] * e
        if col >= 0:
            nu[col] = ref
        if col >= 0 and eliminate:
            qq = 0.0
            qr = 0.0
            for j in range(lo, hi):
                qv = w[j] * (const[j] + a[j])
                q[j] = qv
                qq += qv * qv
                qr += qv * r[j]
            coef = qr / qq if qq > 0.0 else 0.0
            norm = math.sqrt(qq) if qq > 0.0 else math.inf
            nu[col] = ref + coef
            for j in range(lo, hi):
                r[j] -= q[j] * coef
                q[j] /= norm  # the unit column (zero without weight)
        for j in range(lo, hi):
            half += r[j] * r[j]
    return 0.5 * half


@_jit
def _dot(x: Array, y: Array, lo: int, hi: int) -> float:  # pragma: no cover - compiled
    """Give ``x[lo:hi] . y[lo:hi]`` in four interleaved partial sums (fixed order, no BLAS)."""
    s0 = s1 = s2 = s3 = 0.0
    j = lo
    while j + 4 <= hi:
        s0 += x[j] * y[j]
        s1 += x[j + 1] * y[j + 1]
        s2 += x[j + 2] * y[j + 2]
        s3 += x[j + 3] * y[j + 3]
        j += 4
    while j < hi:
        s0 += x[j] * y[j]
        j += 1
    return (s0 + s1) + (s2 + s3)


@_jit
def _normal(blocks: IntArray, block_param: Array, w: Array, t_par: IntArray, t_comp: IntArray,
            t_coef: Array, t_one: BoolArray, eliminate: bool, rel: Array, q: Array, r: Array,
            nu: Array, g: Array, jac: Array, qj: Array, jtj: Array, jtr: Array
            ) -> None:  # pragma: no cover - compiled
    """Write ``J'J`` and ``J'r`` of one parameter vector's projected whitened Jacobian."""
    p, n = jac.shape
    for blk in range(blocks.shape[0]):
        lo, hi, code, col = blocks[blk, 0], blocks[blk, 1], blocks[blk, 2], blocks[blk, 3]
        _gradient(code, block_param[blk], lo, hi, rel, w, nu[col] if col >= 0 else 0.0, g)
    jac[:, :] = 0.0
    for t in range(t_par.shape[0]):  # the chain rule through the affine map
        i, c = t_par[t], t_comp[t]
        if t_one[t]:
            for j in range(n):
                jac[i, j] += g[c, j]
        else:
            for j in range(n):
                jac[i, j] += g[c, j] * t_coef[t, j]
    for i in range(p):
        jtr[i] = _dot(jac[i], r, 0, n)
        for m in range(i, p):
            jtj[i, m] = _dot(jac[i], jac[m], 0, n)
    for blk in range(blocks.shape[0] if eliminate else 0):
        lo, hi, col = blocks[blk, 0], blocks[blk, 1], blocks[blk, 3]
        if col < 0:
            continue
        qrp = _dot(q, r, lo, hi)
        for i in range(p):
            qj[i] = _dot(q, jac[i], lo, hi)
        for i in range(p):  # Kaufman's projection, on the sums
            jtr[i] -= qj[i] * qrp
            for m in range(i, p):
                jtj[i, m] -= qj[i] * qj[m]
    for i in range(p):
        for m in range(i + 1, p):
            jtj[m, i] = jtj[i, m]


@_jit
def _varpro_batch(theta: Array, u: Array, nu_star: Array, blocks: IntArray,
                  block_param: Array, const: Array, angle: BoolArray, w: Array, offset: Array,
                  t_par: IntArray, t_comp: IntArray, t_coef: Array, t_one: BoolArray,
                  eliminate: bool,
                  derivatives: bool, r_out: Array, nu_out: Array, cost: Array, jtj: Array,
                  jtr: Array) -> int:  # pragma: no cover - compiled
    """Evaluate a batch (see the module and :func:`evaluate_batch`); 1: an angle a turn out."""
    n = u.shape[1]
    p = theta.shape[1]
    rel, g, jac = np.empty((6, n)), np.zeros((6, n)), np.empty((p, n))
    h, a, q, qj = np.empty(n), np.empty(n), np.zeros(n), np.empty(p)
    for b in range(u.shape[0]):
        _relative(theta[b], offset, t_par, t_comp, t_coef, t_one, rel)
        cost[b] = _residuals(u[b], nu_star[b], blocks, block_param, const, angle, w,
                             eliminate, rel, h, a, q, r_out[b], nu_out[b])
        if cost[b] == math.inf:
            return 1
        if derivatives:
            _normal(blocks, block_param, w, t_par, t_comp, t_coef, t_one, eliminate, rel, q,
                    r_out[b], nu_out[b], g, jac, qj, jtj[b], jtr[b])
    return 0


class BatchPlan:
    """The per-row arrays the kernel reads, made once per problem."""

    def __init__(self, blocks: IntArray, block_param: Array, const: Array, angle: BoolArray,
                 w: Array, offset: Array, t_par: IntArray, t_comp: IntArray, t_coef: Array,
                 t_one: BoolArray) -> None:
        self.blocks, self.block_param = blocks, block_param
        self.const, self.angle, self.w, self.offset = const, angle, w, offset
        self.t_par, self.t_comp, self.t_coef, self.t_one = t_par, t_comp, t_coef, t_one


def plan_for(obs: Any, inv_sigma: Array | None, const_design: Array) -> BatchPlan | None:
    """Give the kernel's plan of an observation model, or None where the kernel does not apply."""
    rel_map = obs._rel_map
    if inv_sigma is None or rel_map is None or obs._ref is not None:
        return None
    n = len(obs.meas)
    blocks, params = [], []
    const = np.zeros(n)
    for kind, model in obs.models.items():
        sl, ns = obs.slices[kind], obs.nuisance_slices[kind]
        code = _CODES.get(type(model))
        width = ns.stop - ns.start
        with_nuisance = isinstance(model, Frequency | Power)
        if code is None or width != int(with_nuisance):
            return None  # (a drift, or an unknown exponent: two columns in one kind)
        param = (model.c if isinstance(model, Frequency)
                 else model.exponent if isinstance(model, Power) else 0.0)
        col = ns.start if width else -1
        if width:
            const[sl] = const_design[sl, col]
        blocks.append((sl.start, sl.stop, code, col))
        params.append(param)
    terms = rel_map.terms
    t_coef = np.ones((len(terms), n))
    for t, (_, _, coef) in enumerate(terms):
        if coef is not None:
            t_coef[t] = coef
    return BatchPlan(np.array(blocks, dtype=np.int64).reshape(-1, 4), np.array(params, float),
                     const, np.asarray(obs.angle_mask_grouped, dtype=bool),
                     np.ascontiguousarray(inv_sigma, dtype=float),
                     np.ascontiguousarray(rel_map.offset, dtype=float),
                     np.array([i for i, _, _ in terms], dtype=np.int64),
                     np.array([c for _, c, _ in terms], dtype=np.int64), t_coef,
                     np.array([coef is None for _, _, coef in terms], dtype=bool))


def evaluate_batch(plan: BatchPlan, theta: Array, u: Array, nu_star: Array, eliminate: bool,
                   derivatives: bool) -> tuple[Array, Array, Array, Array, Array] | None:
    """Evaluate a batch by the kernel: residuals, nuisance, cost, ``J'J`` and ``J'r``."""
    b, n = u.shape
    p, k = theta.shape[1], nu_star.shape[1]
    r, nu, cost = np.empty((b, n)), np.empty((b, k)), np.empty(b)
    jtj, jtr = np.empty((b, p, p)), np.empty((b, p))
    bad = _varpro_batch(np.ascontiguousarray(theta), np.ascontiguousarray(u),
                        np.ascontiguousarray(nu_star), plan.blocks, plan.block_param,
                        plan.const, plan.angle, plan.w, plan.offset, plan.t_par, plan.t_comp,
                        plan.t_coef, plan.t_one, eliminate, derivatives, r, nu, cost, jtj, jtr)
    return None if bad else (r, nu, cost, jtj, jtr)
