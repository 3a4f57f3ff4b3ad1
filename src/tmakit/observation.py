"""The observation model: a measurement set's rows predicted from motion parameters.

Joins a :class:`~tmakit.motion.MotionModel`, the sensor states recorded in a
:class:`~tmakit.data.MeasurementSet` and one :class:`~tmakit.measurements.MeasurementModel` per
kind.  The batch Jacobian is the chain ``d value / d rel  x  d state / d theta`` (the sensor is
known, so ``d rel / d state`` is the identity), plus ``d value / d nuisance``.

Nuisance parameters are shared by all rows of a kind; their vector is the concatenation of
each kind's :attr:`~tmakit.measurements.MeasurementModel.nuisance_names` in kind order.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .data import MeasurementSet
from .frames import wrap_angle
from .measurements import MeasurementModel, model_for
from .motion import MotionModel


class ObservationModel:
    """Predict every row of ``meas`` from motion parameters ``theta`` and nuisance ``nu``.

    ``options`` maps a kind to its model's constructor options, e.g.
    ``{"frequency": {"drift": True}, "power": {"exponent": None}}``.
    """

    def __init__(self, meas: MeasurementSet, motion: MotionModel,
                 options: Mapping[str, Mapping[str, object]] | None = None) -> None:
        options = dict(options or {})
        self.meas = meas
        self.motion = motion
        self.models: dict[str, MeasurementModel] = {
            k: model_for(k, **dict(options.get(k, {}))) for k in meas.kinds
        }
        self.rows = {k: np.flatnonzero(meas.kind == k) for k in self.models}
        names: list[str] = []
        self.nuisance_slices: dict[str, slice] = {}
        for k, m in self.models.items():
            start = len(names)
            names.extend(m.nuisance_names)
            self.nuisance_slices[k] = slice(start, len(names))
        self.nuisance_names = tuple(names)
        self.has_reference = bool(np.any(meas.kind == "range_difference"))
        self.ref_rows = np.flatnonzero(np.isfinite(meas.time_ref))
        self.angle_mask = np.zeros(len(meas), dtype=bool)
        for k, m in self.models.items():
            if m.is_angle:
                self.angle_mask[self.rows[k]] = True
        self.values = meas.value_si
        self.sigmas = meas.sigma_si

    @property
    def n_nuisance(self) -> int:
        return len(self.nuisance_names)

    def nuisance_vector(self, values: Mapping[str, float] | None) -> NDArray[np.float64]:
        """Nuisance vector from a mapping (defaults such as ``carrier_drift = 0`` filled in)."""
        parts = [m.nuisance_vector(dict(values or {})) for m in self.models.values()]
        return np.concatenate(parts) if parts else np.zeros(0)

    def _relative(self, theta: NDArray[np.float64]) -> tuple[NDArray, NDArray | None]:
        meas = self.meas
        rel = self.motion.states(theta, meas.time) - meas.sensor_state
        rel_ref = None
        if self.has_reference:
            rel_ref = np.full(rel.shape, np.nan)
            r = self.ref_rows
            rel_ref[..., r, :] = (self.motion.states(theta, meas.time_ref[r])
                                  - meas.ref_sensor_state[r])
        return rel, rel_ref

    def predict(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> NDArray[np.float64]:
        """Predicted values (SI) for every row, shape ``(..., n)``."""
        theta = np.asarray(theta, dtype=float)
        nu = np.zeros(0) if nuisance is None else np.asarray(nuisance, dtype=float)
        rel, rel_ref = self._relative(theta)
        out = np.empty(rel.shape[:-1])
        t = self.meas.time
        for k, m in self.models.items():
            idx = self.rows[k]
            out[..., idx] = m.predict(
                rel[..., idx, :], t[idx], nu[..., self.nuisance_slices[k]][..., None, :],
                None if rel_ref is None else rel_ref[..., idx, :])
        return out

    def affine_parts(self, theta: ArrayLike
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(h0, A_const, A_var)``: predictions are ``h0 + (A_const + A_var) @ nuisance``,
        ``A_const`` independent of the geometry (see
        :meth:`~tmakit.measurements.MeasurementModel.affine_parts`)."""
        theta = np.asarray(theta, dtype=float)
        rel, rel_ref = self._relative(theta)
        h0 = np.empty(rel.shape[:-1])
        const = np.zeros((*rel.shape[:-1], self.n_nuisance))
        var = np.zeros((*rel.shape[:-1], self.n_nuisance))
        t = self.meas.time
        for k, m in self.models.items():
            idx = self.rows[k]
            base, c, v = m.affine_parts(rel[..., idx, :], t[idx],
                                        None if rel_ref is None else rel_ref[..., idx, :])
            h0[..., idx] = base
            const[..., idx, self.nuisance_slices[k]] = c
            var[..., idx, self.nuisance_slices[k]] = v
        return h0, const, var

    def affine(self, theta: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(h0 (..., n), A (..., n, k))`` with predictions ``h0 + A @ nuisance``."""
        h0, const, var = self.affine_parts(theta)
        return h0, const + var

    def jacobian(self, theta: ArrayLike, nuisance: ArrayLike | None = None
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(d value / d theta (..., n, p), d value / d nuisance (..., n, k))``."""
        theta = np.asarray(theta, dtype=float)
        nu = np.zeros(0) if nuisance is None else np.asarray(nuisance, dtype=float)
        meas = self.meas
        rel, rel_ref = self._relative(theta)
        dstate = self.motion.jacobian(theta, meas.time)  # (..., n, 6, p)
        j_theta = np.zeros((*rel.shape[:-1], self.motion.n_params))
        j_nu = np.zeros((*rel.shape[:-1], self.n_nuisance))
        dstate_ref = None
        if self.has_reference:
            dstate_ref = np.zeros(dstate.shape)
            r = self.ref_rows
            dstate_ref[..., r, :, :] = self.motion.jacobian(theta, meas.time_ref[r])
        for k, m in self.models.items():
            idx = self.rows[k]
            jac = m.jacobian(rel[..., idx, :], meas.time[idx],
                             nu[..., self.nuisance_slices[k]][..., None, :],
                             None if rel_ref is None else rel_ref[..., idx, :])
            j = np.einsum("...i,...ip->...p", jac.rel, dstate[..., idx, :, :])
            if jac.rel_ref is not None and dstate_ref is not None:
                j = j + np.einsum("...i,...ip->...p", jac.rel_ref, dstate_ref[..., idx, :, :])
            j_theta[..., idx, :] = j
            j_nu[..., idx, self.nuisance_slices[k]] = jac.nuisance
        return j_theta, j_nu

    def residuals(self, theta: ArrayLike, nuisance: ArrayLike | None = None
                  ) -> NDArray[np.float64]:
        """measured - predicted (SI), angles wrapped to (-pi, pi]."""
        res = self.values - self.predict(theta, nuisance)
        return np.where(self.angle_mask, wrap_angle(res), res)
