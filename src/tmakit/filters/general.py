"""The general filter path: a measurement set prepared once per file, its plan, and the step.

The set is prepared once (:class:`PreparedMeasurements`) and so is everything of an update that
does not depend on the state (:class:`StepPlan`; :class:`RowSteps` for rows handed over one update
at a time), because cutting the set per update costs more than a filter step.  The EKF's
posterior covariance is ``P - K H P``, the Joseph form only when that fails its Cholesky check
(:func:`updated_covariance`), repaired only when that fails too (:func:`checked_psd`).  The
dynamics' ``Phi(T)`` and ``Q_k`` are Chen & Sun's, §2.1.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.linalg.lapack import dposv, dpotrf

from ..core.arrays import Array, IntArray
from ..core.frames import wrap_angle
from ..core.linalg import repair_psd, solve_spd
from ..data import KIND_CODES, MeasurementSet
from ..measurements import MeasurementModel
from ..motion.dynamics import NearlyConstantVelocity
from ..observation import MeasurementGroup
from ..observation.groups import time_blocks, tonals_scaled
from ..observation.rows import Index, RowLayout, as_slice, correlated_blocks, resolve_models


class PreparedMeasurements:
    """A measurement set prepared once for a filter run of dimension ``dim``, options, nuisance."""

    def __init__(self, meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        meas, nuisance = tonals_scaled(meas, options, nuisance)  # several tonals: as one
        self.meas = meas
        self.dim = int(dim)
        n = len(meas)
        # The same grouping as tmakit.observation.group_times: one update per time.
        order, self.bounds = time_blocks(meas.time)
        t = meas.time[order]
        self.order = order
        #: Update times (s): the last (latest) row time of each update, as ``run`` uses.
        self.times = t[self.bounds[1:] - 1] if n else np.zeros(0)
        self.models, self.nuisance = resolve_models(meas.kinds, options, nuisance)
        self.kind = meas.kind[order]
        self.values = meas.value_si[order]
        self.sigmas = meas.sigma_si[order]
        self.time = t
        self.time_ref = meas.time_ref[order]
        self.sensor_state = meas.sensor_state[order]
        self.ref_sensor_state = meas.ref_sensor_state[order]
        self.sensor = meas.sensor[order]
        self._kind_codes = {k: i for i, k in enumerate(self.models)}
        #: Each row's kind as its position in :attr:`models`, in run order.
        self.model_index: IntArray = (model_codes(meas.kind_code[order], list(self.models))
                                      if n else np.zeros(0, dtype=np.int64))
        #: What the filters derive from the set once per run (e.g. the general path's plan).
        self.cache: dict[str, object] = {}
        #: Per pattern of kinds in an update (its kind codes): models, index, nuisance and
        #: row layout, made once and shared by the updates with that pattern.
        self._layouts: dict[bytes, tuple[dict, dict, dict, RowLayout]] = {}
        sizes = np.diff(self.bounds)
        #: Every update is one bearing row (the Gaussian sum's compiled run applies).
        self.single_bearing = bool(n > 0 and np.all(sizes == 1)
                                   and set(self.models) == {"bearing"})

    def __len__(self) -> int:
        """Give the number of updates."""
        return int(self.times.shape[0])

    def rows(self, k: int) -> MeasurementSet:
        """Give the rows of update ``k`` as a MeasurementSet (the slow, general path)."""
        return self.meas.take(self.order[self.bounds[k]:self.bounds[k + 1]])

    def group(self, k: int, t: float) -> MeasurementGroup:
        """Give update ``k`` as a :class:`MeasurementGroup`, from views of the columns."""
        a, b = int(self.bounds[k]), int(self.bounds[k + 1])
        codes = self.model_index[a:b]
        key = codes.tobytes()
        parts = self._layouts.get(key)
        if parts is None:  # the first update with this pattern of kinds
            models, index = {}, {}
            for kind, code in self._kind_codes.items():
                idx = np.flatnonzero(codes == code)
                if idx.size:
                    models[kind] = self.models[kind]
                    index[kind] = idx
            nus = {kind: self.nuisance[kind] for kind in models}
            parts = (models, index, nus, RowLayout(models, index, b - a))
            self._layouts[key] = parts
        models, index, nus, layout = parts
        return MeasurementGroup.from_arrays(
            t, self.dim, models, nus, index, self.values[a:b], self.sigmas[a:b],
            self.time[a:b], self.time_ref[a:b], self.sensor_state[a:b],
            self.ref_sensor_state[a:b], self.sensor[a:b], lambda: self.rows(k), layout)


#: The sets prepared so far, per measurement set (whose arrays are read-only) and per
#: (dimension, options, nuisance values): a set filtered again (another filter, another prior,
#: the same filter once more) is prepared once.  Kept while the set lives.
_PREPARED: weakref.WeakKeyDictionary[MeasurementSet, dict[str, PreparedMeasurements]] = \
    weakref.WeakKeyDictionary()


def model_codes(kind_code: IntArray, names: list[str]) -> IntArray:
    """Map the set's kind codes (``data.KIND_CODES``) to positions in ``names``."""
    lookup = np.full(len(KIND_CODES), -1, dtype=np.int64)
    for i, k in enumerate(names):
        lookup[KIND_CODES[k]] = i
    return lookup[kind_code]


