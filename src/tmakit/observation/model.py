"""The observation model: a measurement set's rows predicted from motion parameters.

The Jacobian is ``d value / d rel x d state / d theta`` plus ``d value / d nuisance`` (nuisance
shared by a kind's rows, or by a tonal's: ``carrier[LABEL]``).  Rows are grouped by kind
(:attr:`ObservationModel.order`); the ``*_grouped`` methods work in that order, the others in
the set's own.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.blas import matmul
from ..core.frames import wrap_angle
from ..data import MeasurementSet
from ..measurements import MeasurementModel, model_for, options_with_metadata
from ..motion import MotionModel
from .affine_rows import AffineRows
from .planar import Linearisation, planar_kind, planar_linearisation, planar_values
from .rows import RowModel, group_by_kind


class ObservationModel:
    """Predict every row of ``meas`` from motion parameters ``theta`` and nuisance ``nu``.

    ``theta`` may carry leading batch axes ``(..., p)``, the nuisance the same ``(..., k)``.

    Parameters
    ----------
    meas, motion : MeasurementSet, MotionModel
    options : mapping, optional
        Per-kind model options, e.g. ``{"frequency": {"drift": True}}``.
    """

    def __init__(self, meas: MeasurementSet, motion: MotionModel,
                 options: Mapping[str, Mapping[str, object]] | None = None) -> None:
        kinds = meas.kinds
        options = options_with_metadata(kinds, options, meas.metadata)
        self.options = options  #: the per-kind model options, given or stated by the file
        self.motion = motion
        self.models: dict[str, MeasurementModel] = {k: model_for(k, options.get(k))
                                                     for k in kinds}
        self._set_rows(meas, *group_by_kind(meas, list(self.models)))
        g = self.grouped
        # Affine motion models: relative states by one matrix product (see _states_minus).
        self._rel_map = self._relative_map(self._time, self._sensor)
        self._rel_map_ref = (None if self._ref is None else self._relative_map(
            g.time_ref[self._ref], g.ref_sensor_state[self._ref]))
        self._const_design: Array | None = None
        #: The affine row map and the one kind's model of the planar path, or None.
        self.planar_kind: tuple[AffineRows, MeasurementModel] | None = planar_kind(self)

    def _set_rows(self, meas: MeasurementSet, slices: dict[str, slice],
                  order: NDArray[np.intp] | None) -> None:
        """Hold the set's rows, grouped by kind, and their observation core."""
        self.meas = meas
        #: Each kind's rows, a contiguous slice of the grouped order.
        self.slices = slices
        #: Grouped order is the set's own (one kind, or kinds already in blocks).
        self.in_set_order = order is None
        self._order: NDArray[np.intp] | None = order  # None: the identity, made when first used
        self._inverse: NDArray[np.intp] | None = None if order is None else np.argsort(order)
        self.grouped: MeasurementSet = meas if order is None else meas.take(order)
        self._time: Array = self.grouped.time
        self._sensor: Array = self.grouped.sensor_state
        self.values, self.sigmas = meas.value_si, meas.sigma_si
        self.values_grouped = self._to_grouped(self.values)
        self.sigmas_grouped = self._to_grouped(self.sigmas)
        self._set_row_model()
        self.angle_mask = self._to_set_order(self.angle_mask_grouped)
        self._angles = any(self.models[k].is_angle and sl.stop > sl.start  # (no pass over rows)
                           for k, sl in slices.items())

    @property
    def order(self) -> NDArray[np.intp]:
        """The set's rows in grouped order: grouped row ``j`` is the set's row ``order[j]``."""
        if self._order is None:
            self._order = np.arange(len(self.meas))
        return self._order

    @property
    def inverse(self) -> NDArray[np.intp]:
        """Each of the set's rows' position in the grouped order (the inverse of :attr:`order`)."""
        return self.order if self._inverse is None else self._inverse

    @property
    def rows(self) -> dict[str, NDArray[np.intp]]:
        """Each kind's rows of the set, ascending (its slice of :attr:`order`), in kind order."""
        order = self.order
        return {k: order[sl] for k, sl in self.slices.items()}

    def _set_row_model(self) -> None:
        """Build the observation core of the grouped rows (per-kind predictions, designs)."""
        g = self.grouped
        self.row_model = RowModel(self.models, self.slices, self._time, g.time_ref,
                                  self.sigmas_grouped, g.sensor_code, self._sensor,
                                  g.ref_sensor_state, tonal=g.tonal)
        self.nuisance_names = self.row_model.nuisance_names
        self.nuisance_slices = self.row_model.nuisance_slices
        #: The rows of kinds with an earlier reference sample (a slice of the grouped order).
        self._ref = self.row_model.reference_slice
        self.has_reference = self._ref is not None
        self.angle_mask_grouped = self.row_model.angle

    def _to_grouped(self, x: Array) -> Array:
        """Return rows ``(..., n)`` of the set in grouped order (no copy when they agree)."""
        return x if self.in_set_order else x[..., self.order]

    def _to_set_order(self, x: Array, axis: int = -1) -> Array:
        """Return grouped rows (along ``axis``) in the set's order (no copy when they agree)."""
        if self.in_set_order:
            return x
        return x[..., self.inverse] if axis == -1 else x[..., self.inverse, :]

    def squared_ranges(self, theta: ArrayLike) -> Array:
        """Return the squared distance (n,), m^2, from each row's sensor to the target (grouped).

        Parameters
        ----------
        theta : array_like
            Motion parameters ``(p,)``, SI.

        Returns
        -------
        ndarray
        """
        theta = self.motion.check_theta(np.asarray(theta, dtype=float))
        if self._rel_map is not None and theta.ndim == 1:  # the positions alone
            x, y, z = self._rel_map.single(theta, components=3)
        else:
            rel, _ = self._relative(theta, ref=False)
            x, y, z = rel[..., 0], rel[..., 1], rel[..., 2]
        out = x * x
        out += y * y
        out += z * z
        return cast(Array, out)

    def take(self, index: ArrayLike) -> ObservationModel:
        """Return the model of the rows ``index``, reusing this model's per-row arrays.

        Parameters
        ----------
        index : array_like
            Integer indices or a boolean mask.

        Returns
        -------
        ObservationModel
        """
        idx = np.asarray(index)
        idx = np.flatnonzero(idx) if idx.dtype == bool else idx.astype(np.intp, copy=False)
        meas = self.meas.take(idx)
        slices, order = group_by_kind(meas, list(self.models))
        if any(sl.stop == sl.start for sl in slices.values()) or self.row_model.layout.tonals:
            return ObservationModel(meas, self.motion, self.options)  # (its nuisance anew)
        grouped_idx = idx if order is None else idx[order]  # the new grouped rows, set rows
        pick = grouped_idx if self._inverse is None else self._inverse[grouped_idx]  # ours
        sub = object.__new__(ObservationModel)
        sub.options = {k: dict(v) for k, v in self.options.items()}
        sub.motion, sub.models = self.motion, self.models
        sub._set_rows(meas, slices, order)
        # Our map's sensor states at pick are the new grouped ones: not gathered again.
        sub._rel_map = (None if self._rel_map is None
                        else self._rel_map.take(pick, sensor=sub._sensor))
        sub._rel_map_ref = (None if sub._ref is None or self._rel_map_ref is None
                            or self._ref is None
                            else self._rel_map_ref.take(pick[sub._ref] - self._ref.start))
        sub._const_design = None if self._const_design is None else self._const_design[pick]
        sub.planar_kind = planar_kind(sub)
        return sub

    @property
    def n_nuisance(self) -> int:
        """Number ``k`` of nuisance parameters."""
        return len(self.nuisance_names)

    def nuisance_vector(self, values: Mapping[str, float] | None) -> Array:
        """Return the nuisance vector ``(k,)`` from a mapping, defaults filled in.

        Parameters
        ----------
        values : mapping or None
            Nuisance values by name, SI.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            When a value without default is missing.
        """
        values = dict(values or {})
        parts = []
        for kind, m in self.models.items():
            for label in self.row_model.layout.tonals.get(kind, (None, (None,)))[1]:
                given = {n: values[f"{n}[{label}]"] for n in m.nuisance_names
                         if f"{n}[{label}]" in values}
                parts.append(m.nuisance_vector({**values, **given}))
        return np.concatenate(parts) if parts else np.zeros(0)

    # -- grouped order (for solvers) ---------------------------------------------------------
    def _relative_map(self, times: Array, sensor: Array) -> AffineRows | None:
        """Map ``theta`` to relative states, ``theta @ matrix + offset`` (None: not affine)."""
        terms = self.motion.component_terms(times)
        if terms is None:
            return None
        # The offset minus the sensor states made when used (planar bearings: two components).
        return AffineRows(terms[0], terms[1], self.motion.n_params, sensor)

    def _states_minus(self, theta: Array, times: Array, sensor: Array,
                      rel_map: AffineRows | None, batch_inner: bool = False,
                      each: bool = False) -> Array:
        """Relative states ``(..., m, 6)`` of the target at ``times`` seen from ``sensor``."""
        if rel_map is None:
            return self.motion.states_minus(theta, times, sensor)
        m = times.shape[0]
        if theta.ndim == 1 or (theta.ndim == 2 and theta.shape[0] == 1):
            return rel_map.single(theta)
        if each and theta.ndim == 2:
            return np.stack([rel_map.single(t) for t in theta])
        if batch_inner and theta.ndim == 2:
            flat = matmul(np.ascontiguousarray(rel_map.matrix.T), theta.T)
            flat += rel_map.flat_offset[:, None]
            return flat.reshape(6, m, theta.shape[0]).transpose(2, 1, 0)
        flat = matmul(theta, rel_map.matrix)
        flat += rel_map.flat_offset
        return flat.reshape(*theta.shape[:-1], 6, m).swapaxes(-1, -2)

    def _relative(self, theta: Array, batch_inner: bool = False, each: bool = False,
                  ref: bool = True) -> tuple[Array, Array | None]:
        """Relative states (..., n, 6), grouped, and (..., n_rd, 6) at references (or None)."""
        theta = self.motion.check_theta(theta)
        rel = self._states_minus(theta, self._time, self._sensor, self._rel_map, batch_inner,
                                 each)
        rel_ref = None
        if ref and self._ref is not None:
            g, sl = self.grouped, self._ref
            rel_ref = self._states_minus(theta, g.time_ref[sl], g.ref_sensor_state[sl],
                                         self._rel_map_ref, batch_inner, each)
        return rel, rel_ref

    @property
    def const_design(self) -> Array:
        """``A_const`` ``(n, k)`` in grouped order, computed once."""
        if self._const_design is None:
            self._const_design = self.row_model.const_design()
        return self._const_design

    def linearisation(self, theta: ArrayLike, derivatives: bool = True, each: bool = False,
                      weights: Array | None = None) -> Linearisation:
        """Linearise the predictions ``h0 + (A_const + A_var) @ nu`` in grouped order.

        Parameters
        ----------
        theta : array_like
            Motion parameters ``(..., p)``, SI.
        derivatives : bool
            Also compute the derivatives.
        each : bool
            Each row of a 2-D ``theta`` bit for bit as for it alone.
        weights : ndarray, optional
            ``(n,)`` inverse std of independent rows, to whiten the Jacobian.

        Returns
        -------
        Linearisation
        """
        theta = np.asarray(theta, dtype=float)
        if (lin := (planar_linearisation(self, theta, weights) if derivatives
                    else planar_values(self, theta))) is not None:
            return lin  # one planar kind, affine motion, one theta: only what it needs
        n, k = len(self.meas), self.n_nuisance
        # Values only, for many parameter vectors (a grid): batch axis innermost in memory.
        inner = not derivatives and theta.ndim == 2 and theta.shape[0] > n
        rel, rel_ref = self._relative(theta, inner, each)
        if derivatives and k == 0 and rel_ref is None and len(self.models) == 1:
            # One kind without nuisance (bearings only): its arrays as they come, no copies.
            h0, _, a_var, d0, *_ = next(iter(self.models.values())).affine_derivatives(
                rel, self._time)
            if d0 is not None and d0.flags.writeable and d0.shape == rel.shape:
                lin = Linearisation(self, theta, h0 if h0.flags.owndata else h0.copy(), a_var)
                lin.d_h0, lin.relative = d0, rel
                return lin
        batch = rel.shape[:-2]
        if inner:
            h0 = np.empty((n, batch[0])).T
            a_var = np.zeros((k, n, batch[0])).transpose(2, 1, 0)
        else:  # the design column-major: solvers use its transpose (..., k, n)
            h0 = np.empty((*batch, n))
            a_var = np.zeros((*batch, k, n)).swapaxes(-1, -2)
        lin = Linearisation(self, theta, h0, a_var)
        lin.relative = rel
        if derivatives:  # component-major, like rel: the formulas run along the rows
            lin.d_h0 = np.zeros((*batch, 6, n)).swapaxes(-1, -2)
            if rel_ref is not None:
                lin.d_h0_ref = np.zeros_like(rel_ref)
        lin.d_a = self.row_model.linearise_into(rel, rel_ref, h0, a_var, lin.d_h0,
                                                lin.d_h0_ref)
        return lin

    def predict_grouped(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        """Return :meth:`predict` in grouped order.

        Parameters
        ----------
        theta, nuisance : array_like
            Motion ``(..., p)`` and nuisance ``(..., k)`` parameters (default zeros), SI.

        Returns
        -------
        ndarray
            ``(..., n)``, SI.
        """
        theta = np.asarray(theta, dtype=float)
        nu = np.zeros(0) if nuisance is None else np.asarray(nuisance, dtype=float)
        rel, rel_ref = self._relative(theta)
        return self.row_model.predict(rel, rel_ref, nu)

    def jacobian_grouped(self, theta: ArrayLike, nuisance: ArrayLike | None = None,
                         each: bool = False) -> tuple[Array, Array]:
        """Return :meth:`jacobian` in grouped order.

        Parameters
        ----------
        theta, nuisance : array_like
            Motion ``(..., p)`` and nuisance ``(..., k)`` parameters (default zeros), SI.
        each : bool
            As for :meth:`linearisation`.

        Returns
        -------
        j_theta, j_nuisance : ndarray
            ``(..., n, p)`` and ``(..., n, k)``, SI.
        """
        lin = self.linearisation(theta, derivatives=True, each=each)
        nu = np.zeros(self.n_nuisance) if nuisance is None else np.asarray(nuisance, float)
        return lin.jacobian(nu), self.const_design + lin.a_var

    # -- the set's own row order -------------------------------------------------------------
    def predict(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        """Return predicted values for every row.

        Parameters
        ----------
        theta : array_like
            Motion parameters ``(..., p)``, SI.
        nuisance : array_like, optional
            Nuisance vector ``(..., k)`` (default: empty, for sets without nuisance).

        Returns
        -------
        ndarray
            ``(..., n)``, SI (rad, m, m/s, Hz, dBW).
        """
        return self._to_set_order(self.predict_grouped(theta, nuisance))

    def jacobian(self, theta: ArrayLike, nuisance: ArrayLike | None = None
                 ) -> tuple[Array, Array]:
        """Return the Jacobians with respect to ``theta`` and the nuisance.

        Parameters
        ----------
        theta, nuisance
            As for :meth:`predict`.

        Returns
        -------
        j_theta, j_nuisance : ndarray
            ``d value / d theta`` (..., n, p) and ``d value / d nuisance`` (..., n, k), SI.
        """
        j_theta, j_nu = self.jacobian_grouped(theta, nuisance)
        return self._to_set_order(j_theta, -2), self._to_set_order(j_nu, -2)

    def affine(self, theta: ArrayLike) -> tuple[Array, Array]:
        """Return ``(h0, A)`` with predictions ``h0 + A @ nuisance``.

        Parameters
        ----------
        theta : array_like
            Motion parameters ``(..., p)``, SI.

        Returns
        -------
        h0, a : ndarray
            (..., n) and (..., n, k), SI.
        """
        lin = self.linearisation(theta, derivatives=False)
        inv = self.inverse
        return lin.h0[..., inv], (self.const_design + lin.a_var)[..., inv, :]

    def residuals(self, theta: ArrayLike, nuisance: ArrayLike | None = None) -> Array:
        """Return measured minus predicted, angles wrapped to (-pi, pi].

        Parameters
        ----------
        theta, nuisance
            As for :meth:`predict`.

        Returns
        -------
        ndarray
            ``(..., n)``, SI.
        """
        res = self.values - self.predict(theta, nuisance)
        if not self._angles:  # (in C order, as np.where gives it: the same sums downstream)
            return np.ascontiguousarray(res)
        return np.where(self.angle_mask, wrap_angle(res), res)
