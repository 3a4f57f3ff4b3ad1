"""``Gamma`` over a cloud in closed form for planar bearing, range and range-rate plans.

When the target state is 2-D and every candidate sensor is in the target's plane (``z = 0``),
the Jacobians of the three kinds are combinations of two unit vectors, the line of sight
``e = d / r`` and its normal ``e_perp = (e_y, -e_x)`` (``d`` the relative position,
``r = |d|``, ``q = (u_x d_y - u_y d_x) / r^2`` the bearing rate for relative velocity ``u``):

* bearing ``atan2(d_x, d_y)``: position part ``e_perp / r``;
* range: position part ``e``;
* range rate ``u.e``: position part ``(u - (u.e) e) / r = q e_perp``, velocity part ``e``.

With the rows' position parts ``a_j e_perp + b_j e`` and velocity parts ``c_j e``, and
``W = R^{-1}``, the information ``sum_jk W_jk h_j h_k^T`` is

    position-position  A (I - e e^T) + B (e_perp e^T + e e_perp^T) + D e e^T,
    position-velocity  E (e_perp e^T) + G e e^T,      velocity-velocity  F e e^T,

with scalar fields ``A = a^T W a``, ``B = a^T W b``, ``D = b^T W b``, ``E = a^T W c``,
``G = b^T W c``, ``F = c^T W c`` (``a_j`` is ``1 / r`` or ``q``, the others constants).  The
entries of ``e e^T`` and ``e_perp e^T`` are ``c2 = e_x^2``, ``cs = e_x e_y`` and ``1 - c2``,
so the cloud average needs only the eleven weighted sums ``E[A]``, ``E[A c2]``, ``E[A cs]``,
the same for ``B`` and ``E``, and ``E[c2]``, ``E[cs]``: one matrix product over the cloud.
That is about a third of the arithmetic of :mod:`tmakit.planning.fast_information` (which
``tests/test_planning.py`` checks it against, and which handles 3-D and altitude).
"""

from __future__ import annotations

import threading

import numpy as np

from ..arrays import Array
from .measurement_plan import SensorPlan

PLANAR_KINDS = frozenset({"bearing", "range", "range_rate"})
#: Cloud members times candidates per block (see :data:`fast_information.BLOCK_ELEMENTS`).
BLOCK_ELEMENTS = 1 << 14


def supports_planar(plan: SensorPlan, sensor_states: Array) -> bool:
    """Whether the closed form applies: 2-D, planar kinds, every sensor at ``z = 0``."""
    return (plan.dim == 2 and set(plan.kinds) <= PLANAR_KINDS and not plan.options
            and not plan.nuisance and not np.any(sensor_states[..., 2]))


def _coefficients(plan: SensorPlan) -> dict[str, float]:
    """Return the constant coefficients of the scalar fields, from ``W = R^{-1}``."""
    m = len(plan.kinds)
    w = (np.diag(1.0 / plan.sigmas**2) if plan.covariance is None
         else np.linalg.inv(plan.covariance))
    alpha = np.zeros(m)   # a_j = alpha_j / r + beta_j q
    beta = np.zeros(m)
    gamma = np.zeros(m)   # b_j
    delta = np.zeros(m)   # c_j
    for j, kind in enumerate(plan.kinds):
        if kind == "bearing":
            alpha[j] = 1.0
        elif kind == "range":
            gamma[j] = 1.0
        else:
            beta[j] = 1.0
            delta[j] = 1.0
    return {"A_rr": alpha @ w @ alpha, "A_rq": 2.0 * (alpha @ w @ beta),
            "A_qq": beta @ w @ beta, "B_r": alpha @ w @ gamma, "B_q": beta @ w @ gamma,
            "D": gamma @ w @ gamma, "E_r": alpha @ w @ delta, "E_q": beta @ w @ delta,
            "G": gamma @ w @ delta, "F": delta @ w @ delta}


