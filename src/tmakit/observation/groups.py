"""A group of measurement rows predicted from a filter state.

Rows at times ``t_i`` are predicted from the state moved at constant velocity,
``x(t_i) = Phi(t_i - t) x(t)`` (and back to a reference sample: Chen & Sun, §2.3-2.4), nuisance
values given.  :func:`radar_group` is the radar's group with its full covariance.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..data import MeasurementSet
from ..measurements import MeasurementModel
from ..motion.dynamics import state_names
from ..sensors.radar import RadarModel
from .noise import NoiseModel, checked_covariance
from .rows import RowLayout, RowModel, resolve_models

__all__ = ["TIME_TOLERANCE", "MeasurementGroup", "chain_state", "group_times", "radar_group",
           "radar_rows", "target_states", "time_blocks", "tonals_scaled"]

#: Rows whose times differ by less than this (s) are taken at one time.
TIME_TOLERANCE = 1e-9


def target_states(x: Array, dt: Array, dim: int) -> Array:
    """Move filter states at constant velocity to target 6-vectors at the rows."""
    pos, vel = x[..., None, :dim], x[..., None, dim:]
    out = np.zeros((*x.shape[:-1], dt.shape[0], 6))
    out[..., :dim] = pos + dt[:, None] * vel
    out[..., 3:3 + dim] = vel
    return out


def chain_state(d: Array, dt: Array, dim: int) -> Array:
    """Chain ``d value / d target6`` through ``target6 = [pos + dt vel, vel]``."""
    out = np.empty((*d.shape[:-1], 2 * dim))
    out[..., :dim] = d[..., :dim]
    out[..., dim:] = d[..., :dim] * dt[:, None] + d[..., 3:3 + dim]
    return out


def tonals_scaled(meas: MeasurementSet, options: Mapping[str, Mapping[str, object]] | None,
                  nuisance: Mapping[str, float] | None
                  ) -> tuple[MeasurementSet, Mapping[str, float] | None]:
    """Give the rows of several tonals as one tonal of carrier 1: ``f / f0 = 1 - rdot / c``."""
    if meas.tonal is None:
        return meas, nuisance
    labels = list(dict.fromkeys(meas.tonal[meas.kind_mask("frequency")].tolist()))
    if len(labels) < 2:
        return meas, nuisance
    if dict((options or {}).get("frequency", {})).get("drift"):
        raise ValueError("a filter with a carrier drift follows one tonal: these frequencies "
                         f"are {len(labels)} tonals ({', '.join(labels)})")
    values = dict(nuisance or {})
    missing = [f"carrier[{lab}]" for lab in labels if f"carrier[{lab}]" not in values]
    if missing:
        raise ValueError(f"a filter needs each tonal's f0 as a known value ({', '.join(missing)}"
                         " Hz), e.g. from a batch estimate (nuisance={...})")
    f0 = np.ones(len(meas))
    for lab in labels:
        f0[meas.tonal == lab] = values[f"carrier[{lab}]"]
    scaled = MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si / f0,
                                    meas.sigma_si / f0, meas.sensor_state, meas.time_ref,
                                    meas.ref_sensor_state, meas.metadata, check=False)
    return scaled.with_ambiguous(meas.ambiguous_si), {**values, "carrier": 1.0}


class MeasurementGroup:
    """Rows of a :class:`~tmakit.data.MeasurementSet` for one filter update at time ``t``.

    :meth:`from_arrays` builds one from SI columns (the filters' fast path); :meth:`planned` for
    measurements not yet made (a planner's candidates).

    Parameters
    ----------
    rows : MeasurementSet
        At least one row.
    t : float
        The filter time, s.
    dim : int
        2 or 3 (state ``[x, y, (z), vx, vy, (vz)]``).
    options : mapping, optional
        Per-kind model options.
    nuisance : mapping, optional
        Known nuisance values of the kinds present.
    covariance : array_like, optional
        A full noise covariance (m, m), SI squared, in place of the rows' own (a radar's range
        and range rate).

    Attributes
    ----------
    rows, time, dim
        The set, the filter time (s) and the dimension.
    values, sigmas : ndarray
        Measured values and std (m,), SI.
    models, index, nuisance : dict
        Per kind: the model, its rows, its nuisance vector.
    angle : ndarray of bool
        Rows whose residuals wrap.
    dt, dt_ref : ndarray
        Row and reference times minus ``t`` (m,), s.
    sensor_state : ndarray
        (m, 6), m and m/s.
    full_covariance : ndarray or None
        The full covariance given, if any.

    Raises
    ------
    ValueError
        Without rows, when a nuisance value is missing, or on a covariance that is not
        symmetric positive definite (m, m).

    References
    ----------
    Chen & Sun, eq. 1 (range differences sharing pulse intervals: correlated noise).
    """

    def __init__(self, rows: MeasurementSet, t: float, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None,
                 covariance: ArrayLike | None = None) -> None:
        if len(rows) == 0:
            raise ValueError("a measurement group needs at least one row")
        rows, nuisance = tonals_scaled(rows, options, nuisance)
        models, nus = resolve_models(rows.kinds, options, nuisance)
        index = {kind: np.flatnonzero(rows.kind == kind) for kind in models}
        self._setup(t, dim, models, nus, index, rows.value_si, rows.sigma_si, rows.time,
                    rows.time_ref, rows.sensor_state, rows.ref_sensor_state, rows.sensor,
                    covariance=covariance)
        self._rows: MeasurementSet | None = rows
        self._rows_factory: Callable[[], MeasurementSet] | None = None

    @classmethod
    def from_arrays(cls, t: float, dim: int, models: Mapping[str, MeasurementModel],
                    nuisance: Mapping[str, Array], index: Mapping[str, NDArray[np.int64]],
                    values: Array, sigmas: Array, time: Array, time_ref: Array,
                    sensor_state: Array, ref_sensor_state: Array, sensor: NDArray[np.str_],
                    rows: Callable[[], MeasurementSet], layout: RowLayout | None = None,
                    covariance: ArrayLike | None = None) -> MeasurementGroup:
        """Build a group from columns already in SI.

        Parameters
        ----------
        t, dim, covariance
            As for the constructor.
        models, nuisance : mapping
            From :func:`resolve_models`.
        index : mapping
            The rows of each kind.
        values, sigmas, time, time_ref, sensor_state, ref_sensor_state, sensor
            The rows' columns (SI, s, m, m/s).
        rows : callable
            Makes the MeasurementSet on demand.
        layout : RowLayout, optional
            The layout of ``models`` and ``index``, if made.

        Returns
        -------
        MeasurementGroup

        Raises
        ------
        ValueError
            Without rows.
        """
        if len(values) == 0:
            raise ValueError("a measurement group needs at least one row")
        self = cls.__new__(cls)
        self._setup(t, dim, models, nuisance, index, values, sigmas, time,
                    time_ref, sensor_state, ref_sensor_state, sensor, layout, covariance)
        self._rows = None
        self._rows_factory = rows
        return self

    @classmethod
    def planned(cls, kinds: str | Sequence[str], sigmas: ArrayLike | None, t: float, dim: int,
                options: Mapping[str, Mapping[str, object]] | None = None,
                nuisance: Mapping[str, float] | None = None,
                time_ref: ArrayLike | None = None,
                covariance: ArrayLike | None = None) -> MeasurementGroup:
        """Build measurements not yet made at filter time ``t`` (s): a row per kind, values NaN.

        Their sensor states are zeros, to be given to :meth:`predict`, :meth:`jacobian` or
        :meth:`information` (``sensor_state``).

        Parameters
        ----------
        kinds : str or sequence of str
        sigmas : array_like or None
            Noise std per row, SI; None with ``covariance``.
        t, dim, options, nuisance, covariance
            As for the constructor.
        time_ref : array_like, optional
            Reference times, s, of kinds that use an earlier sample.

        Returns
        -------
        MeasurementGroup

        Raises
        ------
        ValueError
            When a nuisance value is missing, without ``sigmas`` or ``covariance``, or on a bad
            covariance.
        """
        names = [kinds] if isinstance(kinds, str) else list(kinds)
        m = len(names)
        if sigmas is None and covariance is None:
            raise ValueError("a planned group needs sigmas or a covariance")
        sig = (np.ones(m) if sigmas is None
               else np.broadcast_to(np.asarray(sigmas, dtype=float), (m,)).copy())
        t_ref = (np.full(m, np.nan) if time_ref is None
                 else np.broadcast_to(np.asarray(time_ref, dtype=float), (m,)).copy())
        models, nus = resolve_models(dict.fromkeys(names), options, nuisance)
        kind = np.asarray(names)
        index = {k: np.flatnonzero(kind == k) for k in models}
        sensor = np.full(m, "planned")

        def no_rows() -> MeasurementSet:
            raise ValueError("a planned group has no measurement rows")

        return cls.from_arrays(t, dim, models, nus, index, np.full(m, np.nan), sig,
                               np.full(m, float(t)), t_ref, np.zeros((m, 6)),
                               np.zeros((m, 6)), sensor, no_rows, covariance=covariance)

    def _setup(self, t: float, dim: int, models: Mapping[str, MeasurementModel],
               nuisance: Mapping[str, Array], index: Mapping[str, NDArray[np.int64]],
               values: Array, sigmas: Array, time: Array, time_ref: Array,
               sensor_state: Array, ref_sensor_state: Array, sensor: NDArray[np.str_],
               layout: RowLayout | None = None, covariance: ArrayLike | None = None) -> None:
        full = None if covariance is None else checked_covariance(covariance, len(values))
        if full is not None:
            sigmas = np.sqrt(np.diagonal(full)).copy()
        self.time = float(t)
        self.dim = int(dim)
        self.values = values
        self.sigmas = sigmas
        self.nuisance = nuisance
        self.row_model = RowModel(models, index, time, time_ref, sigmas, sensor,
                                  sensor_state, ref_sensor_state, layout)
        self.models = self.row_model.models
        self.index = self.row_model.index
        self.sensor_state = self.row_model.sensor_state
        self.angle = self.row_model.angle
        self.dt = time - self.time
        self.dt_ref = time_ref - self.time
        ref = self.row_model.reference
        self._dt_ref_rows = None if ref is None else self.dt_ref[ref]
        self.full_covariance = full
        self._cov: Array | None = full
        self._noise: NoiseModel | None = (None if full is None
                                          else NoiseModel.from_covariance(full))

    def at(self, t: float, dim: int) -> MeasurementGroup:
        """Return this group, checked to be at filter time ``t`` (s) in ``dim`` dimensions.

        Parameters
        ----------
        t : float
        dim : int

        Returns
        -------
        MeasurementGroup
            ``self``.

        Raises
        ------
        ValueError
            If it is at another time (beyond :data:`TIME_TOLERANCE`) or dimension.
        """
        if abs(self.time - float(t)) > TIME_TOLERANCE or self.dim != int(dim):
            raise ValueError(f"the group is at t={self.time} s in {self.dim}-D, the filter at "
                             f"t={float(t)} s in {int(dim)}-D (predict the filter first)")
        return self

    @property
    def rows(self) -> MeasurementSet:
        """The rows as a :class:`~tmakit.data.MeasurementSet`."""
        if self._rows is None:
            assert self._rows_factory is not None
            self._rows = self._rows_factory()
        return self._rows

    def __len__(self) -> int:
        """Return the number of rows ``m``."""
        return int(self.values.shape[0])

    @property
    def covariance(self) -> Array:
        """Noise covariance ``R`` (m, m), SI units squared."""
        if self._cov is None:
            self._cov = self.row_model.covariance()
        return self._cov

    @property
    def noise(self) -> NoiseModel:
        """Whitening by the group's noise covariance (:class:`NoiseModel`)."""
        if self._noise is None:
            self._noise = NoiseModel.from_rows(self.row_model)
        return self._noise

    def _check_state(self, x: ArrayLike) -> Array:
        x = np.asarray(x, dtype=float)
        if x.ndim == 0 or x.shape[-1] != 2 * self.dim:
            raise ValueError(f"states must have {2 * self.dim} components "
                             f"({', '.join(state_names(self.dim))}); got shape {x.shape}")
        return x

    def relative(self, x: ArrayLike, sensor_state: ArrayLike | None = None
                 ) -> tuple[Array, Array | None]:
        """Return relative states (target minus sensor) from filter states.

        Parameters
        ----------
        x : array_like
            Filter states ``(..., 2 dim)``, m and m/s.
        sensor_state : array_like, optional
            Replaces the rows' sensor states; broadcastable to ``(..., m, 6)``.

        Returns
        -------
        rel, rel_ref : ndarray, ndarray or None
            At the rows and at the reference samples (None without them), m and m/s.

        Raises
        ------
        ValueError
            When the states do not have ``2 dim`` components.
        """
        x = self._check_state(x)
        target_ref = (None if self._dt_ref_rows is None
                      else target_states(x, self._dt_ref_rows, self.dim))
        return self.row_model.relative(target_states(x, self.dt, self.dim), target_ref,
                                       sensor_state)

    def predict(self, x: ArrayLike, sensor_state: ArrayLike | None = None) -> Array:
        """Return predicted values ``(..., m)``, SI, for states (particles, sigma points).

        Parameters
        ----------
        x, sensor_state
            As for :meth:`relative`.

        Returns
        -------
        ndarray
        """
        rel, rel_ref = self.relative(x, sensor_state)
        return self.row_model.predict(rel, rel_ref, self.nuisance)

    def jacobian(self, x: ArrayLike, sensor_state: ArrayLike | None = None) -> Array:
        """Return ``d predict / d x`` ``(..., m, 2 dim)`` at states ``x``.

        Parameters
        ----------
        x, sensor_state
            As for :meth:`relative`.

        Returns
        -------
        ndarray
        """
        rel, rel_ref = self.relative(x, sensor_state)
        d, d_ref, _ = self.row_model.jacobian(rel, rel_ref, self.nuisance)
        h = chain_state(d, self.dt, self.dim)
        if d_ref is not None and self._dt_ref_rows is not None:
            ref = self.row_model.reference
            h[..., ref, :] += chain_state(d_ref, self._dt_ref_rows, self.dim)
        return h

    def information(self, x: ArrayLike, sensor_state: ArrayLike | None = None) -> Array:
        """Return the Fisher information ``H^T R^{-1} H`` ``(..., 2 dim, 2 dim)`` about the state.

        Parameters
        ----------
        x, sensor_state
            As for :meth:`relative`.

        Returns
        -------
        ndarray

        References
        ----------
        Hurtado & Nehorai (2008), eq. 13 (``Xi``, closed form for Gaussian noise).
        """
        w = self.noise.whiten(self.jacobian(x, sensor_state), axis=-2)
        return np.einsum("...mi,...mj->...ij", w, w)

    def residual(self, predicted: ArrayLike, measured: ArrayLike | None = None) -> Array:
        """Return ``measured - predicted`` ``(..., m)``, angles wrapped to (-pi, pi].

        Parameters
        ----------
        predicted : array_like
            ``(..., m)``, SI.
        measured : array_like, optional
            (m,), SI; default the group's values.

        Returns
        -------
        ndarray
        """
        z = self.values if measured is None else measured
        return self.row_model.residual(z, predicted)


def time_blocks(time: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
    """Group rows by time (within :data:`TIME_TOLERANCE` s): their stable order, update bounds."""
    t = np.asarray(time, dtype=float)
    order = np.argsort(t, kind="stable")
    breaks = np.flatnonzero(np.diff(t[order]) > TIME_TOLERANCE) + 1
    return order, np.concatenate([[0], breaks, [t.shape[0]]]).astype(np.int64)


def group_times(meas: MeasurementSet) -> list[NDArray[np.int64]]:
    """Return the row indices of ``meas`` grouped by measurement time (ascending).

    Parameters
    ----------
    meas : MeasurementSet

    Returns
    -------
    list of ndarray
    """
    order, bounds = time_blocks(meas.time)
    return np.split(order, bounds[1:-1])


def radar_rows(radar: RadarModel, t: float, values: ArrayLike, sensor_state: ArrayLike,
               dim: int = 2, sensor: str = "radar", elevation: float = 0.0) -> MeasurementSet:
    """Return one pulse's measurements as rows of a MeasurementSet (marginal sigmas only).

    Parameters
    ----------
    radar : RadarModel
    t : float
        Pulse time, s.
    values : array_like
        :meth:`RadarModel.kinds` values, SI (rad, m, m/s).
    sensor_state : array_like
        (6,), m and m/s.
    dim : {2, 3}
        3 adds elevation.
    sensor : str
    elevation : float
        The target's elevation, rad (3-D only).

    Returns
    -------
    MeasurementSet
    """
    kinds = radar.kinds(dim)
    m = len(kinds)
    z = np.asarray(values, dtype=float).reshape(m)
    state = np.broadcast_to(np.asarray(sensor_state, dtype=float).reshape(6), (m, 6))
    return MeasurementSet.from_si(np.full(m, float(t)), np.full(m, sensor), list(kinds), z,
                                  radar.measurement_sigmas(kinds, elevation), state,
                                  check=False)  # noisy: a range may be < 0


def radar_group(radar: RadarModel, t: float, dim: int = 2, *, elevation: float = 0.0,
                values: ArrayLike | None = None, sensor_state: ArrayLike | None = None,
                sensor: str = "radar") -> MeasurementGroup:
    """Return the radar's measurement group at time ``t`` with its full noise covariance.

    Without ``values`` the group is planned (NaN values, for a planner's candidates).

    Parameters
    ----------
    radar : RadarModel
    t : float
        s.
    dim : {2, 3}
    elevation : float
        The target's elevation for the covariance, rad.
    values : array_like, optional
        Measured values (m,), SI.
    sensor_state : array_like, optional
        (6,), m and m/s; needed with ``values``.
    sensor : str

    Returns
    -------
    MeasurementGroup

    Raises
    ------
    ValueError
        With ``values`` but no ``sensor_state``, or where the covariance does not exist.
    """
    kinds = radar.kinds(dim)
    cov = radar.measurement_covariance(kinds, elevation)
    if values is None:
        return MeasurementGroup.planned(kinds, None, t, dim, covariance=cov)
    if sensor_state is None:
        raise ValueError("radar_group: values need the sensor_state they were measured from")
    rows = radar_rows(radar, t, values, sensor_state, dim, sensor, elevation)
    return MeasurementGroup(rows, t, dim, covariance=cov)