def prepared_for(meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> PreparedMeasurements:
    """Give ``meas`` prepared for a filter, made once per set and settings."""
    key = repr((int(dim), sorted((str(k), sorted(dict(v).items()))
                                 for k, v in dict(options or {}).items()),
                sorted(dict(nuisance or {}).items())))
    try:
        per_set = _PREPARED.get(meas)
        if per_set is None:
            per_set = _PREPARED[meas] = {}
    except TypeError:  # a set that cannot be weakly referenced or hashed: prepared each time
        return PreparedMeasurements(meas, dim, options, nuisance)
    out = per_set.get(key)
    if out is None:
        if len(per_set) >= 8:  # many settings on one set: keep the cache small
            per_set.clear()
        out = per_set[key] = PreparedMeasurements(meas, dim, options, nuisance)
    return out


# -- the step ---------------------------------------------------------------------------------

#: One update of a plan: update time (s), values (m,), sensor states flattened (m * 6,),
#: the kinds' parts, the state-to-target map ``T`` (m * 6, n), its rows as (m, 6, n) or None
#: when every row is at the update time (then ``E`` (6, n) chains), noise ``R`` (m, m), the
#: angle rows (index or None), the row times (m,), and the rows as plain-float records
#: for the kinds' ``row_gradient`` (or None: their ``values_and_derivatives_into``).
Step = tuple[Any, ...]


def sym(p: Array) -> Array:
    """Give ``(P + P^T) / 2`` of one square matrix."""
    out = p + p.T
    out *= 0.5
    return out


def checked_psd(p: Array) -> Array:
    """Give ``p`` symmetrised, repaired (:func:`~tmakit.core.linalg.repair_psd`) only if not PD."""
    p = sym(p)
    if dpotrf(p, lower=1, clean=0)[1] == 0:
        return p
    return repair_psd(p)


def innovation_solve(s: Array, hp: Array, residual: Array) -> tuple[Array, float, float]:
    """Give the gain ``(S^-1 HP)^T``, the NIS ``r^T S^-1 r`` and ``log det S``."""
    m = s.shape[0]
    if m == 1:
        s00 = float(s[0, 0])
        if s00 > 0.0:
            y0 = float(residual[0])
            return hp.T / s00, y0 * y0 / s00, math.log(s00)
    elif m == 2:
        a, c = float(s[0, 0]), float(s[1, 1])
        b = 0.5 * (float(s[0, 1]) + float(s[1, 0]))
        det = a * c - b * b
        if a > 0.0 and det > 0.0:
            inv = np.array([[c, -b], [-b, a]]) / det
            return inv.dot(hp).T, float(residual.dot(inv).dot(residual)), math.log(det)
    else:
        chol, sol, info = dposv(s, np.concatenate((hp, residual[:, None]), axis=1), lower=1)
        if info == 0:
            return (sol[:, :-1].T, float(residual.dot(sol[:, -1])),
                    2.0 * math.fsum(map(math.log, chol.diagonal().tolist())))
    sol, log_det = solve_spd(s, np.concatenate([hp, residual[:, None]], axis=1))
    return sol[:, :-1].T, float(residual @ sol[:, -1]), log_det


def kalman_gain(cov: Array, h: Array, r: Array, residual: Array
                ) -> tuple[Array, float, float]:
    """Give the gain ``P H^T S^-1``, the NIS and ``log det S``, ``S = H P H^T + R``."""
    hp = h.dot(cov)
    s = hp.dot(h.T)
    s += r
    return innovation_solve(s, hp, residual)


def updated_covariance(cov: Array, gain: Array, hp: Array, h: Array, r: Array) -> Array:
    """Give ``P - K H P`` symmetrised, or the Joseph form when that fails its Cholesky check."""
    p = sym(cov - gain.dot(hp))
    if dpotrf(p, lower=1, clean=0)[1] == 0:
        return p
    return joseph(cov, gain, h, r)


def joseph(cov: Array, gain: Array, h: Array, r: Array) -> Array:
    """Give the Joseph form ``(I - K H) P (I - K H)^T + K R K^T``, checked (:func:`checked_psd`)."""
    i_kh = np.eye(cov.shape[0]) - gain.dot(h)
    p = i_kh.dot(cov).dot(i_kh.T)
    p += gain.dot(r).dot(gain.T)
    return checked_psd(p)


class DynamicsCache:
    """``Phi(dt)``, ``Phi^T`` and ``Q(dt)`` of the dynamics, made once per step size."""

    def __init__(self, dynamics: NearlyConstantVelocity) -> None:
        self.dynamics = dynamics
        self._cache: dict[float, tuple[Array, Array, Array]] = {}

    def get(self, dt: float) -> tuple[Array, Array, Array]:
        """Give the transition, its transpose and the process noise of a step ``dt``."""
        out = self._cache.get(dt)
        if out is None:
            if len(self._cache) > 256:  # irregular times: keep the cache small
                self._cache.clear()
            phi = self.dynamics.transition(dt)
            out = (phi, np.ascontiguousarray(phi.T), self.dynamics.noise(dt))
            self._cache[dt] = out
        return out


def predict_rows(step: Step, x: Array) -> Array:
    """Give the predictions of a plan's step at filter states."""
    _, _, sens, parts, tmap, _, _, _, times, _ = step
    xt = x.dot(tmap.T) if x.ndim <= 2 else x @ tmap.T
    rel = (xt - sens).reshape(*x.shape[:-1], -1, 6)
    if len(parts) == 1:
        model, _, nu = parts[0]
        return model.predict(rel, times, nu, None)
    out = np.empty(rel.shape[:-1])
    for model, sl, nu in parts:
        out[..., sl] = model.predict(rel[..., sl, :], times[sl], nu, None)
    return out


def wrap_small(a: Array) -> Array:
    """Give ``wrap_angle(a)``, or ``a`` itself (no copy) when every entry is in (-pi, pi]."""
    flat = a.ravel().tolist()
    if flat and -math.pi < min(flat) and max(flat) <= math.pi:
        return a
    return wrap_angle(a)


def linearise(step: Step, x: Array) -> tuple[Array, Array, bool]:
    """Give the wrapped residual ``z - h(x)`` (m,) and the Jacobian ``H`` (m, n) at ``x``."""
    _, z, sens, parts, tmap, t3, _, angle, times, rows = step
    if rows is not None:
        return _linearise_rows(rows, x, x.shape[0] // 2)
    rel = (tmap.dot(x) - sens).reshape(-1, 6)
    pred = np.empty(rel.shape[0])
    d = np.zeros(rel.shape)
    for model, sl, nu in parts:
        model.values_and_derivatives_into(rel[sl], times[sl], pred[sl], d[sl], nu)
    h = d.dot(EYE_MAPS[x.shape[0]]) if t3 is None else np.einsum("mi,min->mn", d, t3)
    y = z - pred
    if angle is not None:
        y[angle] = wrap_angle(y[angle])
    return y, h, finite(y, h)


def _linearise_rows(rows: list[tuple], x: Array, dim: int) -> tuple[Array, Array, bool]:
    """:func:`linearise` in plain floats, row by row (``row_gradient`` of each kind)."""
    xs = x.tolist()
    if dim == 2:
        px, py, vx, vy = xs
        pz = vz = 0.0
    else:
        px, py, pz, vx, vy, vz = xs
    ys: list[float] = []
    hs: list[float] = []
    nan = float("nan")
    for fn, nu, t, dt, z, ang, s in rows:
        try:
            if dt:
                v, g0, g1, g2, g3, g4, g5 = fn(
                    (px + dt * vx - s[0], py + dt * vy - s[1], pz + dt * vz - s[2],
                     vx - s[3], vy - s[4], vz - s[5]), t, nu)
            else:
                v, g0, g1, g2, g3, g4, g5 = fn(
                    (px - s[0], py - s[1], pz - s[2], vx - s[3], vy - s[4], vz - s[5]), t, nu)
        except (ZeroDivisionError, OverflowError, ValueError):
            v = g0 = g1 = g2 = g3 = g4 = g5 = nan
        if ang:
            y = math.remainder(z - v, math.tau)
            ys.append(math.pi if y == -math.pi else y)
        else:
            ys.append(z - v)
        if dim == 2:
            hs += (g0, g1, g0 * dt + g3, g1 * dt + g4) if dt else (g0, g1, g3, g4)
        else:
            hs += (g0, g1, g2, g0 * dt + g3, g1 * dt + g4, g2 * dt + g5) if dt else \
                (g0, g1, g2, g3, g4, g5)
    m = len(ys)
    ys += hs
    both = np.array(ys)
    y_arr, h_arr = both[:m], both[m:].reshape(m, 2 * dim)
    # NaN or infinity anywhere makes the sum NaN or infinite; an overflow of a finite sum
    # is told apart by the arrays themselves.
    total = sum(ys)
    ok = total - total == 0.0 or bool(np.isfinite(both).all())
    return y_arr, h_arr, ok


def finite(y: Array, h: Array) -> bool:
    """Tell whether a residual and a Jacobian are finite (two dot products decide most cases)."""
    flat = h.reshape(-1)
    total = float(y.dot(y)) + float(flat.dot(flat))
    if total - total == 0.0:
        return True
    return bool(np.isfinite(y).all() and np.isfinite(h).all())


# -- the plan ---------------------------------------------------------------------------------

#: Updates of at most this many rows, all of kinds with a plain-float ``row_gradient``, are
#: linearised row by row in Python floats (cheaper than NumPy calls on so few numbers).
SCALAR_ROWS = 8


def _pattern(codes: IntArray, names: list[str], models: Mapping[str, MeasurementModel],
             nuisance: Mapping[str, Array]
             ) -> tuple[list[tuple[MeasurementModel, Index, Array]],
                        Index | None, dict[str, Index]]:
    """Give the kinds' parts ``(model, rows, nuisance)``, the angle rows, the kinds' index."""
    parts: list[tuple[MeasurementModel, Index, Array]] = []
    index: dict[str, Index] = {}
    angle = np.zeros(codes.shape[0], dtype=bool)
    for i, kind in enumerate(names):
        idx = np.flatnonzero(codes == i)
        if idx.size:
            sl = as_slice(idx)
            model = models[kind]
            parts.append((model, sl, nuisance[kind]))
            index[kind] = sl
            angle[sl] = model.is_angle
    ang = None if not angle.any() else as_slice(np.flatnonzero(angle))
    return parts, ang, index


def _state_map(dt: Array, dim: int) -> Array:
    """``T`` (m, 6, 2 dim): target states at rows ``dt`` (s) after the filter time."""
    m = dt.shape[0]
    out = np.zeros((m, 6, 2 * dim))
    for j in range(dim):
        out[:, j, j] = 1.0
        out[:, j, dim + j] = dt
        out[:, 3 + j, dim + j] = 1.0
    return out


def _diagonal_noise(var: Array, bounds: IntArray) -> list[Array]:
    """Give ``diag(var)`` of each update's rows, made per update size at once (views)."""
    sizes = np.diff(bounds)
    out: list[Array] = [np.empty((0, 0))] * sizes.shape[0]
    for m in np.unique(sizes).tolist():
        which = np.flatnonzero(sizes == m)
        stack = np.zeros((which.size, m, m))
        idx = np.arange(m)
        stack[:, idx, idx] = var[bounds[which][:, None] + idx]
        for j, r in zip(which.tolist(), stack, strict=True):
            out[j] = r
    return out


def _views(arr: Array, bounds: list[int], width: int = 1) -> list[Array]:
    """Give ``arr[width a:width b]`` for each update's rows ``a:b`` (views)."""
    sizes = {b - a for a, b in pairwise(bounds)}
    if len(sizes) == 1 and arr.shape[0] == width * bounds[-1]:
        return list(arr.reshape(len(bounds) - 1, -1))
    return [arr[width * a:width * b] for a, b in pairwise(bounds)]


class StepPlan:
    """Every update of a prepared set as a :data:`Step` (``ok`` False: a kind uses a reference)."""

    def __init__(self, prepared: PreparedMeasurements) -> None:
        self.dim = prepared.dim
        self.ok = not any(m.uses_reference for m in prepared.models.values())
        self.steps: list[Step] = []
        sizes = np.diff(prepared.bounds)
        if not self.ok or len(prepared) == 0:
            return
        names = list(prepared.models)
        codes = prepared.model_index
        update = np.repeat(np.arange(len(prepared)), sizes)
        # Rows of each update sorted by kind: every kind's rows become one slice.
        perm = np.lexsort((codes, update))
        codes = codes[perm]
        dt = prepared.time[perm] - prepared.times[update]
        values = prepared.values[perm]
        sens = prepared.sensor_state[perm]
        var = prepared.sigmas[perm] ** 2
        time, time_ref = prepared.time[perm], prepared.time_ref[perm]
        sensor, sigmas = prepared.sensor[perm], prepared.sigmas[perm]
        correlated = any(m.correlated_noise for m in prepared.models.values())
        scalar = all(m.has_row_gradient for m in prepared.models.values())
        recs = _row_records(_row_info(prepared.models, prepared.nuisance, names, codes),
                            time.tolist(), dt.tolist(), values, sens) if scalar else None
        patterns: dict[bytes, tuple[list, object, dict]] = {}
        maps: dict[bytes, tuple[Array, Array | None]] = {}
        bounds = prepared.bounds.tolist()
        code_bytes, width = codes.tobytes(), codes.itemsize
        moved = (np.add.reduceat(dt != 0.0, prepared.bounds[:-1]) > 0).tolist()
        flat_sens = sens.reshape(-1)
        noise = _diagonal_noise(var, prepared.bounds)
        update_times = prepared.times.tolist()
        value_k, sens_k, time_k = (_views(values, bounds), _views(flat_sens, bounds, 6),
                                   _views(time, bounds))
        for k in range(len(prepared)):
            a, b = bounds[k], bounds[k + 1]
            key = code_bytes[a * width:b * width]
            pat = patterns.get(key)
            if pat is None:
                pat = patterns[key] = _pattern(codes[a:b], names, prepared.models,
                                                prepared.nuisance)
            parts, angle, index = pat
            dkey = dt[a:b].tobytes() if moved[k] else b - a
            tm = maps.get(dkey)
            if tm is None:
                t3 = _state_map(dt[a:b], self.dim)
                tm = maps[dkey] = (t3.reshape(-1, 2 * self.dim), t3 if moved[k] else None)
            r = noise[k]
            if correlated:
                for rows, cov in correlated_blocks(prepared.models, index, time[a:b],
                                                   time_ref[a:b], sigmas[a:b], sensor[a:b]):
                    r[np.ix_(rows, rows)] = cov
            self.steps.append((update_times[k], value_k[k], sens_k[k], parts,
                               tm[0], tm[1], r, angle, time_k[k],
                               recs[a:b] if recs is not None and b - a <= SCALAR_ROWS
                               else None))



def _row_info(models: Mapping[str, MeasurementModel], nuisance: Mapping[str, Array],
              names: list[str], codes: IntArray) -> list[tuple]:
    """Give each row's ``row_gradient``, nuisance values and angle flag (its kind by code)."""
    info = [(models[k].row_gradient, tuple(nuisance[k].tolist()), models[k].is_angle)
            for k in names]
    return [info[c] for c in codes.tolist()]


def _row_records(info: list[tuple], time: list[float], dt: list[float], values: Array,
                 sens: Array) -> list[tuple]:
    """Give the rows as the plain-float records of :func:`linearise`."""
    return [(fn, nu, t, d, v, ang, s) for (fn, nu, ang), t, d, v, s in
            zip(info, time, dt, values.tolist(), sens.tolist(), strict=True)]


def plan_for(prepared: PreparedMeasurements) -> StepPlan:
    """Give the plan of a prepared set, made on first use and kept in its cache."""
    plan = prepared.cache.get("step_plan")
    if not isinstance(plan, StepPlan):
        plan = prepared.cache["step_plan"] = StepPlan(prepared)
    return plan


#: The map ``(6, n)`` from a filter state to the target state at the update time, per ``n``.
EYE_MAPS = {2 * d: _state_map(np.zeros(1), d)[0] for d in (2, 3)}


class RowSteps:
    """Steps, as a plan's, for rows handed over one update at a time (the step-by-step API)."""

    def __init__(self, dim: int, options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self.dim, self.options, self.nuisance = dim, options, nuisance
        self._patterns: dict[bytes, tuple | None] = {}

    def step(self, rows: MeasurementSet, t: float) -> Step | None:
        """Give the step of ``rows`` at filter time ``t``, or None where a group is needed."""
        dt = rows.time - t
        key = rows.kind_code.tobytes() + dt.tobytes()
        if key not in self._patterns:
            if len(self._patterns) > 256:  # irregular row times: keep the cache small
                self._patterns.clear()
            self._patterns[key] = self._pattern(rows, dt)
        pat = self._patterns[key]
        if pat is None:
            return None
        perm, parts, tmap, t3, angle, info, dts = pat
        values, sigmas, time, sens = rows.value_si, rows.sigma_si, rows.time, rows.sensor_state
        if perm is not None:
            values, sigmas, time, sens = values[perm], sigmas[perm], time[perm], sens[perm]
        recs = None if info is None else _row_records(info, time.tolist(), dts, values, sens)
        return (t, values, sens.reshape(-1), parts, tmap, t3, np.diag(sigmas * sigmas), angle,
                time, recs)

    def _pattern(self, rows: MeasurementSet, dt: Array) -> tuple | None:
        models, nus = resolve_models(rows.kinds, self.options, self.nuisance)
        if any(m.uses_reference or m.correlated_noise for m in models.values()):
            return None
        names = list(models)
        codes = model_codes(rows.kind_code, names)
        perm = np.argsort(codes, kind="stable")
        codes, dt = codes[perm], dt[perm]
        parts, angle, _ = _pattern(codes, names, models, nus)
        t3 = _state_map(dt, self.dim)
        info = None
        if codes.shape[0] <= SCALAR_ROWS and all(m.has_row_gradient for m in models.values()):
            info = _row_info(models, nus, names, codes)
        moved = bool(np.any(dt != 0.0))
        return (None if np.all(perm[:-1] < perm[1:]) else perm, parts,
                t3.reshape(-1, 2 * self.dim), t3 if moved else None, angle, info, dt.tolist())
