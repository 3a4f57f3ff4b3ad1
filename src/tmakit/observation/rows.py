"""Rows of several kinds, each predicted by its measurement model (the observation core).

:class:`RowModel` gives predictions, Jacobians, the noise covariance with the correlated blocks
kinds declare (Chen & Sun, eq. 1) and the nuisance structure, through the kinds' hooks only: a
new kind needs no change here.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array, row_labels
from ..core.frames import wrap_angle
from ..data import KIND_CODES, MeasurementSet
from ..measurements import MeasurementModel, model_for

#: The rows of one kind: integer indices or a slice.
Index = NDArray[np.intp] | slice


def resolve_models(kinds: Iterable[str],
                   options: Mapping[str, Mapping[str, object]] | None = None,
                   nuisance: Mapping[str, float] | None = None
                   ) -> tuple[dict[str, MeasurementModel], dict[str, Array]]:
    """Make each kind's measurement model and its known nuisance vector."""
    options = dict(options or {})
    models: dict[str, MeasurementModel] = {}
    values: dict[str, Array] = {}
    for kind in kinds:
        model = model_for(kind, options.get(kind))
        try:
            nu = model.nuisance_vector(dict(nuisance or {}))
        except ValueError as err:
            raise ValueError(
                f"{err}: a filter needs the {kind} nuisance parameter(s) "
                f"({', '.join(model.nuisance_names)}) as known values, e.g. from a batch "
                "estimate (nuisance={...})") from None
        models[kind] = model
        values[kind] = nu
    return models, values


def nuisance_layout(models: Mapping[str, MeasurementModel],
                    tonals: Mapping[str, tuple[str, ...]] | None = None
                    ) -> tuple[tuple[str, ...], dict[str, slice]]:
    """Return the nuisance structure of several kinds."""
    names: list[str] = []
    slices: dict[str, slice] = {}
    for kind, model in models.items():
        start = len(names)
        labels = (tonals or {}).get(kind)
        names.extend(model.nuisance_names if labels is None else
                     [f"{n}[{lab}]" for lab in labels for n in model.nuisance_names])
        slices[kind] = slice(start, len(names))
    return tuple(names), slices


def tonal_groups(models: Mapping[str, MeasurementModel], index: Mapping[str, Index],
                 tonal: NDArray[np.str_] | None
                 ) -> dict[str, tuple[NDArray[np.intp], tuple[str, ...]]]:
    """Give each kind of two tonals or more its rows' tonal numbers and the tonal labels."""
    out: dict[str, tuple[NDArray[np.intp], tuple[str, ...]]] = {}
    for kind, model in models.items():
        if model.nuisance_by_tonal and tonal is not None and model.nuisance_names:
            labels, code = np.unique(tonal[index[kind]], return_inverse=True)
            if labels.size > 1:
                order = np.argsort(np.unique(code, return_index=True)[1])  # first appearance
                out[kind] = (np.argsort(order)[code.reshape(-1)], tuple(labels[order].tolist()))
    return out


def as_slice(index: Index) -> Index:
    """Return an index that is a run of consecutive rows as the equal slice (a view)."""
    if isinstance(index, slice):
        return index
    idx = np.asarray(index)
    if idx.ndim == 1 and idx.size and int(idx[-1]) - int(idx[0]) + 1 == idx.size:
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return index


def reference_span(models: Mapping[str, MeasurementModel], slices: Mapping[str, slice]
                   ) -> slice | None:
    """Return the slice covering every kind that uses an earlier reference sample."""
    spans = [slices[k] for k, m in models.items() if m.uses_reference]
    if not spans:
        return None
    return slice(min(s.start for s in spans), max(s.stop for s in spans))


