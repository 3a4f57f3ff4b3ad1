"""The measurement-model interface.

A model maps relative states (target minus sensor, ``(..., n, 6)``, m and m/s) and its nuisance
parameters (broadcastable to ``(..., n, k)``) to predicted values in SI units, with the analytic
Jacobian of both.  Leading axes of ``rel`` are independent problems.  Also what a kind returns
and declares (:class:`Jacobian`, :class:`ValueRange`) and the relative-state helpers the kinds
share.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array

__all__ = ["Jacobian", "MeasurementModel", "ValueRange", "as_rel", "dot3",
           "inverse_range_and_unit", "range_of", "zeros_nuisance"]


def as_rel(rel: ArrayLike) -> Array:
    """Check and return a relative-state array."""
    rel = np.asarray(rel, dtype=float)
    if rel.ndim == 0 or rel.shape[-1] != 6:
        raise ValueError(f"relative states must have 6 components (position, velocity); "
                         f"got shape {rel.shape}")
    return rel


def dot3(a: Array, b: Array) -> Array:
    """Give the row-wise dot product of two arrays (fast for any memory layout)."""
    return np.einsum("...i,...i->...", a, b)


def range_of(rel: Array) -> Array:
    """Give ``|p|`` of ``p = rel[..., :3]`` by ``np.linalg.norm(p, axis=-1)``'s own sums."""
    p = rel[..., :3]
    return np.sqrt(np.add.reduce(p * p, axis=-1))


def inverse_range_and_unit(rel: Array) -> tuple[Array, Array]:
    """Give ``(1 / r, p / r)`` for the relative position ``p = rel[..., :3]``, ``r = |p|``."""
    p = rel[..., :3]
    inv_r = 1.0 / np.sqrt(dot3(p, p))
    return inv_r, p * inv_r[..., None]


def zeros_nuisance(rel: Array) -> Array:
    """Give a nuisance Jacobian of no columns, for kinds without nuisance parameters."""
    return np.zeros((*rel.shape[:-1], 0))


@dataclass(frozen=True)
class Jacobian:
    """Derivatives of predicted values ``(..., n)``, SI value units per m, m/s or nuisance unit.

    Parameters
    ----------
    rel : ndarray
        d value / d relative state, ``(..., n, 6)``.
    rel_ref : ndarray or None
        d value / d relative state at the reference (earlier) sample, or None.
    nuisance : ndarray
        d value / d nuisance parameters, ``(..., n, k)`` (k may be 0).
    """

    rel: Array
    rel_ref: Array | None
    nuisance: Array


@dataclass(frozen=True)
class ValueRange:
    """The values a file may hold for a kind, in the file unit (deg, Hz, m, ...).

    Parameters
    ----------
    noun : str
        The kind's value with its article, as the file checker names it ("a bearing").
    low, high : float or None
        The limits (None: unbounded on that side).
    low_inclusive, high_inclusive : bool
        Whether a value equal to the limit is valid.
    """

    noun: str
    low: float | None = None
    high: float | None = None
    low_inclusive: bool = True
    high_inclusive: bool = True

    def contains(self, values: ArrayLike) -> NDArray[np.bool_]:
        """Tell where values (file unit) lie in the range.

        Parameters
        ----------
        values : array_like

        Returns
        -------
        ndarray of bool
            The shape of ``values``.
        """
        v = np.asarray(values, dtype=float)
        ok = np.ones(v.shape, dtype=bool)
        if self.low is not None:
            ok &= (v >= self.low) if self.low_inclusive else (v > self.low)
        if self.high is not None:
            ok &= (v <= self.high) if self.high_inclusive else (v < self.high)
        return ok

    def describe(self, unit: str) -> str:
        """Say what a valid value is, as the file checker words it.

        Parameters
        ----------
        unit : str
            The kind's file unit ("deg", "Hz").

        Returns
        -------
        str
            E.g. "a bearing within [-360, 360] deg", "a frequency > 0 Hz".
        """
        if self.low is not None and self.high is not None:
            left = "[" if self.low_inclusive else "("
            right = "]" if self.high_inclusive else ")"
            return f"{self.noun} within {left}{self.low:.10g}, {self.high:.10g}{right} {unit}"
        if self.low is not None:
            return f"{self.noun} {'>=' if self.low_inclusive else '>'} {self.low:g} {unit}"
        if self.high is not None:
            return f"{self.noun} {'<=' if self.high_inclusive else '<'} {self.high:g} {unit}"
        return f"{self.noun} (any value) in {unit}"


