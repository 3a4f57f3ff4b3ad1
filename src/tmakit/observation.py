"""The observation model: a measurement set's rows predicted from motion parameters.

Joins a :class:`~tmakit.motion.MotionModel`, the sensor states recorded in a
:class:`~tmakit.data.MeasurementSet` and one :class:`~tmakit.measurements.MeasurementModel` per
kind.  The batch Jacobian is the chain ``d value / d rel  x  d state / d theta`` (the sensor is
known, so ``d rel / d state`` is the identity), plus ``d value / d nuisance``.

Nuisance parameters are shared by all rows of a kind; their vector is the concatenation of
each kind's :attr:`~tmakit.measurements.MeasurementModel.nuisance_names` in kind order.

Internally the rows are grouped by kind (:attr:`ObservationModel.order`) so that every kind is
a contiguous slice; the ``*_grouped`` methods work in that order (solvers use them, since row
order does not matter to a fit) and the public methods return the set's own row order.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .data import MeasurementSet
from .frames import wrap_angle
from .measurements import MeasurementModel, model_for
from .motion import MotionModel

Array = NDArray[np.float64]


class ObservationModel:
    """Predict every row of ``meas`` from motion parameters ``theta`` and nuisance ``nu``.

    ``options`` maps a kind to its model's constructor options, e.g.
    ``{"frequency": {"drift": True}, "power": {"exponent": None}}``.  ``theta`` may carry
    leading batch axes ``(..., p)``; ``nuisance`` then has the same leading axes ``(..., k)``.
    """

    def __init__(self, meas: MeasurementSet, motion: MotionModel,
                 options: Mapping[str, Mapping[str, object]] | None = None) -> None:
        options = {k: dict(v) for k, v in dict(options or {}).items()}
        self.options = options  #: the per-kind model options, as given
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
        # Rows grouped by kind: each kind a contiguous slice of the grouped order.
        self.order = (np.concatenate([self.rows[k] for k in self.models])
                      if self.models else np.zeros(0, dtype=int))
        self.inverse = np.argsort(self.order)
        self.grouped = meas.take(self.order)
        self.slices: dict[str, slice] = {}
        start = 0
        for k in self.models:
            self.slices[k] = slice(start, start + self.rows[k].size)
            start += self.rows[k].size
        g = self.grouped
        self._time = g.time
        self._sensor = g.sensor_state
        self._ref = self.slices.get("range_difference")
        self.has_reference = self._ref is not None
        self.angle_mask_grouped = np.zeros(len(meas), dtype=bool)
        for k, m in self.models.items():
            if m.is_angle:
                self.angle_mask_grouped[self.slices[k]] = True
        self.angle_mask = self.angle_mask_grouped[self.inverse]
        self.values = meas.value_si
        self.sigmas = meas.sigma_si
        self.values_grouped = self.values[self.order]
        self.sigmas_grouped = self.sigmas[self.order]

    @property
    def n_nuisance(self) -> int:
        return len(self.nuisance_names)

    def nuisance_vector(self, values: Mapping[str, float] | None) -> Array:
        """Nuisance vector from a mapping (defaults such as ``carrier_drift = 0`` filled in)."""
        parts = [m.nuisance_vector(dict(values or {})) for m in self.models.values()]
        return np.concatenate(parts) if parts else np.zeros(0)

    # -- grouped order (for solvers) ---------------------------------------------------------
    def _relative(self, theta: Array) -> tuple[Array, Array | None]:
        """Relative states (..., n, 6) in grouped order, and (..., n_rd, 6) at the reference
        times of the range differences (None without range differences)."""
        rel = self.motion.states(theta, self._time) - self._sensor
        rel_ref = None
        if self._ref is not None:
            g = self.grouped
            sl = self._ref
            rel_ref = (self.motion.states(theta, g.time_ref[sl]) - g.ref_sensor_state[sl])
        return rel, rel_ref

    def _ref_for(self, kind: str, rel_ref: Array | None) -> Array | None:
        return rel_ref if kind == "range_difference" else None

    def linearise_grouped(self, theta: ArrayLike, derivatives: bool = True
                          ) -> tuple[Array, Array, Array, Array | None, Array | None]:
        """In grouped order, one pass: ``(h0, A_const, A_var, dh0, dA)`` with predictions
        ``h0 + (A_const + A_var) @ nu`` (see
        :meth:`~tmakit.measurements.MeasurementModel.affine_derivatives`) and, if asked,
        ``dh0`` ``(..., n, p)`` and ``dA`` ``(..., n, k, p)`` their derivatives with respect to
        ``theta``: ``d predictions / d theta = dh0 + dA @ nu`` for any ``nu``."""
        theta = np.asarray(theta, dtype=float)
        rel, rel_ref = self._relative(theta)
        batch = rel.shape[:-1]
        k, p = self.n_nuisance, self.motion.n_params
        h0 = np.empty(batch)
        a_const = np.zeros((*batch, k))
        a_var = np.zeros((*batch, k))
        dh0 = np.empty((*batch, p)) if derivatives else None
        d_a = np.zeros((*batch, k, p)) if derivatives else None
        t = self._time
        motion = self.motion
        for kind, m in self.models.items():
            sl, ns = self.slices[kind], self.nuisance_slices[kind]
            r_k, ref_k = rel[..., sl, :], self._ref_for(kind, rel_ref)
            if not derivatives:
                base, c, v = m.affine_parts(r_k, t[sl], ref_k)
                h0[..., sl], a_const[..., sl, ns], a_var[..., sl, ns] = base, c, v
                continue
            base, c, v, d0, d0_ref, da, da_ref = m.affine_derivatives(r_k, t[sl], ref_k)
            h0[..., sl], a_const[..., sl, ns], a_var[..., sl, ns] = base, c, v
            j0 = motion.chain(d0, theta, t[sl])
            if d0_ref is not None:
                j0 = j0 + motion.chain(d0_ref, theta, self.grouped.time_ref[sl])
            dh0[..., sl, :] = j0
            if c.shape[-1]:
                # chain() works on (..., m, 6): put the nuisance axis in front of the rows.
                ja = np.swapaxes(motion.chain(np.swapaxes(da, -2, -3), theta, t[sl]), -2, -3)
                if da_ref is not None:
                    ja = ja + np.swapaxes(motion.chain(np.swapaxes(da_ref, -2, -3), theta,
                                                       self.grouped.time_ref[sl]), -2, -3)
                d_a[..., sl, ns, :] = ja
        return h0, a_const, a_var, dh0, d_a

    def predict_grouped(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        theta = np.asarray(theta, dtype=float)
        nu = np.zeros(0) if nuisance is None else np.asarray(nuisance, dtype=float)
        rel, rel_ref = self._relative(theta)
        out = np.empty(rel.shape[:-1])
        t = self._time
        for k, m in self.models.items():
            sl, ns = self.slices[k], self.nuisance_slices[k]
            out[..., sl] = m.predict(rel[..., sl, :], t[sl], nu[..., ns][..., None, :],
                                     self._ref_for(k, rel_ref))
        return out

    def jacobian_grouped(self, theta: ArrayLike, nuisance: ArrayLike | None = None
                         ) -> tuple[Array, Array]:
        _, a_const, a_var, dh0, d_a = self.linearise_grouped(theta, derivatives=True)
        assert dh0 is not None and d_a is not None
        nu = np.zeros(self.n_nuisance) if nuisance is None else np.asarray(nuisance, float)
        return dh0 + np.einsum("...nkp,...k->...np", d_a, nu), a_const + a_var

    # -- the set's own row order -------------------------------------------------------------
    def predict(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        """Predicted values (SI) for every row, shape ``(..., n)``."""
        return self.predict_grouped(theta, nuisance)[..., self.inverse]

    def jacobian(self, theta: ArrayLike, nuisance: ArrayLike | None = None
                 ) -> tuple[Array, Array]:
        """``(d value / d theta (..., n, p), d value / d nuisance (..., n, k))``."""
        j_theta, j_nu = self.jacobian_grouped(theta, nuisance)
        return j_theta[..., self.inverse, :], j_nu[..., self.inverse, :]

    def affine_parts(self, theta: ArrayLike) -> tuple[Array, Array, Array]:
        """``(h0, A_const, A_var)``: predictions are ``h0 + (A_const + A_var) @ nuisance``,
        ``A_const`` independent of the geometry (see
        :meth:`~tmakit.measurements.MeasurementModel.affine_parts`)."""
        h0, c, v, _, _ = self.linearise_grouped(theta, derivatives=False)
        inv = self.inverse
        return h0[..., inv], c[..., inv, :], v[..., inv, :]

    def affine(self, theta: ArrayLike) -> tuple[Array, Array]:
        """``(h0 (..., n), A (..., n, k))`` with predictions ``h0 + A @ nuisance``."""
        h0, const, var = self.affine_parts(theta)
        return h0, const + var

    def residuals(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        """measured - predicted (SI), angles wrapped to (-pi, pi]."""
        res = self.values - self.predict(theta, nuisance)
        return np.where(self.angle_mask, wrap_angle(res), res)
