"""Stone Soup interoperability: detections, measurement models and two initiators.

Install with ``pip install "tmakit[stonesoup]"`` (Stone Soup ≥ 1.0).  Stone Soup's Cartesian
state is ``[x, vx, y, vy(, z, vz)]``; tmakit's rows are predicted by the observation layer.
"""

from __future__ import annotations

import importlib.util

if importlib.util.find_spec("stonesoup") is None:  # pragma: no cover - the extra is missing
    raise ModuleNotFoundError("tmakit.interop.stonesoup needs Stone Soup: "
                              "pip install \"tmakit[stonesoup]\" (or stonesoup>=1.0)",
                              name="stonesoup")

import datetime as dt
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike
from stonesoup.base import Property
from stonesoup.initiator.base import GaussianInitiator
from stonesoup.models.measurement import nonlinear as ss
from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
from stonesoup.types.angle import Bearing
from stonesoup.types.array import StateVector, StateVectors
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track

from ..core.arrays import Array
from ..data import MeasurementSet
from ..filters import BearingPrior
from ..filters.track import Track as TmakitTrack
from ..observation import MeasurementGroup
from ..observation.groups import group_times
from ..results.estimate import EstimateResult
from ..tracking import MIN_WINDOW, search_window
from ..tracking import BearingInitiator as _FirstBearingStart
from ..tracking import track as tmakit_track
from ..tracking.errors import StartError, TrackingError
from ..tracking.initiators import CONFIRM_P_VALUE, DEFAULT_MAX_RELATIVE_STD

__all__ = ["EPOCH", "NATIVE_MODELS", "BatchInitiator", "BearingInitiator",
           "TmakitMeasurementModel", "cartesian_mapping", "detection_feed", "from_detections",
           "to_detections"]

#: The default timestamp of time 0 s of a measurement set (UTC).
EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)


