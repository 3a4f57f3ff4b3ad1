"""The measurement-model interface.

A measurement model maps relative states (target minus sensor, ``(..., n, 6)``, see
:mod:`tmakit.core.frames`) and its nuisance parameters to predicted values in SI units, and gives
the analytic Jacobian with respect to both.  It knows nothing about motion models or sensors.
Leading axes of ``rel`` are independent problems (particles, Monte Carlo runs).

``nuisance`` is an array broadcastable to ``(..., n, k)`` for ``k`` nuisance parameters: a
plain ``(k,)`` vector for one problem, ``(B, 1, k)`` for a batch of ``B`` problems.

Time enters only where the physics needs it: the carrier drift of :class:`Frequency`.  Range
differences (:class:`RangeDifference`) also take the relative state at the earlier sample.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from .geometry import as_rel, dot3, inverse_range_and_unit, zeros_nuisance
from .values import Jacobian, ValueRange

__all__ = ["Jacobian", "MeasurementModel", "ValueRange", "as_rel", "dot3",
           "inverse_range_and_unit", "zeros_nuisance"]


class MeasurementModel:
    """One kind of measurement.

    Subclasses set the class attributes and implement :meth:`predict` and :meth:`jacobian`.

    Per-kind special cases are hooks here, so that a new kind is one file plus its
    registration in :data:`tmakit.measurements.KINDS`: :attr:`value_range` (checked by the
    file reader, :meth:`check_values`), :attr:`uses_reference` (an earlier sample),
    :attr:`correlated_noise` and :meth:`noise_covariance` (the noise of rows of one sensor),
    :attr:`nuisance_names` and :meth:`affine_parts` (the nuisance structure),
    :attr:`mirror_symmetric` and :attr:`gives_height` (the sensor-plane ambiguity),
    :attr:`scale_free` and :attr:`height_blind` (what the observability words and the height
    check of :mod:`tmakit.batch.height` need),
    :attr:`wrap_period` (how simulated values are written).
    """

    #: Name used in files (the ``kind`` column).
    kind: str = ""
    #: Unit of ``value`` and ``sigma`` in files.
    file_unit: str = ""
    #: value_SI = value_file * file_scale + file_offset; sigma_SI = sigma_file * file_scale.
    file_scale: float = 1.0
    file_offset: float = 0.0
    #: Residuals of angles are wrapped to (-pi, pi].
    is_angle: bool = False
    #: Needs the relative state at an earlier reference sample (``time_ref``).
    uses_reference: bool = False
    #: Needs the target velocity (it is not a function of position alone).
    uses_velocity: bool = False
    #: The values a file may hold (file units); None: any finite value.
    value_range: ValueRange | None = None
    #: Rows of one sensor have correlated noise (:meth:`noise_covariance` is not diagonal).
    correlated_noise: bool = False
    #: A difference between two sensors at one time (``tdoa``, ``fdoa``): the reference
    #: sample is the reference sensor's at the row's own time, and the rows whose noise is
    #: correlated are those at one time sharing the reference sensor (not those of one sensor).
    between_sensors: bool = False
    #: Predictions do not change when the target is mirrored through a horizontal plane of
    #: the sensors (the sensor-plane ambiguity of 3-D tracking; elevation breaks it).
    mirror_symmetric: bool = False
    #: The kind measures height above the sensor, so a set holding it is 3-D.
    gives_height: bool = False
    #: Predictions do not change when the relative state (target minus sensor, position and
    #: velocity) is scaled: angles alone, which cannot give range.
    scale_free: bool = False
    #: Predictions depend on the horizontal relative state only (a bearing): the height of the
    #: emitter above the sensors changes nothing.
    height_blind: bool = False
    #: Simulated values are written wrapped into ``[0, wrap_period)`` (SI; None: not wrapped),
    #: as files carry bearings in [0, 360) degrees.
    wrap_period: float | None = None

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the model options a measurement set's metadata states (a file's ``# key:``).

        Parameters
        ----------
        metadata : mapping of str to str
            The set's metadata.

        Returns
        -------
        dict
            Constructor options; empty for kinds that read none (explicit options win).
        """
        return {}

    @classmethod
    def check_values(cls, values: ArrayLike) -> NDArray[np.bool_]:
        """Tell where file values (file units, e.g. degrees) are valid for this kind.

        Parameters
        ----------
        values : array_like
            Values in :attr:`file_unit`.

        Returns
        -------
        ndarray of bool
            Same shape as ``values``; all True when the kind has no :attr:`value_range`.
        """
        if cls.value_range is None:
            return np.ones(np.shape(values), dtype=bool)
        return cls.value_range.contains(values)

    @classmethod
    def describe_values(cls) -> str | None:
        """Say what a valid file value of this kind is, for error messages.

        Returns
        -------
        str or None
            E.g. "a frequency > 0 Hz"; None when any finite value is valid.
        """
        return None if cls.value_range is None else cls.value_range.describe(cls.file_unit)

    def noise_covariance(self, time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike,
                         sensor: ArrayLike | None = None) -> Array:
        """Give the noise covariance of rows of this kind (SI units squared).

        Parameters
        ----------
        time, time_ref : array_like
            Row times and reference times (m,), s (``time_ref``: if :attr:`uses_reference`).
        sigma : array_like
            Standard deviations (m,), SI.
        sensor : array_like, optional
            Sensor ids (m,): rows of different sensors are independent.

        Returns
        -------
        ndarray
            (m, m); ``diag(sigma^2)`` unless the kind has :attr:`correlated_noise`.
        """
        return np.diag(np.asarray(sigma, dtype=float) ** 2)

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """Names of this model's nuisance parameters (shared by all its samples).

        Returns
        -------
        tuple of str
            Empty for kinds without nuisance parameters.
        """
        return ()

    def default_nuisance(self) -> dict[str, float]:
        """Give the nuisance values used when a caller gives none.

        Returns
        -------
        dict of str to float
            Default values by nuisance name, in the nuisance parameters' SI units.
        """
        return {}

    def nuisance_vector(self, values: dict[str, float] | None) -> Array:
        """Give the nuisance vector in :attr:`nuisance_names` order, defaults filled in.

        Parameters
        ----------
        values : dict of str to float or None
            Nuisance values by name, SI; missing ones come from :meth:`default_nuisance`.

        Returns
        -------
        ndarray
            ``(k,)`` nuisance vector, SI units.

        Raises
        ------
        ValueError
            If a nuisance parameter has neither a value nor a default.
        """
        merged = {**self.default_nuisance(), **(values or {})}
        missing = [n for n in self.nuisance_names if n not in merged]
        if missing:
            raise ValueError(f"{self.kind}: nuisance parameter(s) {', '.join(missing)} "
                             "have no value")
        return np.array([float(merged[n]) for n in self.nuisance_names])

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict the measured values.

        Parameters
        ----------
        rel : array_like
            Relative states (target minus sensor) ``(..., n, 6)``: position m, velocity m/s.
        t : array_like, optional
            Sample times ``(n,)``, s (only kinds whose values depend on time use them).
        nuisance : array_like, optional
            Nuisance parameters broadcastable to ``(..., n, k)``, SI (if the kind has any).
        rel_ref : array_like, optional
            Relative states at the earlier samples, like ``rel`` (if :attr:`uses_reference`).

        Returns
        -------
        ndarray
            Predicted values ``rel.shape[:-1]``, SI units (rad, m, m/s, Hz, dBW).

        Raises
        ------
        NotImplementedError
            Always, in the base class; kinds raise ValueError for bad or missing inputs.
        """
        raise NotImplementedError

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the analytic derivatives of :meth:`predict`.

        Parameters
        ----------
        rel, t, nuisance, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        Jacobian
            Derivatives with respect to ``rel``, ``rel_ref`` and the nuisance parameters.

        Raises
        ------
        NotImplementedError
            As for :meth:`predict`.
        """
        raise NotImplementedError

    #: Whether :meth:`row_gradient` is implemented (plain floats for one row).
    has_row_gradient = False

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give one row's prediction and its derivatives in plain floats.

        Filters with a handful of rows per update (:mod:`tmakit.filters.general`) call it in
        place of :meth:`predict_gradient`, whose NumPy calls cost more than the arithmetic on
        so few numbers; kinds that have it set :attr:`has_row_gradient`.

        Parameters
        ----------
        rel : tuple of float
            The relative state ``(x, y, z, vx, vy, vz)`` (m, m/s).
        t : float
            Sample time (s).
        nuisance : tuple of float
            The kind's nuisance values (SI), in :attr:`nuisance_names` order.

        Returns
        -------
        tuple of float
            The value (SI) followed by its six derivatives with respect to ``rel``.

        Raises
        ------
        NotImplementedError
            Unless the kind implements it.
        """
        raise NotImplementedError(f"{self.kind}: no plain-float row_gradient")

    def predict_gradient(self, rel: Array, t: Array | None = None,
                         nuisance: Array | None = None) -> tuple[Array, Array]:
        """Give the predictions and their derivatives with respect to ``rel`` in one pass.

        The filters' step (:mod:`tmakit.filters.general`) calls it once per kind and update;
        kinds override it to share the work of :meth:`predict` and :meth:`jacobian`.  Not for
        kinds that :attr:`uses_reference`.

        Parameters
        ----------
        rel, t, nuisance
            As for :meth:`predict` (``rel`` an array ``(..., n, 6)``, m and m/s).

        Returns
        -------
        values : ndarray
            ``rel.shape[:-1]``, SI units (rad, m, m/s, Hz, dBW).
        d_rel : ndarray
            ``rel.shape``: d value / d relative state (SI per m, per m/s).
        """
        return (self.predict(rel, t, nuisance, None),
                self.jacobian(rel, t, nuisance, None).rel)

    def affine(self, rel: ArrayLike, t: ArrayLike | None = None,
               rel_ref: ArrayLike | None = None) -> tuple[Array, Array]:
        """Split the prediction as ``h0 + A @ nuisance`` (every nuisance enters linearly).

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        h0 : ndarray
            ``(..., n)``, SI units of the value.
        A : ndarray
            ``(..., n, k)``, value units per nuisance unit.
        """
        rel = as_rel(rel)
        k = len(self.nuisance_names)
        if k == 0:
            return self.predict(rel, t, None, rel_ref), np.zeros((*rel.shape[:-1], 0))
        base = self.predict(rel, t, np.zeros(k), rel_ref)
        cols = [self.predict(rel, t, np.eye(k)[j], rel_ref) - base for j in range(k)]
        return base, np.stack(cols, axis=-1)

    def affine_parts(self, rel: ArrayLike, t: ArrayLike | None = None,
                     rel_ref: ArrayLike | None = None) -> tuple[Array, Array, Array]:
        """Split :meth:`affine`'s design into a part fixed by the geometry and the rest.

        ``A = A_const + A_var``.  Solvers subtract ``A_const @ nuisance`` from the data once,
        so that large nuisance values (a GHz carrier) do not swamp the residuals in rounding.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        h0 : ndarray
            ``(..., n)``, SI units of the value.
        A_const, A_var : ndarray
            ``(..., n, k)`` each, value units per nuisance unit.
        """
        h0, a = self.affine(rel, t, rel_ref)
        return h0, np.zeros(a.shape), a

    def values_and_derivatives_into(self, rel: Array, t: Array, values: Array,
                                    d_rel: Array) -> None:
        """Write :meth:`predict` and :meth:`jacobian`'s ``rel`` into given arrays (no nuisance).

        For kinds without nuisance parameters or reference samples: the solvers' linearisation
        writes each kind's rows straight into its own arrays (no temporaries, no copies).
        Kinds override it to share work between the two, with the same operations (the same
        bits).

        Parameters
        ----------
        rel, t
            As for :meth:`predict`.
        values : ndarray
            ``rel.shape[:-1]``, written (SI).
        d_rel : ndarray
            ``rel.shape``, zeros on entry; written where the derivatives are not zero (SI per
            m, per m/s).
        """
        values[...] = self.predict(rel, t, None, None)
        d_rel[...] = self.jacobian(rel, t, None, None).rel

    def affine_derivatives(self, rel: ArrayLike, t: ArrayLike | None = None,
                           rel_ref: ArrayLike | None = None
                           ) -> tuple[Array, Array, Array, Array | None, Array | None,
                                      Array | None, Array | None]:
        """Give the affine parts and their derivatives in one pass.

        Since the predictions are affine in the nuisance,
        ``d predict / d rel = dh0 + sum_j nu_j dA[..., j, :]``.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        h0, A_const, A_var : ndarray
            As for :meth:`affine_parts`.
        dh0, dh0_ref : ndarray or None
            ``(..., n, 6)``: d ``h0`` / d relative state (at the reference sample), per m, m/s.
        dA, dA_ref : ndarray or None
            ``(..., n, k, 6)``: d ``A_var`` likewise.  None where it vanishes identically
            (``dh0`` of a frequency, ``dA`` of a design that does not depend on the geometry,
            every ``*_ref`` of a kind without reference).
        """
        rel = as_rel(rel)
        k = len(self.nuisance_names)
        if k == 0:  # no nuisance: the prediction and its Jacobian
            jac = self.jacobian(rel, t, None, rel_ref)
            empty = np.zeros((*rel.shape[:-1], 0))
            return (self.predict(rel, t, None, rel_ref), empty, empty, jac.rel, jac.rel_ref,
                    None, None)
        h0, a_const, a_var = self.affine_parts(rel, t, rel_ref)
        base = self.jacobian(rel, t, np.zeros(k), rel_ref)
        d_a, d_a_ref = [], []
        for j in range(k):  # exact: the Jacobian is affine in the nuisance too
            unit = self.jacobian(rel, t, np.eye(k)[j], rel_ref)
            d_a.append(unit.rel - base.rel)
            if base.rel_ref is not None and unit.rel_ref is not None:
                d_a_ref.append(unit.rel_ref - base.rel_ref)
        dA_ref = np.stack(d_a_ref, axis=-2) if base.rel_ref is not None else None
        return h0, a_const, a_var, base.rel, base.rel_ref, np.stack(d_a, axis=-2), dA_ref

    # -- edges: file units <-> SI ------------------------------------------------------
    def value_to_si(self, value: ArrayLike) -> Array:
        """Convert file values to SI: ``value * file_scale + file_offset``.

        Parameters
        ----------
        value : array_like
            Values in :attr:`file_unit`.

        Returns
        -------
        ndarray
            Values in SI units (rad, m, m/s, Hz, dBW).
        """
        return np.asarray(value, dtype=float) * self.file_scale + self.file_offset

    def value_from_si(self, value: ArrayLike) -> Array:
        """Convert SI values to :attr:`file_unit`, inverting :meth:`value_to_si`.

        Parameters
        ----------
        value : array_like
            Values in SI units (rad, m, m/s, Hz, dBW).

        Returns
        -------
        ndarray
            Values in :attr:`file_unit`.
        """
        return (np.asarray(value, dtype=float) - self.file_offset) / self.file_scale

    def sigma_to_si(self, sigma: ArrayLike) -> Array:
        """Convert file standard deviations to SI: ``sigma * file_scale``.

        Parameters
        ----------
        sigma : array_like
            Standard deviations in :attr:`file_unit`.

        Returns
        -------
        ndarray
            Standard deviations in SI units.
        """
        return np.asarray(sigma, dtype=float) * self.file_scale

    def sigma_from_si(self, sigma: ArrayLike) -> Array:
        """Convert SI standard deviations to :attr:`file_unit`, inverting :meth:`sigma_to_si`.

        Parameters
        ----------
        sigma : array_like
            Standard deviations in SI units.

        Returns
        -------
        ndarray
            Standard deviations in :attr:`file_unit`.
        """
        return np.asarray(sigma, dtype=float) / self.file_scale

    def residual(self, measured: ArrayLike, predicted: ArrayLike) -> Array:
        """Give ``measured - predicted``, wrapped to (-pi, pi] for angles.

        Parameters
        ----------
        measured, predicted : array_like
            Values in SI units, broadcastable.

        Returns
        -------
        ndarray
            Residuals, SI units (rad for angles).
        """
        diff = np.asarray(measured, dtype=float) - np.asarray(predicted, dtype=float)
        if self.is_angle:
            from ..core.frames import wrap_angle

            return wrap_angle(diff)
        return diff

    def __repr__(self) -> str:
        """Name the kind with its options, e.g. ``Bearing()``."""
        return f"{type(self).__name__}()"
