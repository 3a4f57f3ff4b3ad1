"""A group of measurement rows predicted from a filter state.

The filters hold the target state ``[position, velocity]`` (see :mod:`.dynamics`) at one time
``t``.  A row taken at another time ``t_i`` (a group may mix times, sensors and kinds) is
predicted from the state moved there at constant velocity, ``x(t_i) = Phi(t_i - t) x(t)``; a
range difference also needs the state at its earlier sample, moved back the same way (the
back-propagated trajectory of 003_e5155d4fe60daef8.txt §2.3-2.4).  The measurement models of
:mod:`tmakit.measurements` do the rest, with their analytic Jacobians.

Nuisance parameters (carrier, power constant, ...) must be known to a filter: pass their values
(``{"carrier": 9.4e9}``); a batch estimate gives them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..frames import wrap_angle
from ..measurements import MeasurementModel, model_for, range_difference_covariance
from ..motion.dynamics import state_names

Array = NDArray[np.float64]


#: Rows whose times differ by less than this (s) are taken at one time.
TIME_TOLERANCE = 1e-9


def embedding(dt: Array, dim: int) -> Array:
    """``d rel6 / d x`` for rows ``dt`` seconds after the filter time: ``(m, 6, 2 dim)``.

    The 6-vector is the (3-D) target state at the row's time; a 2-D state has z = vz = 0."""
    dt = np.asarray(dt, dtype=float)
    out = np.zeros((dt.shape[0], 6, 2 * dim))
    idx = np.arange(dim)
    out[:, idx, idx] = 1.0
    out[:, idx, idx + dim] = dt[:, None]
    out[:, idx + 3, idx + dim] = 1.0
    return out


def resolve_models(kinds: Iterable[str],
                   options: Mapping[str, Mapping[str, object]] | None = None,
                   nuisance: Mapping[str, float] | None = None
                   ) -> tuple[dict[str, MeasurementModel], dict[str, Array]]:
    """The measurement model of each kind and its nuisance vector (known values): raises a
    clear error when a kind needs a nuisance value that was not given."""
    options = dict(options or {})
    models: dict[str, MeasurementModel] = {}
    values: dict[str, Array] = {}
    for kind in kinds:
        model = model_for(kind, **dict(options.get(kind, {})))
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