def cartesian_mapping(dim: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Return Stone Soup's position and velocity indices of a constant-velocity state."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    return tuple(range(0, 2 * dim, 2)), tuple(range(1, 2 * dim, 2))


class TmakitMeasurementModel(NonLinearGaussianMeasurement):
    """tmakit measurement rows at one time as a Stone Soup measurement model.

    Build it with :meth:`from_rows`.  ``function`` and ``jacobian`` evaluate tmakit's models at the
    state's position and velocity (``mapping``, ``velocity_mapping``) in SI; angle rows are Stone
    Soup ``Bearing`` values, so innovations wrap to (-pi, pi].
    """

    group: MeasurementGroup = Property(doc="The rows, their models, sensor states and noise.")
    velocity_mapping: tuple[int, ...] = Property(doc="State indices of vx, vy(, vz).")

    @classmethod
    def from_rows(cls, rows: MeasurementSet, dim: int = 2, ndim_state: int | None = None,
                  mapping: Sequence[int] | None = None,
                  velocity_mapping: Sequence[int] | None = None,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None) -> TmakitMeasurementModel:
        """Build the model of measurement rows taken at one time."""
        if len(rows) and np.ptp(rows.time) > 1e-9:
            raise ValueError("a measurement model holds rows of one time; got times "
                             f"{rows.time.min():g} to {rows.time.max():g} s")
        pos, vel = cartesian_mapping(dim)
        pos = tuple(int(i) for i in (pos if mapping is None else mapping))
        vel = tuple(int(i) for i in (vel if velocity_mapping is None else velocity_mapping))
        n_state = 2 * dim if ndim_state is None else int(ndim_state)
        if len(pos) != dim or len(vel) != dim or max(pos + vel) >= n_state:
            raise ValueError(f"mapping {pos} and velocity_mapping {vel} do not fit a "
                             f"{dim}-D target in a state of {n_state}")
        group = MeasurementGroup(rows, float(rows.time[0]), dim, options, nuisance)
        return cls(ndim_state=n_state, mapping=pos, velocity_mapping=vel,
                   noise_covar=np.array(group.covariance), group=group)

    @classmethod
    def for_kinds(cls, kinds: str | Sequence[str], sigmas: ArrayLike,
                  sensor_state: ArrayLike, dim: int = 2, *, sensor: str = "sensor",
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None, ndim_state: int | None = None,
                  mapping: Sequence[int] | None = None,
                  velocity_mapping: Sequence[int] | None = None) -> TmakitMeasurementModel:
        """Build a model of tmakit kinds made from one sensor state, for Stone Soup's own loops.

        ``ndim_state``, ``mapping``, ``velocity_mapping``, ``options`` and ``nuisance`` are as
        for :meth:`from_rows`.
        """
        names = [kinds] if isinstance(kinds, str) else list(kinds)
        n = len(names)
        rows = MeasurementSet.from_si(np.zeros(n), [sensor] * n, names, np.zeros(n),
                                      np.broadcast_to(np.asarray(sigmas, dtype=float), (n,)),
                                      np.tile(np.asarray(sensor_state, dtype=float), (n, 1)))
        return cls.from_rows(rows, dim, ndim_state, mapping, velocity_mapping, options,
                             nuisance)

    @property
    def ndim_meas(self) -> int:
        """The number of rows ``m``."""
        return len(self.group)

    def typed_vector(self) -> Array:
        """Return a column with Bearing(0) on the angle rows, 0.0 elsewhere."""
        return np.array([[Bearing(0.0)] if a else [0.0] for a in self.group.angle],
                        dtype=object)

    def _tmakit_states(self, state: object) -> Array:
        """Return the tmakit states ``(N, 2 dim)`` of a Stone Soup state (N columns)."""
        sv = np.asarray(state.state_vector, dtype=np.float64)  # type: ignore[attr-defined]
        return sv[list(self.mapping) + list(self.velocity_mapping), :].T

    def function(self, state: object, noise: bool | ArrayLike = False,
                 **kwargs: object) -> StateVector | StateVectors:
        """Return the predicted rows (m, N), SI, angle rows as Bearing values."""
        x = self._tmakit_states(state)
        values = self.group.predict(x).T  # (m, N)
        if noise is True:
            values = values + np.asarray(self.rvs(num_samples=x.shape[0], **kwargs), float)
        elif noise is not False and noise is not None:
            values = values + np.asarray(noise, dtype=float)
        typed = self.typed_vector() + values
        return StateVector(typed) if typed.shape[1] == 1 else StateVectors(typed)

    def jacobian(self, state: object, **kwargs: object) -> Array:
        """Return the analytic Jacobian ``d function / d state`` (m, ndim_state), SI."""
        h = self.group.jacobian(self._tmakit_states(state)[0])
        out = np.zeros((len(self.group), self.ndim_state))
        out[:, list(self.mapping) + list(self.velocity_mapping)] = h
        return out

    def rvs(self, num_samples: int = 1, random_state: object = None,
            **kwargs: object) -> StateVector | StateVectors:
        """Draw noise samples (m, num_samples) from the rows' covariance, angle rows typed."""
        rng = np.random.default_rng(random_state)  # type: ignore[arg-type]
        draws = rng.multivariate_normal(np.zeros(len(self.group)), self.covar(), num_samples).T
        typed = self.typed_vector() + draws
        return StateVector(typed) if num_samples == 1 else StateVectors(typed)

    def logpdf(self, state1: object, state2: object, **kwargs: object) -> float | Array:
        """Return the log likelihood of measurement ``state1`` given state ``state2``."""
        z = np.asarray(state1.state_vector, dtype=np.float64)[:, 0]  # type: ignore[attr-defined]
        r = self.group.residual(self.group.predict(self._tmakit_states(state2)), z)
        w = self.group.noise.whiten(r, axis=-1)
        _, logdet = np.linalg.slogdet(np.asarray(self.covar(), dtype=float))
        ll = -0.5 * (np.sum(w**2, axis=-1) + logdet + len(self.group) * np.log(2 * np.pi))
        return float(ll[0]) if ll.shape[0] == 1 else ll

    def pdf(self, state1: object, state2: object, **kwargs: object) -> float | Array:
        """Return the likelihood, ``exp(logpdf)``."""
        return np.exp(self.logpdf(state1, state2, **kwargs))

#: Stone Soup's own measurement models read by :func:`from_detections`: the tmakit kind of
#: each component of their measurement vector.
NATIVE_MODELS: dict[type, tuple[str, ...]] = {
    ss.Cartesian2DToBearing: ("bearing",),
    ss.CartesianToBearingRange: ("bearing", "range"),
    ss.CartesianToElevationBearing: ("elevation", "bearing"),
    ss.CartesianToElevationBearingRange: ("elevation", "bearing", "range"),
}


def to_detections(meas: MeasurementSet, dim: int | None = None, *,
                  epoch: dt.datetime = EPOCH, per_sensor: bool = False,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None,
                  ndim_state: int | None = None, mapping: Sequence[int] | None = None,
                  velocity_mapping: Sequence[int] | None = None) -> list[Detection]:
    """Turn a measurement set into Stone Soup detections, in time order."""
    dim = int(meas.dim if dim is None else dim)
    out = []
    for index in group_times(meas):
        rows = meas.take(index)
        parts = ([rows.take(np.flatnonzero(rows.sensor == s)) for s in rows.sensors]
                 if per_sensor else [rows])
        for part in parts:
            model = TmakitMeasurementModel.from_rows(part, dim, ndim_state, mapping,
                                                     velocity_mapping, options, nuisance)
            value = model.typed_vector() + part.value_si[:, None]
            out.append(Detection(StateVector(value),
                                 timestamp=epoch + dt.timedelta(seconds=float(part.time[0])),
                                 measurement_model=model,
                                 metadata={"sensor": ",".join(part.sensors),
                                           "kinds": ",".join(part.kinds)}))
    return out


def detection_feed(detections: Iterable[Detection]) -> list[tuple[dt.datetime, set[Detection]]]:
    """Group detections by timestamp for a Stone Soup tracker's ``detector``."""
    by_time: dict[dt.datetime, set[Detection]] = {}
    for d in detections:
        by_time.setdefault(d.timestamp, set()).add(d)
    return sorted(by_time.items(), key=lambda item: item[0])


def from_detections(detections: Iterable[Detection], *, epoch: dt.datetime = EPOCH,
                    sensor: str = "stonesoup",
                    metadata: Mapping[str, str] | None = None) -> MeasurementSet:
    """Turn Stone Soup detections into a measurement set."""
    parts = []
    ordered = sorted(detections, key=lambda d: d.timestamp)
    for i, d in enumerate(ordered):
        t = (d.timestamp - epoch).total_seconds()
        z = np.asarray(d.state_vector, dtype=float)[:, 0]
        model = d.measurement_model
        if isinstance(model, TmakitMeasurementModel):
            rows = model.group.rows
            shift = t - float(rows.time[0])
            parts.append(MeasurementSet.from_si(rows.time + shift, rows.sensor, rows.kind, z,
                                                rows.sigma_si, rows.sensor_state,
                                                rows.time_ref + shift, rows.ref_sensor_state))
        else:
            parts.append(_native_rows(i, d, model, t, z, sensor))
    if not parts:
        raise ValueError("no detections to convert")
    return MeasurementSet.concatenate(parts, dict(metadata or {}))


def _native_rows(i: int, d: Detection, model: object, t: float, z: np.ndarray,
                 sensor: str) -> MeasurementSet:
    """Return the rows of a detection made with one of Stone Soup's own models."""
    kinds = NATIVE_MODELS.get(type(model))
    where = f"detection {i} (t = {t:g} s)"
    if kinds is None:
        raise ValueError(f"{where}: its measurement model {type(model).__name__} is not one "
                         "tmakit reads (TmakitMeasurementModel or "
                         f"{', '.join(c.__name__ for c in NATIVE_MODELS)})")
    if np.any(np.asarray(model.rotation_offset, dtype=np.float64) != 0.0):  # type: ignore[attr-defined]
        raise ValueError(f"{where}: a rotation_offset is not supported; rotate the sensor "
                         "frame into East-North-Up first")
    cov = np.asarray(model.covar(), dtype=np.float64)  # type: ignore[attr-defined]
    if np.any(cov != np.diag(np.diag(cov))):
        raise ValueError(f"{where}: correlated measurement noise is not supported "
                         "(tmakit's rows have independent sigmas)")
    values = z.copy()
    for k, kind in enumerate(kinds):
        if kind == "bearing":  # counter-clockwise from East -> clockwise from North
            values[k] = np.angle(np.exp(1j * (0.5 * np.pi - z[k])))
    offset = np.asarray(model.translation_offset, dtype=np.float64).ravel()  # type: ignore[attr-defined]
    state = np.zeros(6)
    state[:offset.size] = offset
    n = len(kinds)
    return MeasurementSet.from_si(np.full(n, t), [str(d.metadata.get("sensor", sensor))] * n,
                                  list(kinds), values, np.sqrt(np.diag(cov)),
                                  np.tile(state, (n, 1)))


class BatchInitiator(GaussianInitiator):
    """Start a Stone Soup track from tmakit's batch estimate, with no initial guess.

    Once the detections (accumulated over calls, all of one target) span ``min_window`` distinct
    times, the constant-velocity estimate over them starts a track by the start rule of
    :func:`tmakit.tracking.search_window` (else it is retried when the times have grown
    by ``growth``, and :attr:`problem` says why): a ``GaussianState`` at the latest time.

    Parameters
    ----------
    *args, **kwargs
        Stone Soup properties (documented with each below), by position or name.
    """

    dim: int = Property(default=2, doc="Spatial dimension of the target, 2 or 3.")
    max_relative_std: float = Property(
        default=DEFAULT_MAX_RELATIVE_STD,
        doc="Start quality: largest position std (1 sigma) over range to the nearest sensor.")
    min_window: int = Property(default=MIN_WINDOW,
                               doc="Distinct measurement times before the first try.")
    growth: float = Property(default=1.25, doc="Factor by which the times grow between tries.")
    confirm_p_value: float = Property(
        default=CONFIRM_P_VALUE, doc="A fit whose chi-square p-value is below it is no start.")
    options: Mapping[str, Mapping[str, object]] | None = Property(
        default=None, doc="Per-kind model options, as for tmakit.batch.estimate.")
    epoch: dt.datetime = Property(default=EPOCH, doc="The timestamp of time 0 s.")

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        if self.dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {self.dim}")
        if not self.max_relative_std > 0 or not self.growth > 1 or self.min_window < 1:
            raise ValueError("max_relative_std must be > 0, growth > 1 and min_window >= 1; "
                             f"got {self.max_relative_std}, {self.growth}, {self.min_window}")
        self.detections: list[Detection] = []
        self.estimate: EstimateResult | None = None
        self.tries = 0
        self.problem = ""
        self._next_try = int(self.min_window)

    def initiate(self, detections: Iterable[Detection], timestamp: dt.datetime,
                 **kwargs: object) -> set[Track]:
        """Collect detections; return one track once the batch estimate is a good start."""
        self.detections.extend(detections)
        if len({d.timestamp for d in self.detections}) < self._next_try:
            return set()
        meas = from_detections(self.detections, epoch=self.epoch)
        times = np.unique(meas.time)
        self.tries += 1
        try:
            choice = search_window(meas, self.dim, self.options, init_window=times.size,
                                   fit_p_value=self.confirm_p_value)
            rel = choice.chosen.relative_position_std
            self.problem = "" if rel < self.max_relative_std else (
                f"position std {rel:.0%} of the range (a start needs < "
                f"{self.max_relative_std:.0%})")
        except StartError as e:
            self.problem = str(e)
        if self.problem:
            self._next_try = max(times.size + 1, int(np.ceil(self.growth * times.size)))
            return set()
        result = choice.chosen.estimate
        assert result is not None  # a chosen window always has its estimate
        self.estimate = result
        when = self.epoch + dt.timedelta(seconds=float(times[-1]))
        self.detections, self._next_try = [], int(self.min_window)
        return {Track([_stonesoup_state(result.estimate, result.covariance, self.dim, when)])}


def _stonesoup_state(mean: np.ndarray, cov: np.ndarray, dim: int, when: dt.datetime
                     ) -> GaussianState:
    """Give a tmakit state and covariance as a Stone Soup ``GaussianState``."""
    pos, vel = cartesian_mapping(dim)
    order = list(pos) + list(vel)
    m = np.zeros(2 * dim)
    p = np.zeros((2 * dim, 2 * dim))
    m[order] = mean
    p[np.ix_(order, order)] = cov
    return GaussianState(m, p, timestamp=when)


class BearingInitiator(GaussianInitiator):
    """Start a Stone Soup track at its first bearing: tmakit's Gaussian sum from a prior.

    Each call runs the Gaussian sum of :class:`tmakit.tracking.BearingInitiator` over the
    detections so far (of one target) and starts a track, one ``GaussianState`` per detection
    time, once the position's largest 1-sigma semi-axis is below ``max_relative_std`` of the
    range; :attr:`track` keeps tmakit's track, :attr:`problem` says why there is none yet.

    Parameters
    ----------
    *args, **kwargs
        Stone Soup properties (documented with each below), by position or name.

    Raises
    ------
    ValueError
        For a ``dim`` other than 2 or 3, a prior that is not a ``BearingPrior``, or a start
        rule that cannot be met.
    """

    prior: BearingPrior = Property(default=None, doc="Range and speed intervals (default: "
                                                     "BearingPrior's defaults).")
    dim: int = Property(default=2, doc="Spatial dimension of the target, 2 or 3.")
    q_density: float = Property(default=0.0, doc="The target's continuous white-noise "
                                                 "acceleration density per axis, m^2/s^3.")
    max_relative_std: float = Property(
        default=DEFAULT_MAX_RELATIVE_STD,
        doc="Start quality: largest position std (1 sigma) over range to the sensor.")
    confirm_p_value: float = Property(
        default=CONFIRM_P_VALUE, doc="A start whose innovations' p-value is below it fails.")
    options: Mapping[str, Mapping[str, object]] | None = Property(
        default=None, doc="Per-kind model options, as for tmakit.track.")
    epoch: dt.datetime = Property(default=EPOCH, doc="The timestamp of time 0 s.")

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        if self.prior is None:
            self.prior = BearingPrior()
        if self.dim not in (2, 3) or not isinstance(self.prior, BearingPrior):
            raise ValueError(f"dim must be 2 or 3 and prior a tmakit.BearingPrior; got "
                             f"{self.dim}, {type(self.prior).__name__}")
        if not self.max_relative_std > 0 or not 0 <= self.confirm_p_value <= 1:
            raise ValueError("max_relative_std must be > 0 and confirm_p_value in 0..1; got "
                             f"{self.max_relative_std}, {self.confirm_p_value}")
        self.detections: list[Detection] = []
        self.track: TmakitTrack | None = None
        self.problem = ""

    def initiate(self, detections: Iterable[Detection], timestamp: dt.datetime,
                 **kwargs: object) -> set[Track]:
        """Collect detections; return one track once the Gaussian sum is a good start."""
        self.detections.extend(detections)
        if not self.detections:
            return set()
        meas = from_detections(self.detections, epoch=self.epoch)
        try:
            tr = tmakit_track(meas, "gsf", q_density=self.q_density, dim=self.dim,
                              options=self.options, initiator=_FirstBearingStart(
                                  self.prior, confirm_p_value=self.confirm_p_value))
        except TrackingError as e:
            self.problem, self.detections = str(e), []
            return set()
        cov = tr.covariances[-1, :self.dim, :self.dim]
        last = np.abs(meas.time - meas.time.max()) < 1e-9
        rng = float(np.min(np.linalg.norm(tr.states[-1, :self.dim]
                                          - meas.sensor_state[last][:, :self.dim], axis=1)))
        rel = float(np.sqrt(max(np.max(np.linalg.eigvalsh(cov)), 0.0))) / max(rng, 1e-9)
        if not rel < self.max_relative_std:
            self.problem = (f"position std {rel:.0%} of the range (a start needs < "
                            f"{self.max_relative_std:.0%})")
            return set()
        self.track, self.detections, self.problem = tr, [], ""
        return {Track([_stonesoup_state(m, c, self.dim,
                                        self.epoch + dt.timedelta(seconds=float(t)))
                       for t, m, c in zip(tr.times, tr.states, tr.covariances, strict=True)])}
