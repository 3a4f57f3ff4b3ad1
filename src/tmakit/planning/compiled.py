"""The planner's compiled code (``numba``): ``Gamma`` over a cloud, ``J^{-1}``, a whole decision.

``Gamma`` of planar bearing, range and range-rate plans is written in closed form: weighted sums
over the cloud of products of ``1/r`` and the bearing rate ``q`` (:data:`PRODUCTS`), combined by
constant coefficients of ``W = R^{-1}``.
"""

from __future__ import annotations

import numba
import numpy as np

from ..core.arrays import Array
from ..observation.varpro_compiled import geometric_row
from ..sensors.tracks import E1_COEFF, E2_COEFF, SERIES_BELOW, SERIES_TERMS
from .measurement_plan import SensorPlan

#: The products of ``1/r`` and the bearing rate ``q`` the kernels sum.
PRODUCTS = ("ir2", "irq", "qq", "ir", "q")
#: Rows of the general kernel's output: ``E[c2]``, ``E[cs]``, then per product ``g``
#: ``E[g]``, ``E[g c2]``, ``E[g cs]``.
ROWS = 2 + 3 * len(PRODUCTS)
PLANAR_KINDS = frozenset({"bearing", "range", "range_rate"})
#: The coefficients of each product in ``(A, B, E)`` (names of :func:`_coefficients`).
_PRODUCT_COEFFICIENTS = (("A_rr", None, None), ("A_rq", None, None), ("A_qq", None, None),
                         (None, "B_r", "E_r"), (None, "B_q", "E_q"))
#: The basis packed for the kernels: product names, coefficients (P, 3) in ``A``, ``B``,
#: ``E``, and the constants ``D``, ``G``, ``F``.
Packed = tuple[list[str], Array, Array]


def spd_inverse(information: Array) -> Array | None:
    """Return ``J^{-1}`` (..., n, n) of positive-definite information matrices."""
    info = np.ascontiguousarray(information, dtype=float)
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    out = np.empty_like(flat)
    if not spd_inverse_stack(flat, out):
        return None
    return out.reshape(info.shape)


def planar_plan(plan: SensorPlan) -> bool:
    """Tell whether the closed form applies to the plan: 2-D, planar kinds, no options."""
    return (plan.dim == 2 and set(plan.kinds) <= PLANAR_KINDS and not plan.options
            and not plan.nuisance)


def supports_planar(plan: SensorPlan, sensor_states: Array) -> bool:
    """Tell whether the closed form applies: a planar plan, every sensor at ``z = 0``."""
    return planar_plan(plan) and not np.any(sensor_states[..., 2])


def compiled_basis(plan: SensorPlan) -> Packed:
    """Return the plan's planar basis packed for the compiled kernels (kept per plan noise)."""
    sigmas = np.asarray(plan.sigmas, dtype=float)
    cov = None if plan.covariance is None else np.asarray(plan.covariance, dtype=float)
    key = (tuple(plan.kinds), sigmas.tobytes(), None if cov is None else cov.tobytes())
    if key not in _BASES:
        if len(_BASES) >= 64:
            _BASES.clear()
        k = _coefficients(plan.kinds, sigmas, cov)
        basis = [(name, tuple(k[n] if n is not None else 0.0 for n in keys))
                 for name, keys in zip(PRODUCTS, _PRODUCT_COEFFICIENTS, strict=True)]
        basis = [(name, coef) for name, coef in basis if any(coef)]
        _BASES[key] = ([n for n, _ in basis],
                       np.array([c for _, c in basis], dtype=float).reshape(-1, 3),
                       np.array([k["D"], k["G"], k["F"]]))
    return _BASES[key]


_BASES: dict[tuple[object, ...], Packed] = {}