class RowLayout:
    """Where each kind's rows sit in a block of ``m`` rows, shared by blocks of one pattern."""

    def __init__(self, models: Mapping[str, MeasurementModel], index: Mapping[str, Index],
                 m: int, tonal: NDArray[np.str_] | None = None) -> None:
        self.models = dict(models)
        self.index = dict(index)
        # A kind's rows: all (one kind), or its index, contiguous ones as a slice (a view).
        self.take: dict[str, Index] = ({k: slice(None) for k in self.models}
                                       if len(self.models) == 1 else
                                       {k: as_slice(i) for k, i in self.index.items()})
        self.angle = np.zeros(m, dtype=bool)
        for kind, model in self.models.items():
            if model.is_angle:
                self.angle[self.index[kind]] = True
        self.ref_take: dict[str, slice] = {}
        self.reference_slice: slice | None = None  # rows grouped by kind: the reference span
        self.reference: NDArray[np.intp] | None = None
        if all(isinstance(i, slice) for i in self.index.values()):
            span = reference_span(self.models, self.index)  # type: ignore[arg-type]
            if span is not None:
                self.reference_slice = span
                self.reference = np.arange(span.start, span.stop)
                for kind, model in self.models.items():
                    sl = self.index[kind]
                    if model.uses_reference and isinstance(sl, slice):
                        self.ref_take[kind] = slice(sl.start - span.start,
                                                    sl.stop - span.start)
        else:
            refs: list[NDArray[np.intp]] = []
            for kind, model in self.models.items():
                if model.uses_reference:
                    rows = np.arange(m)[self.index[kind]]
                    start = sum(r.size for r in refs)
                    self.ref_take[kind] = slice(start, start + rows.size)
                    refs.append(rows)
            self.reference = np.concatenate(refs) if refs else None
        #: The kinds of several tonals: their rows' tonal numbers and labels.
        self.tonals = tonal_groups(self.models, self.index, tonal)
        self.nuisance_names, self.nuisance_slices = nuisance_layout(
            self.models, {k: labels for k, (_, labels) in self.tonals.items()})

    def _spread(self, kind: str, x: Array, axis: int = -1) -> Array:
        """Put a kind's per-row nuisance columns (``axis``, ``k``) in its rows' tonal's columns."""
        if kind not in self.tonals:
            return x
        code, labels = self.tonals[kind]
        x = np.moveaxis(x, axis, -1)
        k = x.shape[-1]
        shape = [1] * x.ndim
        shape[x.ndim - 2 if axis == -1 else x.ndim - 3] = code.size
        cols = (code[:, None] * k + np.arange(k)).reshape(*shape[:-1], k)
        out = np.zeros((*x.shape[:-1], k * len(labels)))
        np.put_along_axis(out, np.broadcast_to(cols, x.shape), x, axis=-1)
        return np.moveaxis(out, -1, axis)

    def _per_row(self, kind: str, nu: Array) -> Array:
        """Give a kind's nuisance ``(..., k)`` or, with tonals, each row's ``(..., m_kind, k)``."""
        if kind not in self.tonals:
            return nu[..., None, :]
        code, labels = self.tonals[kind]
        return nu.reshape(*nu.shape[:-1], len(labels), -1)[..., code, :]


