"""``Gamma`` over a whole particle cloud for every candidate, written out for the geometric kinds.

:func:`~tmakit.planning.candidates.expected_information` with ``gamma="cloud"`` asks for
``sum_i w_i H_i^T R^{-1} H_i`` for ``C`` candidates and ``N`` particles: ``C N`` Jacobians.
The general path (:meth:`MeasurementGroup.information`) builds every ``(m, n)`` Jacobian and
every ``(n, n)`` product; here, for plans whose kinds are all geometric (``bearing``,
``elevation``, ``range``, ``range_rate``: functions of the relative position ``d`` and velocity
``u`` only, no options or nuisance), the Jacobians are written out component by component on
``(C, N)`` arrays (relative position ``d``, ``rho^2 = dx^2 + dy^2``, ``r = |d|``):

* bearing ``atan2(dx, dy)``: ``d/dd = (dy, -dx, 0) / rho^2``;
* elevation ``atan2(dz, rho)``: ``d/dd = (-dx dz, -dy dz, rho^2) / (rho r^2)``;
* range ``r``: ``d/dd = d / r``;
* range rate ``d.u / r``: ``d/dd = (u - rdot d / r) / r``, ``d/du = d / r``;

only the non-zero components are kept, whitened by ``R^{-1/2}`` (a full ``R`` mixes the
rows), their products summed over the rows, and each of the ``n (n + 1) / 2`` entries of
``Gamma`` is one weighted sum over the cloud (a matrix-vector product).
``tests/test_planning.py`` checks it against the general path.
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import Array
from .measurement_plan import SensorPlan

#: Kinds this module writes out (functions of the relative position and velocity only).
GEOMETRIC_KINDS = frozenset({"bearing", "elevation", "range", "range_rate"})


def supports(plan: SensorPlan) -> bool:
    """Tell whether the plan's kinds are all geometric, with no options or nuisance."""
    return (set(plan.kinds) <= GEOMETRIC_KINDS and not plan.options and not plan.nuisance)


def _rows(kind: str, d: list[Array], u: list[Array], rho2: Array, inv_r: Array
          ) -> list[tuple[int, Array]]:
    """Non-zero components ``(relative-state index 0..5, values (C, N))`` of one row."""
    dx, dy, dz = d
    if kind == "bearing":
        inv = 1.0 / rho2
        return [(0, dy * inv), (1, -dx * inv)]
    if kind == "range":
        return [(0, dx * inv_r), (1, dy * inv_r), (2, dz * inv_r)]
    if kind == "elevation":
        rho = np.sqrt(rho2)
        a = inv_r * inv_r / rho
        return [(0, -dx * dz * a), (1, -dy * dz * a), (2, rho2 * a)]
    # range rate
    ex, ey, ez = dx * inv_r, dy * inv_r, dz * inv_r
    rdot = ex * u[0] + ey * u[1] + ez * u[2]
    return [(0, (u[0] - rdot * ex) * inv_r), (1, (u[1] - rdot * ey) * inv_r),
            (2, (u[2] - rdot * ez) * inv_r), (3, ex), (4, ey), (5, ez)]


#: Cloud members per block: keeps the temporaries small enough to be reused by the
#: allocator (whole-cloud temporaries of a few MB are returned to the system after every call
#: and fault back in on the next, which costs more than the arithmetic).
BLOCK_ELEMENTS = 1 << 15


def cloud_information(plan: SensorPlan, states: Array, weights: Array,
                      sensor_states: Array) -> Array:
    """Return ``sum_i w_i Xi(x_i, s_c)`` (C, n, n) for candidate sensor states ``s_c``.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 11 and 13.
    """
    batch = sensor_states.shape[:-1]
    s = sensor_states.reshape(-1, 6)
    n = 2 * plan.dim
    block = max(1, BLOCK_ELEMENTS // s.shape[0])
    out = np.zeros((s.shape[0], n, n))
    for lo in range(0, states.shape[0], block):   # blocks of the cloud, not members
        out += _block_information(plan, states[lo:lo + block], weights[lo:lo + block], s)
    return out.reshape(*batch, n, n)


def _block_information(plan: SensorPlan, states: Array, weights: Array, s: Array) -> Array:
    dim = plan.dim
    n = 2 * dim
    c = s.shape[0]
    cols = np.ascontiguousarray(states.T)
    d = [(cols[i][None, :] if i < dim else 0.0) - s[:, i, None] for i in range(3)]
    u = [(cols[dim + i][None, :] if i < dim else 0.0) - s[:, 3 + i, None]
         for i in range(3)]
    d = [np.broadcast_to(a, (c, states.shape[0])) for a in d]
    rho2 = d[0] * d[0] + d[1] * d[1]
    inv_r = 1.0 / np.sqrt(rho2 + d[2] * d[2])
    rows = [_rows(k, d, u, rho2, inv_r) for k in plan.kinds]
    # state columns: relative position i -> i, velocity 3 + i -> dim + i (i < dim)
    col = {i: i for i in range(dim)} | {3 + i: dim + i for i in range(dim)}
    if plan.covariance is None:
        whiten = np.diag(1.0 / plan.sigmas)
    else:
        whiten = np.linalg.inv(np.linalg.cholesky(plan.covariance))
    # whitened rows: w_k = sum_j whiten[k, j] h_j, component by component
    whitened: list[dict[int, Array]] = []
    for k in range(len(rows)):
        acc: dict[int, Array] = {}
        for j, row in enumerate(rows):
            if whiten[k, j] == 0.0:
                continue
            for idx, val in row:
                if idx in col:
                    term = val * whiten[k, j]
                    if col[idx] in acc:
                        acc[col[idx]] += term
                    else:
                        acc[col[idx]] = term
        whitened.append(acc)
    # sum over rows of the products, then one weighted sum over the cloud per entry
    products: dict[tuple[int, int], Array] = {}
    for acc in whitened:
        present = sorted(acc)
        for i, a in enumerate(present):
            for b in present[i:]:
                prod = acc[a] * acc[b]
                if (a, b) in products:
                    products[(a, b)] += prod
                else:
                    products[(a, b)] = prod
    out = np.zeros((c, n, n))
    for (a, b), prod in products.items():   # at most n (n + 1) / 2 entries
        out[:, a, b] = out[:, b, a] = prod @ weights
    return out
