"""The general filter path's plan: a compiled set prepared once per file.

See :mod:`.general` for what a step does with it.  Everything here is made once per file: the
rows of each update sorted by kind (every kind's rows a slice), the linear map from the filter
state to the target states at the rows (one per pattern of row-time offsets), the noise
covariance of each update, the angle rows, and plain-float row records for the kinds with a
``row_gradient``.
"""

from __future__ import annotations

from itertools import pairwise
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..arrays import Array
from ..measurements import MeasurementModel
from ..observation.rows import Index, as_slice, correlated_blocks
from .general import Step

if TYPE_CHECKING:  # pragma: no cover
    from .compiled import CompiledMeasurements

#: Updates of at most this many rows, all of kinds with a plain-float ``row_gradient``, are
#: linearised row by row in Python floats (cheaper than NumPy calls on so few numbers).
SCALAR_ROWS = 8

def _state_map(dt: Array, dim: int) -> Array:
    """``T`` (m, 6, 2 dim): target states at rows ``dt`` (s) after the filter time."""
    m = dt.shape[0]
    out = np.zeros((m, 6, 2 * dim))
    for j in range(dim):
        out[:, j, j] = 1.0
        out[:, j, dim + j] = dt
        out[:, 3 + j, dim + j] = 1.0
    return out


def _diagonal_noise(var: Array, bounds: NDArray[np.int64]) -> list[Array]:
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
    """Give ``arr[width a:width b]`` for each update's rows ``a:b`` (views).

    When every update has as many rows, the rows of one reshape (made at once).
    """
    sizes = {b - a for a, b in pairwise(bounds)}
    if len(sizes) == 1 and arr.shape[0] == width * bounds[-1]:
        return list(arr.reshape(len(bounds) - 1, -1))
    return [arr[width * a:width * b] for a, b in pairwise(bounds)]


class StepPlan:
    """Every update of a compiled set, prepared for the general path (see the module text).

    Parameters
    ----------
    compiled : CompiledMeasurements
        The set compiled for the filter (its ``dim``, options and nuisance values).

    Attributes
    ----------
    ok : bool
        False when a kind uses an earlier reference sample (the group path is used).
    steps : list
        One :data:`Step` per update.
    sizes : numpy.ndarray
        Rows per update (K,).
    """

    def __init__(self, compiled: CompiledMeasurements) -> None:
        self.dim = compiled.dim
        self.ok = not any(m.uses_reference for m in compiled.models.values())
        self.steps: list[Step] = []
        self.sizes = np.diff(compiled.bounds)
        if not self.ok or len(compiled) == 0:
            return
        names = list(compiled.models)
        codes = compiled.model_index
        update = np.repeat(np.arange(len(compiled)), self.sizes)
        # Rows of each update sorted by kind: every kind's rows become one slice.
        perm = np.lexsort((codes, update))
        codes = codes[perm]
        dt = compiled.time[perm] - compiled.times[update]
        values = compiled.values[perm]
        sens = compiled.sensor_state[perm]
        var = compiled.sigmas[perm] ** 2
        time, time_ref = compiled.time[perm], compiled.time_ref[perm]
        sensor, sigmas = compiled.sensor[perm], compiled.sigmas[perm]
        correlated = any(m.correlated_noise for m in compiled.models.values())
        scalar = all(m.has_row_gradient for m in compiled.models.values())
        recs = self._records(compiled, names, codes, values, sens, dt, time) if scalar else None
        patterns: dict[bytes, tuple[list, object, dict]] = {}
        maps: dict[bytes, tuple[Array, Array | None]] = {}
        self.eye_map = _state_map(np.zeros(1), self.dim)[0]
        bounds = compiled.bounds.tolist()
        code_bytes, width = codes.tobytes(), codes.itemsize
        moved = (np.add.reduceat(dt != 0.0, compiled.bounds[:-1]) > 0).tolist()
        flat_sens = sens.reshape(-1)
        noise = _diagonal_noise(var, compiled.bounds)
        update_times = compiled.times.tolist()
        value_k, sens_k, time_k = (_views(values, bounds), _views(flat_sens, bounds, 6),
                                   _views(time, bounds))
        for k in range(len(compiled)):
            a, b = bounds[k], bounds[k + 1]
            key = code_bytes[a * width:b * width]
            pat = patterns.get(key)
            if pat is None:
                pat = patterns[key] = self._pattern(codes[a:b], names, compiled)
            parts, angle, index = pat
            dkey = dt[a:b].tobytes() if moved[k] else b - a
            tm = maps.get(dkey)
            if tm is None:
                t3 = _state_map(dt[a:b], self.dim)
                tm = maps[dkey] = (t3.reshape(-1, 2 * self.dim), t3 if moved[k] else None)
            r = noise[k]
            if correlated:
                for rows, cov in correlated_blocks(compiled.models, index, time[a:b],
                                                   time_ref[a:b], sigmas[a:b], sensor[a:b]):
                    r[np.ix_(rows, rows)] = cov
            self.steps.append((update_times[k], value_k[k], sens_k[k], parts,
                               tm[0], tm[1], r, angle, time_k[k],
                               recs[a:b] if recs is not None and b - a <= SCALAR_ROWS
                               else None))

    @staticmethod
    def _records(compiled: CompiledMeasurements, names: list[str], codes: NDArray[np.int64],
                 values: Array, sens: Array, dt: Array, time: Array) -> list[tuple]:
        """Give every row as a plain-float record for :func:`linearise` (kinds in order)."""
        info = [(compiled.models[k].row_gradient, tuple(compiled.nuisance[k].tolist()),
                 compiled.models[k].is_angle) for k in names]
        per_row = [info[c] for c in codes.tolist()]
        return [(fn, nu, t, d, v, ang, s) for (fn, nu, ang), t, d, v, s in
                zip(per_row, time.tolist(), dt.tolist(), values.tolist(),
                    sens.tolist(), strict=True)]

    @staticmethod
    def _pattern(codes: NDArray[np.int64], names: list[str], compiled: CompiledMeasurements
                 ) -> tuple[list[tuple[MeasurementModel, Index, Array]], object,
                            dict[str, Index]]:
        """Give the kinds' parts ``(model, rows, nuisance)``, the angle rows, the kinds' index."""
        parts: list[tuple[MeasurementModel, Index, Array]] = []
        index: dict[str, Index] = {}
        angle = np.zeros(codes.shape[0], dtype=bool)
        for i, kind in enumerate(names):
            idx = np.flatnonzero(codes == i)
            if idx.size:
                sl = as_slice(idx)
                model = compiled.models[kind]
                parts.append((model, sl, compiled.nuisance[kind]))
                index[kind] = sl
                angle[sl] = model.is_angle
        ang: object = None if not angle.any() else as_slice(np.flatnonzero(angle))
        return parts, ang, index


def plan_for(compiled: CompiledMeasurements) -> StepPlan:
    """Give the plan of a compiled set, made on first use and kept in its cache.

    Parameters
    ----------
    compiled : CompiledMeasurements
        The set compiled for the filter.

    Returns
    -------
    StepPlan
    """
    plan = compiled.cache.get("step_plan")
    if not isinstance(plan, StepPlan):
        plan = compiled.cache["step_plan"] = StepPlan(compiled)
    return plan