class RowModel:
    """Rows of several kinds predicted by their measurement models."""

    def __init__(self, models: Mapping[str, MeasurementModel], index: Mapping[str, Index],
                 time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike, sensor: ArrayLike,
                 sensor_state: ArrayLike, ref_sensor_state: ArrayLike,
                 layout: RowLayout | None = None, tonal: NDArray[np.str_] | None = None
                 ) -> None:
        self.time, self.time_ref = np.asarray(time, float), np.asarray(time_ref, float)
        self.sigma = np.asarray(sigma, dtype=float)
        self.sensor = np.asarray(sensor)
        self.sensor_state = np.asarray(sensor_state, dtype=float)
        self.ref_sensor_state = np.asarray(ref_sensor_state, dtype=float)
        if layout is None:
            layout = RowLayout(models, index, self.time.shape[0], tonal)
        self.layout = layout
        self.models, self.index = layout.models, layout.index
        self._take, self._ref_take = layout.take, layout.ref_take
        self.angle, self.reference = layout.angle, layout.reference
        self.reference_slice = layout.reference_slice
        self.nuisance_names, self.nuisance_slices = layout.nuisance_names, layout.nuisance_slices

    def __len__(self) -> int:
        """Return the number of rows ``m``."""
        return int(self.time.shape[0])

    def _nuisance(self, kind: str, nuisance: Mapping[str, Array] | Array | None
                  ) -> Array | None:
        if nuisance is None:
            return None
        if isinstance(nuisance, dict):  # (dict, not Mapping: this runs once per kind and step)
            nu = nuisance[kind]
            return nu if kind not in self.layout.tonals else self.layout._per_row(kind, nu)
        assert isinstance(nuisance, np.ndarray)  # (a mapping is a dict here)
        return self.layout._per_row(kind, nuisance[..., self.nuisance_slices[kind]])

    # -- relative states ---------------------------------------------------------------------
    def relative(self, target: Array, target_ref: Array | None = None,
                 sensor_state: ArrayLike | None = None) -> tuple[Array, Array | None]:
        """Return relative states (target minus sensor) from target states."""
        sensor = self.sensor_state if sensor_state is None else np.asarray(sensor_state, float)
        rel = target - sensor
        rel_ref = None
        if self.reference is not None and target_ref is not None:
            rel_ref = target_ref - self.ref_sensor_state[self.reference]
        return rel, rel_ref

    # -- predictions and Jacobians -----------------------------------------------------------
    def predict(self, rel: Array, rel_ref: Array | None = None,
                nuisance: Mapping[str, Array] | Array | None = None) -> Array:
        """Return predicted values (..., m), SI."""
        if len(self.models) == 1:  # one kind: its (new, writeable) predictions are the block's
            ((kind, model),) = self.models.items()
            ref = rel_ref if kind in self._ref_take else None
            pred = model.predict(rel, self.time, self._nuisance(kind, nuisance), ref)
            if (pred.shape == rel.shape[:-1] and pred.dtype == np.float64
                    and pred.flags.writeable and pred.base is None):
                return pred
            out = np.empty(rel.shape[:-1])
            out[...] = pred
            return out
        out = np.empty(rel.shape[:-1])
        for kind, model in self.models.items():
            rows = self._take[kind]
            ref = (rel_ref[..., self._ref_take[kind], :]
                   if kind in self._ref_take and rel_ref is not None else None)
            out[..., rows] = model.predict(rel[..., rows, :], self.time[rows],
                                           self._nuisance(kind, nuisance), ref)
        return out

    def jacobian(self, rel: Array, rel_ref: Array | None = None,
                 nuisance: Mapping[str, Array] | Array | None = None,
                 with_nuisance: bool = False) -> tuple[Array, Array | None, Array | None]:
        """Return the analytic derivatives of :meth:`predict`."""
        d = np.empty(rel.shape)
        d_ref = None if rel_ref is None else np.empty(rel_ref.shape)
        d_nu = None
        if with_nuisance:
            d_nu = np.zeros((*rel.shape[:-1], len(self.nuisance_names)))
        for kind, model in self.models.items():
            rows = self._take[kind]
            ref_rows = self._ref_take.get(kind)
            ref = None if ref_rows is None or rel_ref is None else rel_ref[..., ref_rows, :]
            jac = model.jacobian(rel[..., rows, :], self.time[rows],
                                 self._nuisance(kind, nuisance), ref)
            d[..., rows, :] = jac.rel
            if ref_rows is not None and d_ref is not None:
                d_ref[..., ref_rows, :] = jac.rel_ref
            if d_nu is not None:
                d_nu[..., rows, self.nuisance_slices[kind]] = self.layout._spread(kind,
                                                                                 jac.nuisance)
        return d, d_ref, d_nu

    def reference_rows(self, kind: str) -> slice | None:
        """Return where a kind's rows sit in arrays at the reference samples (None without)."""
        return self._ref_take.get(kind)

    # -- nuisance structure: predictions affine in the nuisance ------------------------------
    def const_design(self) -> Array:
        """Return ``A_const`` (m, k), the part of the nuisance design that ignores the geometry."""
        m, k = len(self), len(self.nuisance_names)
        out = np.zeros((m, k))
        if not k:  # no nuisance: no column
            return out
        rel = np.ones((m, 6))  # any finite geometry
        for kind, model in self.models.items():
            rows, ns = self._take[kind], self.nuisance_slices[kind]
            if ns.stop > ns.start:
                ref = rel[rows] if model.uses_reference else None
                out[rows, ns] = self.layout._spread(
                    kind, model.affine_parts(rel[rows], self.time[rows], ref)[1])
        return out

    def linearise_into(self, rel: Array, rel_ref: Array | None, h0: Array, a_var: Array,
                       d_h0: Array | None = None, d_h0_ref: Array | None = None
                       ) -> list[tuple[str, Array | None, Array | None]]:
        """Write the affine parts of the predictions, ``h0 + (A_const + A_var) @ nu``, in place."""
        d_a: list[tuple[str, Array | None, Array | None]] = []
        for kind, model in self.models.items():
            rows, ns = self._take[kind], self.nuisance_slices[kind]
            ref_rows = self._ref_take.get(kind)
            r_k = rel[..., rows, :]
            ref_k = None if ref_rows is None or rel_ref is None else rel_ref[..., ref_rows, :]
            t = self.time[rows]
            spread = self.layout._spread
            if d_h0 is None:
                h0[..., rows], _, v = model.affine_parts(r_k, t, ref_k)
                a_var[..., rows, ns] = spread(kind, v)
                continue
            if (ns.stop == ns.start and ref_k is None and not model.uses_reference
                    and isinstance(rows, slice)):  # (views: written in place)
                model.values_and_derivatives_into(r_k, t, h0[..., rows], d_h0[..., rows, :])
                continue  # no nuisance, no reference: written in place
            base, _, v, d0, d0_ref, da, da_ref = model.affine_derivatives(r_k, t, ref_k)
            h0[..., rows], a_var[..., rows, ns] = base, spread(kind, v)
            if d0 is not None:
                d_h0[..., rows, :] = d0
            if d0_ref is not None and d_h0_ref is not None and ref_rows is not None:
                d_h0_ref[..., ref_rows, :] = d0_ref
            if ns.stop > ns.start and (da is not None or da_ref is not None):
                d_a.append((kind, None if da is None else spread(kind, da, -2),
                             None if da_ref is None else spread(kind, da_ref, -2)))
        return d_a

    def residual(self, measured: ArrayLike, predicted: ArrayLike) -> Array:
        """Return ``measured - predicted`` (..., m), angle rows wrapped to (-pi, pi]."""
        diff = np.asarray(measured, dtype=float) - np.asarray(predicted, dtype=float)
        return np.where(self.angle, wrap_angle(diff), diff)

    # -- noise -------------------------------------------------------------------------------
    def correlated_blocks(self, singletons: bool = True
                          ) -> list[tuple[NDArray[np.intp], Array]]:
        """Return the noise blocks that are not diagonal."""
        return correlated_blocks(self.models, self.index, self.time, self.time_ref,
                                 self.sigma, self.sensor, singletons, self.ref_sensor_state)

    def covariance(self) -> Array:
        """Return the noise covariance ``R`` (m, m), SI squared, with the correlated blocks."""
        r = np.diag(self.sigma**2)
        for rows, cov in self.correlated_blocks():
            r[np.ix_(rows, rows)] = cov
        return r