def _coefficients(kinds: tuple[str, ...], sigmas: Array,
                  covariance: Array | None) -> dict[str, float]:
    """Return the constant coefficients of the scalar fields, from ``W = R^{-1}``."""
    m = len(kinds)
    w = np.diag(1.0 / sigmas**2) if covariance is None else np.linalg.inv(covariance)
    alpha = np.zeros(m)   # a_j = alpha_j / r + beta_j q
    beta = np.zeros(m)
    gamma = np.zeros(m)   # b_j
    delta = np.zeros(m)   # c_j
    for j, kind in enumerate(kinds):
        if kind == "bearing":
            alpha[j] = 1.0
        elif kind == "range":
            gamma[j] = 1.0
        else:
            beta[j] = 1.0
            delta[j] = 1.0

    def dot(u: Array, v: Array) -> float:
        return float(u @ w @ v)

    return {"A_rr": dot(alpha, alpha), "A_rq": 2.0 * dot(alpha, beta),
            "A_qq": dot(beta, beta), "B_r": dot(alpha, gamma), "B_q": dot(beta, gamma),
            "D": dot(gamma, gamma), "E_r": dot(alpha, delta), "E_q": dot(beta, delta),
            "G": dot(gamma, delta), "F": dot(delta, delta)}


def planar_information(plan: SensorPlan, states: Array, weights: Array,
                       sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (*B, 4, 4) in the closed form of the module.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    names, coefficients, constants = compiled_basis(plan)
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    cols = np.ascontiguousarray(states.T)
    sums = _cloud_sums(names, cols, weights, s)
    out = np.empty((s.shape[0], 4, 4))
    assemble_gamma(sums, coefficients, constants, out)
    return out.reshape(*batch, 4, 4)


def _cloud_sums(names: list[str], cols: Array, weights: Array, sensors: Array) -> Array:
    """Return the weighted cloud sums (2 + 3 P, C) of the products ``names``."""
    c = sensors.shape[0]
    w = np.ascontiguousarray(weights, dtype=float)
    x = np.ascontiguousarray(cols[0])
    y = np.ascontiguousarray(cols[1])
    if names == ["ir2"]:
        out = np.empty((5, c))
        position_sums(x, y, w, np.ascontiguousarray(sensors[:, 0]),
                      np.ascontiguousarray(sensors[:, 1]), out)
        return out
    full = np.empty((ROWS, c))
    general_sums(x, y, np.ascontiguousarray(cols[2]), np.ascontiguousarray(cols[3]), w,
                 np.ascontiguousarray(sensors, dtype=float), full)
    rows = [0, 1]
    for name in names:
        k = 2 + 3 * PRODUCTS.index(name)
        rows += [k, k + 1, k + 2]
    return full[rows]


def fly(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float
        ) -> tuple[Array, Array]:
    """Fly every action from every start for one step (the rows of :func:`fly_rows`)."""
    size = starts.shape[0] * actions.shape[1]
    fields, flags = np.empty((20, size)), np.empty((4, size), dtype=np.bool_)
    fly_rows(starts, actions, own_climb, limits, float(interval), fields, flags)
    return fields, flags


_sums = numba.njit(cache=True, nogil=True, error_model="numpy",
                   fastmath={"reassoc", "contract", "nsz"})
_exact = numba.njit(cache=True, nogil=True, error_model="numpy")


@_sums
def position_sums(x: Array, y: Array, w: Array, sx: Array, sy: Array, out: Array) -> None:
    """Write (5, C): E[c2], E[cs], E[1/r^2], E[c2/r^2], E[cs/r^2] (no velocity terms)."""
    for c in range(sx.shape[0]):
        a0 = a1 = a2 = a3 = a4 = 0.0
        px = sx[c]
        py = sy[c]
        for i in range(x.shape[0]):
            dx = x[i] - px
            dy = y[i] - py
            dx2 = dx * dx
            ir2 = 1.0 / (dx2 + dy * dy)
            c2 = dx2 * ir2
            cs = dx * dy * ir2
            wi = w[i]
            wg = wi * ir2
            a0 += wi * c2
            a1 += wi * cs
            a2 += wg
            a3 += wg * c2
            a4 += wg * cs
        out[0, c] = a0
        out[1, c] = a1
        out[2, c] = a2
        out[3, c] = a3
        out[4, c] = a4


@_sums
def general_sums(x: Array, y: Array, vx: Array, vy: Array, w: Array, s: Array,
                 out: Array) -> None:
    """Write (17, C): E[c2], E[cs], then E[g], E[g c2], E[g cs] for g in ir2, irq, qq, ir, q."""
    for c in range(s.shape[0]):
        px, py, pvx, pvy = s[c, 0], s[c, 1], s[c, 3], s[c, 4]
        a0 = a1 = b0 = b1 = b2 = d0 = d1 = d2 = e0 = e1 = e2 = 0.0
        f0 = f1 = f2 = h0 = h1 = h2 = 0.0
        for i in range(x.shape[0]):
            dx = x[i] - px
            dy = y[i] - py
            dx2 = dx * dx
            ir2 = 1.0 / (dx2 + dy * dy)
            c2 = dx2 * ir2
            cs = dx * dy * ir2
            ir = np.sqrt(ir2)
            q = ((vx[i] - pvx) * dy - (vy[i] - pvy) * dx) * ir2
            wi = w[i]
            a0 += wi * c2
            a1 += wi * cs
            g = wi * ir2
            b0 += g
            b1 += g * c2
            b2 += g * cs
            g = wi * (ir * q)
            d0 += g
            d1 += g * c2
            d2 += g * cs
            g = wi * (q * q)
            e0 += g
            e1 += g * c2
            e2 += g * cs
            g = wi * ir
            f0 += g
            f1 += g * c2
            f2 += g * cs
            g = wi * q
            h0 += g
            h1 += g * c2
            h2 += g * cs
        sums = (a0, a1, b0, b1, b2, d0, d1, d2, e0, e1, e2, f0, f1, f2, h0, h1, h2)
        for k in range(17):
            out[k, c] = sums[k]


@_exact
def _cholesky(a: Array, d: Array, low: Array) -> bool:
    """Write the Cholesky factor of ``a / (d d^T)`` to ``low``; False if not PD."""
    n = a.shape[0]
    for j in range(n):
        acc = a[j, j] / (d[j] * d[j])
        for p in range(j):
            acc -= low[j, p] * low[j, p]
        if not acc > 0.0:
            return False
        low[j, j] = np.sqrt(acc)
        for i in range(j + 1, n):
            acc = a[i, j] / (d[i] * d[j])
            for p in range(j):
                acc -= low[i, p] * low[j, p]
            low[i, j] = acc / low[j, j]
    return True


@_exact
def _lower_inverse(low: Array, inv: Array) -> None:
    """Write the inverse of the lower-triangular ``low`` to ``inv`` (forward substitution)."""
    n = low.shape[0]
    for i in range(n):
        inv[i, i] = 1.0 / low[i, i]
        for j in range(i):
            acc = 0.0
            for p in range(j, i):
                acc += low[i, p] * inv[p, j]
            inv[i, j] = -acc * inv[i, i]


@_exact
def _gram(inv: Array, d: Array, out: Array) -> bool:
    """Write ``(L^{-T} L^{-1}) / (d d^T)`` to ``out``; False if a value is not finite."""
    n = inv.shape[0]
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for p in range(j, n):
                acc += inv[p, i] * inv[p, j]
            v = acc / (d[i] * d[j])
            if not np.isfinite(v):
                return False
            out[i, j] = v
            out[j, i] = v
    return True


@_exact
def spd_inverse_stack(info: Array, out: Array) -> bool:
    """Write ``J^{-1}`` of every (n, n) matrix of ``info`` to ``out``."""
    n = info.shape[1]
    low = np.zeros((n, n))
    inv = np.zeros((n, n))
    d = np.empty(n)
    for k in range(info.shape[0]):
        for i in range(n):
            d[i] = np.sqrt(max(info[k, i, i], 1e-300))
        if not _cholesky(info[k], d, low):
            return False
        _lower_inverse(low, inv)
        if not _gram(inv, d, out[k]):
            return False
    return True


@_exact
def assemble_gamma(sums: Array, coef: Array, dgf: Array, out: Array) -> None:
    """Write ``Gamma`` (C, 4, 4) from the cloud sums, as NumPy does it."""
    d, g, f = dgf[0], dgf[1], dgf[2]
    fields = np.empty(11)
    for c in range(sums.shape[1]):
        fields[:9] = 0.0
        fields[9] = sums[0, c]
        fields[10] = sums[1, c]
        for j in range(coef.shape[0]):
            for k in range(3):
                if coef[j, k] != 0.0:
                    for m in range(3):
                        fields[3 * k + m] += coef[j, k] * sums[2 + 3 * j + m, c]
        ea, eac2, eacs, eb, ebc2, ebcs, ee, eec2, eecs, ec2, ecs = fields
        out[c, 0, 0] = ea - eac2 + 2.0 * ebcs + d * ec2
        out[c, 0, 1] = out[c, 1, 0] = -eacs + eb - 2.0 * ebc2 + d * ecs
        out[c, 1, 1] = eac2 - 2.0 * ebcs + d * (1.0 - ec2)
        out[c, 0, 2] = out[c, 2, 0] = eecs + g * ec2
        out[c, 0, 3] = out[c, 3, 0] = ee - eec2 + g * ecs
        out[c, 1, 2] = out[c, 2, 1] = -eec2 + g * ecs
        out[c, 1, 3] = out[c, 3, 1] = -eecs + g * (1.0 - ec2)
        out[c, 2, 2] = f * ec2
        out[c, 2, 3] = out[c, 3, 2] = f * ecs
        out[c, 3, 3] = f * (1.0 - ec2)


#: The first row of the sensor state in :func:`fly_rows`'s output (20 rows, see ``_fly_one``).
SENSOR = 8

_TERMS = SERIES_TERMS   # the constant-turn factors' power series (sensors/tracks.py)
_E1, _E2 = np.array(E1_COEFF), np.array(E2_COEFF)
_LIMIT_TOL = 1e-9
_TWO_PI = 2.0 * np.pi


@_exact
def _differs(applied: float, commanded: float) -> bool:
    return abs(applied - commanded) > _LIMIT_TOL * max(1.0, abs(commanded))


@_exact
def _clip(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


@_exact
def _wrap(angle: float) -> float:
    """``tmakit.core.frames.wrap_angle`` of one angle (rad), the same operations."""
    shifted = angle + np.pi
    out = shifted - np.pi
    if not (shifted >= 0.0 and shifted < _TWO_PI):
        out = np.mod(shifted, _TWO_PI) - np.pi
    if out == -np.pi:
        out = np.pi
    return out


@_exact
def _turn_factors(z: complex) -> tuple[complex, complex]:
    """``E1(z) = (e^z - 1) / z`` and ``E2(z) = (e^z (z - 1) + 1) / z^2``, stable at 0."""
    if abs(z) < SERIES_BELOW:
        s1 = complex(_E1[_TERMS - 1])
        s2 = complex(_E2[_TERMS - 1])
        for k in range(_TERMS - 2, -1, -1):
            s1 = s1 * z + _E1[k]
            s2 = s2 * z + _E2[k]
        return s1, s2
    ez = np.exp(z)
    return (ez - 1.0) / z, (ez * (z - 1.0) + 1.0) / (z * z)


@_exact
def _fly_one(st: Array, hc: float, target: float, c_cmd: float, lim: Array, t: float,
             row: Array, flag: Array) -> None:
    """One start state ``st`` and one action; its fields ``row`` and ``flag`` written."""
    x0, y0, z0, psi0, v0 = st[0], st[1], st[2], st[3], st[4]
    v1 = _clip(target, lim[0], lim[1])
    acc_cmd = (v1 - v0) / t
    acc = _clip(acc_cmd, -lim[3], lim[3])
    w_cmd = hc / t
    w = _clip(w_cmd, -lim[2], lim[2])
    c = _clip(c_cmd, (lim[5] - z0) / t, (lim[6] - z0) / t)
    c = _clip(c, -lim[4], lim[4])
    flag[0] = _differs(v1, target)
    flag[1] = _differs(w, w_cmd)
    flag[2] = _differs(acc, acc_cmd)
    flag[3] = _differs(c, c_cmd)
    v_end = max(v0 + acc * t, 0.0) if flag[2] else v1
    e1, e2 = _turn_factors(1j * (w * t))
    disp = np.exp(1j * psi0) * t * (v0 * e1 + acc * t * e2)
    psi = _wrap(psi0 + w * t)
    row[0] = x0 + disp.imag
    row[1] = y0 + disp.real
    row[2] = z0 + c * t
    row[3] = psi
    row[4] = v_end
    row[5] = c
    row[6] = w
    row[7] = acc
    row[8] = row[0]
    row[9] = row[1]
    row[10] = row[2]
    row[11] = v_end * np.sin(psi)
    row[12] = v_end * np.cos(psi)
    row[13] = c
    row[14] = x0
    row[15] = y0
    row[16] = z0
    row[17] = _wrap(psi0)   # as PlatformState.trusted does (the same value, to rounding)
    row[18] = v0
    row[19] = st[5]


@_exact
def fly_rows(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float,
             out: Array, flags: Array) -> None:
    """Fly every action from every start state for one step; write ``(20, M A)`` fields."""
    n_act = actions.shape[1]
    for m in range(starts.shape[0]):
        st = starts[m]
        for a in range(n_act):
            target = st[4] * actions[1, a] + actions[2, a]
            c_cmd = st[5] if own_climb else actions[3, a]
            k = m * n_act + a
            _fly_one(st, actions[0, a], target, c_cmd, limits, interval, out[:, k],
                     flags[:, k])


@_exact
def _symmetric_product(left: Array, mid: Array, out: Array) -> None:
    """``out = sym(left^T mid left)`` for small square matrices (plain loops, no BLAS)."""
    n = mid.shape[0]
    tmp = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += mid[i, k] * left[k, j]
            tmp[i, j] = acc
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += left[k, i] * tmp[k, j]
            out[i, j] = acc
    _symmetrise(out)


@_exact
def _symmetrise(a: Array) -> None:
    n = a.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            v = 0.5 * (a[i, j] + a[j, i])
            a[i, j] = v
            a[j, i] = v


@_exact
def _cholesky_solve(s: Array, ag: Array) -> Array:
    """Return ``H = L^{-1} (A G)^T`` with ``L L^T = S`` (positive definite, r x r)."""
    r, n = s.shape[0], ag.shape[0]
    low = np.zeros((r, r))
    _cholesky(s, np.ones(r), low)   # S = I + G^T A G: positive definite
    half = np.empty((r, n))   # forward substitution L H = (A G)^T
    for col in range(n):
        for i in range(r):
            acc = ag[col, i]
            for p in range(i):
                acc -= low[i, p] * half[p, col]
            half[i, col] = acc / low[i, i]
    return half


@_exact
def _predict(info: Array, f_inv: Array, g: Array) -> Array:
    """``predict_information`` of one (n, n) matrix: the same Woodbury form, in plain loops."""
    n, r = info.shape[0], g.shape[1]
    a = np.empty((n, n))
    _symmetric_product(f_inv, info, a)
    if r == 0:
        return a
    ag = np.zeros((n, r))
    for i in range(n):
        for j in range(r):
            for k in range(n):
                ag[i, j] += a[i, k] * g[k, j]
    s = np.empty((r, r))
    for i in range(r):
        for j in range(r):
            acc = 1.0 if i == j else 0.0
            for k in range(n):
                acc += g[k, i] * ag[k, j]
            s[i, j] = acc
    _symmetrise(s)
    half = _cholesky_solve(s, ag)
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(r):
                acc += half[k, i] * half[k, j]
            out[i, j] = a[i, j] - acc
    _symmetrise(out)
    return out


@_exact
def _moved_cloud(states: Array, weights: Array, transition: Array, at_mean: bool,
                 rows: int) -> Array:
    """Return the cloud ``F x_i`` by rows (4, N) (the first ``rows`` written), or its mean."""
    n = states.shape[1]
    if at_mean:
        mean = np.zeros(n)
        for i in range(states.shape[0]):
            for j in range(n):
                mean[j] += weights[i] * states[i, j]
        out = np.zeros((n, 1))
        for i in range(n):
            for j in range(n):
                out[i, 0] += transition[i, j] * mean[j]
        return out
    out = np.empty((n, states.shape[0]))
    for i in range(rows):   # the planar state [x, y, vx, vy]: four terms, unrolled
        f0, f1, f2, f3 = transition[i, 0], transition[i, 1], transition[i, 2], transition[i, 3]
        for p in range(states.shape[0]):
            out[i, p] = (((f0 * states[p, 0]) + f1 * states[p, 1]) + f2 * states[p, 2]
                         + f3 * states[p, 3])
    return out


@_exact
def _add_symmetric(pred: Array, info: Array) -> None:
    """``info[c] = sym(pred + info[c])`` for every candidate (``symmetrise`` of the sum)."""
    n = pred.shape[0]
    for c in range(info.shape[0]):
        for i in range(n):
            for j in range(i, n):
                v = 0.5 * ((pred[i, j] + info[c, i, j]) + (pred[j, i] + info[c, j, i]))
                info[c, i, j] = v
                info[c, j, i] = v


@_exact
def _score(cov: Array, weighting: Array, cost: Array, bound: Array) -> int:
    """Write ``Tr{Pi C}`` and the position bound (m) per candidate; return the least cost's."""
    n = cov.shape[1]
    best = -1
    for c in range(cov.shape[0]):
        acc = 0.0
        for i in range(n):
            for j in range(n):
                acc += weighting[i, j] * cov[c, j, i]
        cost[c] = acc
        bound[c] = np.sqrt(max(cov[c, 0, 0] + cov[c, 1, 1], 0.0))
        if acc == acc and (best < 0 or acc < cost[best]):
            best = c
    return max(best, 0)


@_exact
def decide_planar(position: Array, heading: float, speed: float, climb: float,
                  actions: Array, own_climb: bool, limits: Array, interval: float,
                  information: Array, f_inv: Array, g: Array,
                  transition: Array, states: Array, weights: Array, at_mean: bool,
                  coef: Array, dgf: Array, position_only: bool, weighting: Array,
                  out: Array, flags: Array, info: Array, cov: Array, cost: Array,
                  bound: Array) -> int:
    """One decision over ``A`` candidates; return the best, or why not."""
    start = np.empty((1, 6))
    for i in range(3):  # (element by element: no array assignment's shape check to compile)
        start[0, i] = position[i]
    start[0, 3] = heading
    start[0, 4] = speed
    start[0, 5] = climb
    fly_rows(start, actions, own_climb, limits, interval, out, flags)
    n_cand = out.shape[1]
    for c in range(n_cand):
        if out[SENSOR + 2, c] != 0.0:
            return -1
    cols = _moved_cloud(states, weights, transition, at_mean, 2 if position_only else 4)
    w = np.ones(1) if at_mean else weights
    if position_only:
        sums = np.empty((5, n_cand))
        position_sums(cols[0], cols[1], w, out[SENSOR], out[SENSOR + 1], sums)
    else:
        sums = np.empty((17, n_cand))
        sensor = np.ascontiguousarray(out[SENSOR:SENSOR + 6].T)
        general_sums(cols[0], cols[1], cols[2], cols[3], w, sensor, sums)
    assemble_gamma(sums, coef, dgf, info)
    _add_symmetric(_predict(information, f_inv, g), info)
    if not spd_inverse_stack(info, cov):
        return -2
    return _score(cov, weighting, cost, bound)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def geometric_sums(codes: Array, whiten: Array, states: Array, weights: Array,
                   sensors: Array, out: Array) -> None:  # pragma: no cover - compiled
    """Add ``sum_i w_i (W H_i)' (W H_i)`` (C, n, n) to ``out``, ``H_i`` the kinds' rows."""
    m, n = codes.shape[0], states.shape[1]
    dim = n // 2
    h, g = np.zeros((m, n)), np.zeros((m, n))
    for c in range(sensors.shape[0]):
        s = sensors[c]
        for i in range(states.shape[0]):
            x = states[i]
            z, vz = (x[2], x[5]) if dim == 3 else (0.0, 0.0)
            rel = (x[0] - s[0], x[1] - s[1], z - s[2], x[dim] - s[3], x[dim + 1] - s[4],
                   vz - s[5])
            for k in range(m):
                row = geometric_row(codes[k], rel)
                for a in range(dim):
                    h[k, a], h[k, dim + a] = row[1 + a], row[4 + a]
            for k in range(m):
                for a in range(n):
                    t = 0.0
                    for j in range(m):
                        t += whiten[k, j] * h[j, a]
                    g[k, a] = t
            for k in range(m):
                for a in range(n):
                    ga = weights[i] * g[k, a]
                    for b in range(a, n):
                        out[c, a, b] += ga * g[k, b]
        for a in range(n):
            for b in range(a + 1, n):
                out[c, b, a] = out[c, a, b]