class MeasurementModel:
    """One kind of measurement.

    Subclasses set the class attributes and implement :meth:`predict` and :meth:`jacobian`; a new
    kind is one file plus its entry in :data:`tmakit.measurements.KINDS`.
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
    #: The row's sensor is the ENU frame's origin (``altitude``: ``rel`` is the target's
    #: position); the rules refuse a row of it elsewhere.
    sensor_at_origin: bool = False
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
    #: The nuisance is one per tonal (the set's ``tonal`` labels): a contact's several tonals.
    nuisance_by_tonal: bool = False

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the constructor options a set's metadata (a file's ``# key:``) states.

        Parameters
        ----------
        metadata : mapping of str to str

        Returns
        -------
        dict
            Constructor options; empty for kinds that read none.
        """
        return {}

    @classmethod
    def check_values(cls, values: ArrayLike) -> NDArray[np.bool_]:
        """Tell where file values (:attr:`file_unit`) are valid for this kind.

        Parameters
        ----------
        values : array_like

        Returns
        -------
        ndarray of bool
            All True when the kind has no :attr:`value_range`.
        """
        if cls.value_range is None:
            return np.ones(np.shape(values), dtype=bool)
        return cls.value_range.contains(values)

    @classmethod
    def describe_values(cls) -> str | None:
        """Say what a valid file value is, for error messages.

        Returns
        -------
        str or None
            None when any finite value is valid.
        """
        return None if cls.value_range is None else cls.value_range.describe(cls.file_unit)

    def noise_covariance(self, time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike,
                         sensor: ArrayLike | None = None) -> Array:
        """Give the noise covariance of rows of this kind (SI units squared).

        Parameters
        ----------
        time, time_ref : array_like
            Row and reference times (m,), s.
        sigma : array_like
            Standard deviations (m,), SI.
        sensor : array_like, optional
            Sensor ids (m,); rows of different sensors are independent.

        Returns
        -------
        ndarray
            (m, m); ``diag(sigma^2)`` unless :attr:`correlated_noise`.
        """
        return np.diag(np.asarray(sigma, dtype=float) ** 2)

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """Names of the nuisance parameters (shared by all samples)."""
        return ()

    def default_nuisance(self) -> dict[str, float]:
        """Give the nuisance values used when a caller gives none.

        Returns
        -------
        dict of str to float
            SI values by nuisance name.
        """
        return {}

    def nuisance_vector(self, values: dict[str, float] | None) -> Array:
        """Give the nuisance vector in :attr:`nuisance_names` order, defaults filled in.

        Parameters
        ----------
        values : dict of str to float or None
            Nuisance values by name, SI.

        Returns
        -------
        ndarray
            ``(k,)``, SI.

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
            Relative states ``(..., n, 6)``, m and m/s.
        t : array_like, optional
            Sample times ``(n,)``, s (kinds whose values depend on time).
        nuisance : array_like, optional
            Broadcastable to ``(..., n, k)``, SI.
        rel_ref : array_like, optional
            Relative states at the earlier samples (if :attr:`uses_reference`).

        Returns
        -------
        ndarray
            ``rel.shape[:-1]``, SI (rad, m, m/s, Hz, dBW).

        Raises
        ------
        NotImplementedError
            In the base class; kinds raise ValueError for bad or missing inputs.
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
            Derivatives with respect to ``rel``, ``rel_ref`` and the nuisance.
        """
        raise NotImplementedError

    #: Whether :meth:`row_gradient` is implemented (plain floats for one row).
    has_row_gradient = False

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give one row's prediction and its derivatives in plain floats (for small updates).

        Parameters
        ----------
        rel : tuple of float
            ``(x, y, z, vx, vy, vz)``, m and m/s.
        t : float
            Sample time, s.
        nuisance : tuple of float
            Nuisance values, SI, in :attr:`nuisance_names` order.

        Returns
        -------
        tuple of float
            The value (SI) then its six derivatives with respect to ``rel``; only where
            :attr:`has_row_gradient`.
        """
        raise NotImplementedError(f"{self.kind}: no plain-float row_gradient")

    def affine_parts(self, rel: ArrayLike, t: ArrayLike | None = None,
                     rel_ref: ArrayLike | None = None) -> tuple[Array, Array, Array]:
        """Split the prediction as ``h0 + (A_const + A_var) @ nuisance``.

        ``A_const`` is fixed by geometry: solvers subtract ``A_const @ nuisance`` once, so a GHz
        carrier does not swamp the residuals.  The base class finds ``A_var`` by unit nuisance
        vectors (exact: predictions are affine in the nuisance).

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        h0 : ndarray
            ``(..., n)``, SI.
        A_const, A_var : ndarray
            ``(..., n, k)``, value units per nuisance unit.
        """
        rel = as_rel(rel)
        k = len(self.nuisance_names)
        empty = np.zeros((*rel.shape[:-1], k))
        if k == 0:
            return self.predict(rel, t, None, rel_ref), empty, empty
        base = self.predict(rel, t, np.zeros(k), rel_ref)
        cols = [self.predict(rel, t, np.eye(k)[j], rel_ref) - base for j in range(k)]
        return base, empty, np.stack(cols, axis=-1)

    def values_and_derivatives_into(self, rel: Array, t: Array | None, values: Array,
                                    d_rel: Array, nuisance: Array | None = None) -> None:
        """Write :meth:`predict` and d value / d ``rel`` in place (no reference sample).

        Parameters
        ----------
        rel, t, nuisance
            As for :meth:`predict`.
        values, d_rel : ndarray
            ``rel.shape[:-1]`` and ``rel.shape`` (zeros on entry), written in SI.
        """
        values[...] = self.predict(rel, t, nuisance, None)
        d_rel[...] = self.jacobian(rel, t, nuisance, None).rel

    def affine_derivatives(self, rel: ArrayLike, t: ArrayLike | None = None,
                           rel_ref: ArrayLike | None = None
                           ) -> tuple[Array, Array, Array, Array | None, Array | None,
                                      Array | None, Array | None]:
        """Give the affine parts and their derivatives in one pass.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        h0, A_const, A_var : ndarray
            As for :meth:`affine_parts`.
        dh0, dh0_ref : ndarray or None
            ``(..., n, 6)``: d ``h0`` / d relative state (now, at the reference), per m and m/s.
        dA, dA_ref : ndarray or None
            ``(..., n, k, 6)``: d ``A_var`` likewise; None where it vanishes identically.
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
    def value_from_si(self, value: ArrayLike) -> Array:
        """Convert SI values to :attr:`file_unit`.

        Parameters
        ----------
        value : array_like

        Returns
        -------
        ndarray
        """
        return (np.asarray(value, dtype=float) - self.file_offset) / self.file_scale

    def sigma_to_si(self, sigma: ArrayLike) -> Array:
        """Convert file standard deviations to SI: ``sigma * file_scale``.

        Parameters
        ----------
        sigma : array_like

        Returns
        -------
        ndarray
        """
        return np.asarray(sigma, dtype=float) * self.file_scale

    def sigma_from_si(self, sigma: ArrayLike) -> Array:
        """Convert SI standard deviations to :attr:`file_unit`.

        Parameters
        ----------
        sigma : array_like

        Returns
        -------
        ndarray
        """
        return np.asarray(sigma, dtype=float) / self.file_scale

    def residual(self, measured: ArrayLike, predicted: ArrayLike) -> Array:
        """Give ``measured - predicted``, wrapped to (-pi, pi] for angles.

        Parameters
        ----------
        measured, predicted : array_like
            SI values, broadcastable.

        Returns
        -------
        ndarray
        """
        diff = np.asarray(measured, dtype=float) - np.asarray(predicted, dtype=float)
        if self.is_angle:
            from ..core.frames import wrap_angle

            return wrap_angle(diff)
        return diff

    def __repr__(self) -> str:
        """Name the kind with its options, e.g. ``Bearing()``."""
        return f"{type(self).__name__}()"