def planar_information(plan: SensorPlan, states: Array, weights: Array,
                       sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (*B, 4, 4) in the closed form of the module.

    Parameters
    ----------
    plan : SensorPlan
        2-D, kinds among bearing, range, range rate (:func:`supports_planar`).
    states : ndarray, shape (N, 4)
        Target cloud ``[x, y, vx, vy]`` at the measurement time (m, m/s).
    weights : ndarray, shape (N,)
        Normalised weights.
    sensor_states : ndarray, shape (*B, 6)
        Candidate sensor states (``z = 0``).

    Returns
    -------
    ndarray, shape (*B, 4, 4)
        SI.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    k = _coefficients(plan)
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    block = max(1, BLOCK_ELEMENTS // s.shape[0])
    sums = np.zeros((11, s.shape[0]))
    cols = np.ascontiguousarray(states.T)
    for lo in range(0, states.shape[0], block):   # blocks of the cloud, not members
        sums += _block_sums(k, cols[:, lo:lo + block], weights[lo:lo + block], s)
    return _assemble(k, sums).reshape(*batch, 4, 4)


class _Workspace(threading.local):
    """Work arrays of one block shape, kept between calls (one set per thread).

    Fresh block-sized temporaries are returned to the system after every call and fault back
    in on the next (page faults cost more than the arithmetic here); reused ones do not.
    """

    def __init__(self) -> None:
        self.sets: dict[tuple[int, int], dict[str, Array]] = {}

    def get(self, c: int, b: int) -> dict[str, Array]:
        if (c, b) not in self.sets:
            if len(self.sets) >= 4:   # a few shapes (mean and cloud, last block) at most
                self.sets.pop(next(iter(self.sets)))
            names = ("dx", "dy", "dxdy", "dx2", "ir2", "ir", "q", "ux", "uy", "tmp")
            arrays = {n: np.empty((c, b)) for n in names}
            arrays["f"] = np.empty((11, c, b))
            self.sets[(c, b)] = arrays
        return self.sets[(c, b)]


_WORK = _Workspace()


def _block_sums(k: dict[str, float], cols: Array, weights: Array, s: Array) -> Array:
    """Return the eleven weighted sums (11, C) over one block of the cloud."""
    c, b = s.shape[0], cols.shape[1]
    w = _WORK.get(c, b)
    f = w["f"]
    f[:9] = 0.0                      # the fields; unused ones stay zero
    dx, dy, dxdy, dx2, ir2, tmp = w["dx"], w["dy"], w["dxdy"], w["dx2"], w["ir2"], w["tmp"]
    np.subtract(cols[0][None, :], s[:, 0, None], out=dx)
    np.subtract(cols[1][None, :], s[:, 1, None], out=dy)
    np.multiply(dx, dy, out=dxdy)
    np.multiply(dx, dx, out=dx2)
    np.multiply(dy, dy, out=ir2)
    ir2 += dx2
    np.reciprocal(ir2, out=ir2)
    c2, cs = f[9], f[10]
    np.multiply(dx2, ir2, out=c2)
    np.multiply(dxdy, ir2, out=cs)
    need_q = any(k[n] for n in ("A_rq", "A_qq", "B_q", "E_q"))
    need_r = any(k[n] for n in ("A_rq", "B_r", "E_r"))
    ir = np.sqrt(ir2, out=w["ir"]) if need_r else None
    q = None
    if need_q:
        ux, uy, q = w["ux"], w["uy"], w["q"]
        np.subtract(cols[2][None, :], s[:, 3, None], out=ux)
        np.subtract(cols[3][None, :], s[:, 4, None], out=uy)
        np.multiply(ux, dy, out=q)
        q -= np.multiply(uy, dx, out=tmp)
        q *= ir2
    _field(f[0], tmp, ((k["A_rr"], ir2, None), (k["A_rq"], ir, q), (k["A_qq"], q, q)))
    _field(f[3], tmp, ((k["B_r"], ir, None), (k["B_q"], q, None)))
    _field(f[6], tmp, ((k["E_r"], ir, None), (k["E_q"], q, None)))
    used = [i for i, names in ((0, ("A_rr", "A_rq", "A_qq")), (3, ("B_r", "B_q")),
                               (6, ("E_r", "E_q"))) if any(k[n] for n in names)]
    for i in used:
        np.multiply(f[i], c2, out=f[i + 1])
        np.multiply(f[i], cs, out=f[i + 2])
    rows = [9, 10] + [i + j for i in used for j in range(3)]
    sums = np.zeros((11, c))
    sums[rows] = f[rows] @ weights
    return sums


def _field(out: Array, tmp: Array,
           terms: tuple[tuple[float, Array | None, Array | None], ...]) -> None:
    """``out += coefficient * a * b`` (``b`` may be None) over the non-zero terms."""
    for coef, a, b in terms:
        if not coef or a is None:
            continue
        if b is None:
            np.multiply(a, coef, out=tmp)
        else:
            np.multiply(a, b, out=tmp)
            tmp *= coef
        out += tmp


def _assemble(k: dict[str, float], sums: Array) -> Array:
    """``Gamma`` (C, 4, 4) from the eleven weighted sums."""
    ea, eac2, eacs, eb, ebc2, ebcs, ee, eec2, eecs, ec2, ecs = sums
    d, g, f = k["D"], k["G"], k["F"]
    out = np.empty((sums.shape[1], 4, 4))
    out[:, 0, 0] = ea - eac2 + 2.0 * ebcs + d * ec2
    out[:, 0, 1] = out[:, 1, 0] = -eacs + eb - 2.0 * ebc2 + d * ecs
    out[:, 1, 1] = eac2 - 2.0 * ebcs + d * (1.0 - ec2)
    pv = np.empty((sums.shape[1], 2, 2))
    pv[:, 0, 0] = eecs + g * ec2
    pv[:, 0, 1] = ee - eec2 + g * ecs
    pv[:, 1, 0] = -eec2 + g * ecs
    pv[:, 1, 1] = -eecs + g * (1.0 - ec2)
    out[:, :2, 2:] = pv
    out[:, 2:, :2] = np.swapaxes(pv, -1, -2)
    out[:, 2, 2] = f * ec2
    out[:, 2, 3] = out[:, 3, 2] = f * ecs
    out[:, 3, 3] = f * (1.0 - ec2)
    return out
