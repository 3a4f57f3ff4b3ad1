"""The compiled kernels of one whole planning decision (imported only by ``compiled``)."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.arrays import Array
from .compiled_sums import assemble_gamma, general_sums, position_sums, spd_inverse_stack

_exact = numba.njit(cache=True, nogil=True, error_model="numpy")

#: Rows (fields) of :func:`fly`'s output.
END_POSITION, END_HEADING, END_SPEED, CLIMB, TURN, ACCEL = 0, 3, 4, 5, 6, 7
SENSOR, START_POSITION, START_HEADING, START_SPEED, START_CLIMB = 8, 14, 17, 18, 19
COLUMNS = 20

_SERIES_BELOW = 0.25
_TERMS = 17
_E1 = np.array([1.0 / math.factorial(n + 1) for n in range(_TERMS)])
_E2 = np.array([1.0 / (math.factorial(n) * (n + 2)) for n in range(_TERMS)])
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
    if abs(z) < _SERIES_BELOW:
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
def fly(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float,
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
    for j in range(r):
        acc = s[j, j]
        for p in range(j):
            acc -= low[j, p] * low[j, p]
        low[j, j] = np.sqrt(acc)
        for i in range(j + 1, r):
            acc = s[i, j]
            for p in range(j):
                acc -= low[i, p] * low[j, p]
            low[i, j] = acc / low[j, j]
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
    start[0, :3] = position
    start[0, 3] = heading
    start[0, 4] = speed
    start[0, 5] = climb
    fly(start, actions, own_climb, limits, interval, out, flags)
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