#: Most rows of one sensor whose spans overlap in one chain (one dense correlated noise block;
#: its covariance and eigen-decomposition take about 5 * 8 * n^2 bytes and n^3 operations).
MAX_GROUP_ROWS = 4096


def overlapping_groups(rows: NDArray[np.intp], time: Array, time_ref: Array,
                       singletons: bool = True) -> Iterator[NDArray[np.intp]]:
    """Split rows into groups whose spans ``(time_ref, time]`` overlap (transitively)."""
    if rows.shape[0] == 0:
        return
    order = np.argsort(time_ref[rows], kind="stable")
    start, end = time_ref[rows][order], time[rows][order]
    # a new group starts where a span begins at or after the end of every earlier span
    reach = np.maximum.accumulate(end)
    cut = np.flatnonzero(start[1:] >= reach[:-1]) + 1
    bounds = np.concatenate(([0], cut, [rows.shape[0]]))
    for lo, hi in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
        if hi - lo > 1 or singletons:
            yield np.sort(rows[order[lo:hi]])


def shared_reference_groups(rows: NDArray[np.intp], time: Array, ref_state: Array | None,
                            singletons: bool = True) -> Iterator[NDArray[np.intp]]:
    """Split differences between sensors into the groups at one time with one reference."""
    if rows.shape[0] == 0:
        return
    key = time[rows][:, None]
    if ref_state is not None:
        key = np.concatenate([key, ref_state[rows, :3]], axis=1)
    label, _ = row_labels(key)
    order = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.diff(label[order])) + 1
    for g in np.split(order, cuts):
        if g.shape[0] > 1 or singletons:
            yield rows[np.sort(g)]