class MeasurementGroup:
    """Rows of a :class:`~tmakit.data.MeasurementSet` to be used in one filter update at
    time ``t`` (s).

    ``dim``: 2 or 3 (filter state ``2 dim`` long); ``options``: per-kind model options as for
    :class:`~tmakit.observation.ObservationModel`; ``nuisance``: known values of the nuisance
    parameters of the kinds present.

    Attributes: ``rows`` (the MeasurementSet), ``time``, ``dim``, ``values`` and ``sigmas``
    (SI), ``models``/``index``/``nuisance`` per kind, ``angle`` (rows whose residuals wrap),
    ``dt``/``dt_ref`` (row times and reference times minus ``t``), ``covariance`` (R, SI).
    :meth:`from_arrays` builds one from precomputed columns without a MeasurementSet (the
    filters' fast path, :mod:`.compiled`); ``rows`` is then made on first use.
    """

    def __init__(self, rows: MeasurementSet, t: float, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        if len(rows) == 0:
            raise ValueError("a measurement group needs at least one row")
        models, nus = resolve_models(rows.kinds, options, nuisance)
        index = {kind: np.flatnonzero(rows.kind == kind) for kind in models}
        self._setup(t, dim, models, nus, index, rows.value_si, rows.sigma_si, rows.time,
                    rows.time_ref, rows.sensor_state, rows.ref_sensor_state, rows.sensor)
        self._rows: MeasurementSet | None = rows
        self._rows_factory: Callable[[], MeasurementSet] | None = None

    @classmethod
    def from_arrays(cls, t: float, dim: int, models: Mapping[str, MeasurementModel],
                    nuisance: Mapping[str, Array], index: Mapping[str, NDArray[np.int64]],
                    values: Array, sigmas: Array, time: Array, time_ref: Array,
                    sensor_state: Array, ref_sensor_state: Array, sensor: NDArray[np.str_],
                    rows: Callable[[], MeasurementSet]) -> MeasurementGroup:
        """A group from columns already in SI (``models``/``nuisance`` from
        :func:`resolve_models`, ``index`` the rows of each kind); ``rows`` makes the
        MeasurementSet when someone asks for it."""
        if len(values) == 0:
            raise ValueError("a measurement group needs at least one row")
        self = cls.__new__(cls)
        self._setup(t, dim, dict(models), dict(nuisance), dict(index), values, sigmas, time,
                    time_ref, sensor_state, ref_sensor_state, sensor)
        self._rows = None
        self._rows_factory = rows
        return self

    def _setup(self, t: float, dim: int, models: dict[str, MeasurementModel],
               nuisance: dict[str, Array], index: dict[str, NDArray[np.int64]], values: Array,
               sigmas: Array, time: Array, time_ref: Array, sensor_state: Array,
               ref_sensor_state: Array, sensor: NDArray[np.str_]) -> None:
        self.time = float(t)
        self.dim = int(dim)
        self.values = values
        self.sigmas = sigmas
        self.models = models
        self.index = index
        self.nuisance = nuisance
        self._time = time
        self._time_ref = time_ref
        self._sensor_state = sensor_state
        self._ref_sensor_state = ref_sensor_state
        self._sensor = sensor
        self.angle = np.zeros(len(values), dtype=bool)
        for kind, model in models.items():
            if model.is_angle:
                self.angle[index[kind]] = True
        self.dt = time - self.time
        self.dt_ref = time_ref - self.time
        self._cov: Array | None = None
        self._emb: Array | None = None
        self._emb_ref: Array | None = None

    @property
    def rows(self) -> MeasurementSet:
        """The rows as a :class:`~tmakit.data.MeasurementSet`."""
        if self._rows is None:
            assert self._rows_factory is not None
            self._rows = self._rows_factory()
        return self._rows

    def __len__(self) -> int:
        return int(self.values.shape[0])

    @property
    def covariance(self) -> Array:
        """Noise covariance ``R`` (SI): independent rows, except range differences of one
        sensor that share pulse intervals (003_e5155d4fe60daef8.txt eq. 1)."""
        if self._cov is None:
            r = np.diag(self.sigmas**2)
            rd = self.index.get("range_difference")
            if rd is not None:
                r[np.ix_(rd, rd)] = range_difference_covariance(
                    self._time[rd], self._time_ref[rd], self.sigmas[rd], self._sensor[rd])
            self._cov = r
        return self._cov

    @property
    def _embed(self) -> Array:
        if self._emb is None:
            self._emb = embedding(self.dt, self.dim)
        return self._emb

    @property
    def _embed_ref(self) -> Array | None:
        rd = self.index.get("range_difference")
        if rd is None:
            return None
        if self._emb_ref is None:
            self._emb_ref = embedding(self.dt_ref[rd], self.dim)
        return self._emb_ref

    def _target6(self, x: Array, dt: Array) -> Array:
        """Target 6-vectors ``(..., m, 6)`` at times ``t + dt`` from states ``(..., 2 dim)``."""
        d = self.dim
        pos, vel = x[..., None, :d], x[..., None, d:]
        out = np.zeros((*x.shape[:-1], dt.shape[0], 6))
        out[..., :d] = pos + dt[:, None] * vel
        out[..., 3:3 + d] = vel
        return out

    def _relative(self, x: Array, kind: str) -> tuple[Array, Array | None]:
        idx = self.index[kind]
        rel = self._target6(x, self.dt[idx]) - self._sensor_state[idx]
        rel_ref = None
        if kind == "range_difference":
            rel_ref = self._target6(x, self.dt_ref[idx]) - self._ref_sensor_state[idx]
        return rel, rel_ref

    def _check_state(self, x: Array) -> None:
        if x.ndim == 0 or x.shape[-1] != 2 * self.dim:
            raise ValueError(f"states must have {2 * self.dim} components "
                             f"({', '.join(state_names(self.dim))}); got shape {x.shape}")

    def predict(self, x: ArrayLike) -> Array:
        """Predicted values (SI) ``(..., m)`` for states ``(..., 2 dim)`` (particles,
        sigma points)."""
        x = np.asarray(x, dtype=float)
        self._check_state(x)
        out = np.empty((*x.shape[:-1], len(self)))
        for kind, model in self.models.items():
            idx = self.index[kind]
            rel, rel_ref = self._relative(x, kind)
            out[..., idx] = model.predict(rel, self._time[idx], self.nuisance[kind], rel_ref)
        return out

    def jacobian(self, x: ArrayLike) -> Array:
        """``d predict / d x`` ``(m, 2 dim)`` at one state ``x``."""
        x = np.asarray(x, dtype=float)
        self._check_state(x)
        out = np.empty((len(self), 2 * self.dim))
        for kind, model in self.models.items():
            idx = self.index[kind]
            rel, rel_ref = self._relative(x, kind)
            jac = model.jacobian(rel, self._time[idx], self.nuisance[kind], rel_ref)
            h = np.einsum("mi,mij->mj", jac.rel, self._embed[idx])
            if jac.rel_ref is not None:
                h += np.einsum("mi,mij->mj", jac.rel_ref, self._embed_ref)
            out[idx] = h
        return out

    def residual(self, predicted: ArrayLike, measured: ArrayLike | None = None) -> Array:
        """``measured - predicted`` (SI), angles wrapped to (-pi, pi]; ``measured`` defaults
        to the group's values.  Broadcasts over leading axes of ``predicted``."""
        z = self.values if measured is None else np.asarray(measured, dtype=float)
        diff = z - np.asarray(predicted, dtype=float)
        return np.where(self.angle, wrap_angle(diff), diff)


def group_times(meas: MeasurementSet) -> list[NDArray[np.int64]]:
    """Row indices of ``meas`` grouped by measurement time (ascending)."""
    order = np.argsort(meas.time, kind="stable")
    t = meas.time[order]
    breaks = np.flatnonzero(np.diff(t) > TIME_TOLERANCE) + 1
    return np.split(order, breaks)
