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

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..frames import wrap_angle
from ..measurements import MeasurementModel, model_for, range_difference_covariance

Array = NDArray[np.float64]


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


class MeasurementGroup:
    """Rows of a :class:`~tmakit.data.MeasurementSet` to be used in one filter update at
    time ``t`` (s).

    ``dim``: 2 or 3 (filter state ``2 dim`` long); ``options``: per-kind model options as for
    :class:`~tmakit.observation.ObservationModel`; ``nuisance``: known values of the nuisance
    parameters of the kinds present.
    """

    def __init__(self, rows: MeasurementSet, t: float, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        if len(rows) == 0:
            raise ValueError("a measurement group needs at least one row")
        options = dict(options or {})
        self.rows = rows
        self.time = float(t)
        self.dim = int(dim)
        self.values = rows.value_si
        self.sigmas = rows.sigma_si
        self.models: dict[str, MeasurementModel] = {}
        self.index: dict[str, NDArray[np.int64]] = {}
        self.nuisance: dict[str, Array] = {}
        for kind in rows.kinds:
            model = model_for(kind, **dict(options.get(kind, {})))
            try:
                nu = model.nuisance_vector(dict(nuisance or {}))
            except ValueError as err:
                raise ValueError(
                    f"{err}: a filter needs the {kind} nuisance parameter(s) "
                    f"({', '.join(model.nuisance_names)}) as known values, e.g. from a batch "
                    "estimate (nuisance={...})") from None
            self.models[kind] = model
            self.index[kind] = np.flatnonzero(rows.kind == kind)
            self.nuisance[kind] = nu
        self.angle = np.zeros(len(rows), dtype=bool)
        for kind, model in self.models.items():
            if model.is_angle:
                self.angle[self.index[kind]] = True
        self.dt = rows.time - self.time
        self.dt_ref = rows.time_ref - self.time
        self._embed = embedding(self.dt, self.dim)
        rd = self.index.get("range_difference")
        self._embed_ref = (embedding(self.dt_ref[rd], self.dim) if rd is not None else None)
        self.covariance = self._covariance()

    def __len__(self) -> int:
        return len(self.rows)

    def _covariance(self) -> Array:
        """Noise covariance ``R`` (SI): independent rows, except range differences of one
        sensor that share pulse intervals (003_e5155d4fe60daef8.txt eq. 1)."""
        r = np.diag(self.sigmas**2)
        rd = self.index.get("range_difference")
        if rd is not None:
            rows = self.rows
            block = range_difference_covariance(rows.time[rd], rows.time_ref[rd],
                                                self.sigmas[rd], rows.sensor[rd])
            r[np.ix_(rd, rd)] = block
        return r

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
        rows = self.rows
        rel = self._target6(x, self.dt[idx]) - rows.sensor_state[idx]
        rel_ref = None
        if kind == "range_difference":
            rel_ref = self._target6(x, self.dt_ref[idx]) - rows.ref_sensor_state[idx]
        return rel, rel_ref

    def predict(self, x: ArrayLike) -> Array:
        """Predicted values (SI) ``(..., m)`` for states ``(..., 2 dim)`` (particles,
        sigma points)."""
        x = np.asarray(x, dtype=float)
        out = np.empty((*x.shape[:-1], len(self.rows)))
        for kind, model in self.models.items():
            rel, rel_ref = self._relative(x, kind)
            out[..., self.index[kind]] = model.predict(rel, self.rows.time[self.index[kind]],
                                                       self.nuisance[kind], rel_ref)
        return out

    def jacobian(self, x: ArrayLike) -> Array:
        """``d predict / d x`` ``(m, 2 dim)`` at one state ``x``."""
        x = np.asarray(x, dtype=float)
        out = np.empty((len(self.rows), 2 * self.dim))
        for kind, model in self.models.items():
            idx = self.index[kind]
            rel, rel_ref = self._relative(x, kind)
            jac = model.jacobian(rel, self.rows.time[idx], self.nuisance[kind], rel_ref)
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