def correlated_blocks(models: Mapping[str, MeasurementModel], index: Mapping[str, Index],
                      time: Array, time_ref: Array, sigma: Array, sensor: NDArray[Any],
                      singletons: bool = True, ref_state: Array | None = None
                      ) -> list[tuple[NDArray[np.intp], Array]]:
    """Return the correlated noise blocks of a set of rows."""
    blocks: list[tuple[NDArray[np.intp], Array]] = []
    m = time.shape[0]
    for kind, model in models.items():
        if not model.correlated_noise:
            continue
        rows = np.arange(m)[index[kind]]
        if model.between_sensors:
            for g in shared_reference_groups(rows, time, ref_state, singletons):
                _check_group_size(g.shape[0])
                blocks.append((g, model.noise_covariance(time[g], time_ref[g], sigma[g])))
            continue
        for s in np.unique(sensor[rows]):
            own = rows[sensor[rows] == s]
            for g in overlapping_groups(own, time, time_ref, singletons):
                _check_group_size(g.shape[0])
                blocks.append((g, model.noise_covariance(time[g], time_ref[g], sigma[g])))
    return blocks


def _check_group_size(n: int) -> None:
    """Refuse one chain of overlapping rows too large for a dense covariance."""
    if n > MAX_GROUP_ROWS:
        raise ValueError(
            f"{n:,} range differences of one sensor share pulse intervals (their spans "
            f"time_ref..time overlap in one chain, e.g. one time_ref for all): their noise is "
            f"one dense {n:,} x {n:,} covariance, more than the limit of {MAX_GROUP_ROWS:,} "
            "rows (its memory grows with the square, its time with the cube); use differences "
            "between consecutive samples, or fewer rows (--from/--to)")


def group_by_kind(meas: MeasurementSet, kinds: list[str]
                  ) -> tuple[dict[str, slice], NDArray[np.intp] | None]:
    """Group the rows of a set by kind: each kind's slice of the grouped order, and that order."""
    n = len(meas)
    if len(kinds) <= 1:
        return {k: slice(0, n) for k in kinds}, None
    code = meas.kind_code
    order = None
    if not bool(np.all(code[1:] >= code[:-1])):
        order = np.argsort(code, kind="stable")
        code = code[order]
    ends = np.searchsorted(code, [KIND_CODES[k] for k in kinds], side="right").tolist()
    return {k: slice(a, b) for k, a, b in zip(kinds, [0, *ends[:-1]], ends, strict=True)}, order


def angle_runs(models: Mapping[str, MeasurementModel], slices: Mapping[str, slice], m: int
               ) -> tuple[bool, bool, slice | None]:
    """Tell whether some and all of ``m`` rows grouped by kind are angles, and where."""
    runs = sorted((sl.start, sl.stop) for kind, sl in slices.items()
                  if models[kind].is_angle and sl.stop > sl.start)
    count = sum(stop - start for start, stop in runs)
    # Disjoint runs form one run when their span holds no other row.
    one = bool(runs) and runs[-1][1] - runs[0][0] == count
    return count > 0, count == m, slice(runs[0][0], runs[-1][1]) if one else None
