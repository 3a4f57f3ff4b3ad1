"""The one interface of tmakit's recursive filters, and the track they produce.

A filter holds the state ``[x, y, (z), vx, vy, (vz)]`` (ENU m, m/s) and its covariance; it
predicts under nearly-constant-velocity dynamics (Chen & Sun, §2.1), updates with rows of any
kinds and sensors, and runs over a :class:`~tmakit.data.MeasurementSet` to a :class:`Track`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Self, TypedDict, Unpack

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.blas import one_thread
from ..core.linalg import check_prior
from ..data import MeasurementSet
from ..motion.dynamics import NearlyConstantVelocity, state_names
from ..observation.groups import TIME_TOLERANCE, MeasurementGroup
from .general import PreparedMeasurements, prepared_for
from .track import SKIPPED, Recorder, Track, TrackExtras, UpdateInfo

if TYPE_CHECKING:  # pragma: no cover
    from ..results.estimate import EstimateResult
    from .bearing_prior import BearingPrior, FirstBearing


#: A process-noise acceleration standard deviation, for all axes or per axis (m/s^2).
ProcessNoise = float | tuple[float, ...]
#: Per-kind measurement-model options (``{"frequency": {"drift": True}}``).
KindOptions = Mapping[str, Mapping[str, object]]


def whole_number(value: float, name: str, low: int, what: str = "") -> int:
    """Give ``value`` as an int: a whole number (not a bool) >= ``low``, else ValueError."""
    try:
        ok = not isinstance(value, bool) and int(value) == value and value >= low
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"{name} must be a whole number{what} >= {low}; got {value!r}")
    return int(value)


class FilterSettings(TypedDict, total=False):
    """The keywords of tmakit's filter constructors, for the ``from_*`` starts (PEP 692).

    Each filter class takes the shared four and its own, documented on the class; a keyword its
    class does not take raises :class:`TypeError` naming it, and one named nowhere here is a
    type error.

    Attributes
    ----------
    q, dynamics, options, nuisance
        Every filter's (:class:`TrackingFilter`).
    iterations
        :class:`~tmakit.filters.ExtendedKalmanFilter` (``int``), the modified-gain EKF, the
        Gaussian sum (``None``: its default) and the IMM.
    alpha, beta, kappa
        :class:`~tmakit.filters.UnscentedKalmanFilter`.
    gain, reflect
        :class:`~tmakit.filters.ModifiedGainEKF` (``reflect`` also the reflecting EKF).
    particles, rng, resample_threshold, regularise, bandwidth, bearing_start
        :class:`~tmakit.filters.ParticleFilter` and the multiple-model particle filter.
    history
        The particle, Gaussian-sum and multiple-model filters.
    component
        :class:`~tmakit.filters.GaussianSumFilter` and the IMM.
    split_threshold, prune, merge, capacity
        :class:`~tmakit.filters.GaussianSumFilter`.
    model_q, transition, turn_rates, turn_q, sojourn, probabilities
        :class:`~tmakit.filters.InteractingMultipleModel` and the multiple-model particle
        filter.
    rate_noise, rate_std
        :class:`~tmakit.filters.InteractingMultipleModel`.
    origin
        :class:`~tmakit.filters.ModifiedPolarEKF`.
    """

    q: ProcessNoise
    dynamics: NearlyConstantVelocity | None
    options: KindOptions | None
    nuisance: Mapping[str, float] | None
    iterations: int | None
    alpha: float
    beta: float
    kappa: float
    gain: str
    reflect: bool | None
    particles: int
    rng: np.random.Generator | int | None
    resample_threshold: float
    regularise: bool
    bandwidth: float
    bearing_start: tuple[BearingPrior, FirstBearing] | None
    history: bool
    component: str
    split_threshold: float
    prune: float
    merge: float
    capacity: int
    model_q: Sequence[float]
    transition: ArrayLike | None
    turn_rates: Sequence[float] | None
    turn_q: float
    sojourn: float
    probabilities: ArrayLike | None
    rate_noise: float | None
    rate_std: float
    origin: ArrayLike | None


class TrackingFilter(ABC):
    """A recursive filter for a nearly-constant-velocity emitter (Chen & Sun, §2.1); abstract.

    Subclasses implement ``_init_state``, ``state``, ``covariance``, ``_predict``, ``_update``.

    Parameters
    ----------
    mean, covariance : array_like
        Gaussian prior at ``time``: ``(n,)`` and ``(n, n)``, n = 4 (``[x, y, vx, vy]``) or 6
        (m, m/s), the covariance positive definite.
    time : float, optional
        Time of the prior (s).
    q : float or tuple of float, optional
        Process-noise acceleration standard deviation, for all axes or per axis (m/s^2).
    dynamics : NearlyConstantVelocity, optional
        The dynamics, instead of ``q``.
    options : mapping, optional
        Per-kind measurement-model options (``{"frequency": {"drift": True}}``, ...).
    nuisance : mapping of str to float, optional
        Known nuisance values (carrier Hz, power constant dBW, ...).

    Raises
    ------
    ValueError
        If the prior is not a valid 4- or 6-state Gaussian or the dynamics' dimension differs.

    References
    ----------
    Chen & Sun, §2.1 (``Phi(T)`` and ``Q_k`` of the dynamics), §2.2 (measurements at earlier
    sample times).
    """

    name = ""
    #: Whether the constructor takes ``particles`` and ``rng`` (no caller inspects a signature).
    takes_particles = False
    takes_rng = False
    #: The spatial dimensions the filter tracks in.
    dims: tuple[int, ...] = (2, 3)
    #: Limit BLAS to one thread while working (:func:`tmakit.core.blas.one_thread`).
    single_blas_thread = False
    #: What the filter keeps for its smoother (``history=True``), handed to ``track.extra``.
    history: Any = None

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        mean, cov = check_prior(mean, covariance, "the prior mean", "the prior covariance")
        self.dim = mean.shape[0] // 2
        self.dynamics = dynamics if dynamics is not None else NearlyConstantVelocity(
            self.dim, q)
        if self.dynamics.dim != self.dim:
            raise ValueError(f"dynamics are {self.dynamics.dim}-D but the prior is "
                             f"{self.dim}-D")
        self.options = {k: dict(v) for k, v in dict(options or {}).items()}
        self.nuisance = dict(nuisance or {})
        self.time = float(time)
        self.log_likelihood = 0.0
        #: Updates skipped because the prediction was not finite (the target at a sensor).
        self.skipped_updates = 0
        with one_thread(self.single_blas_thread):
            self._init_state(mean, cov)

    @abstractmethod
    def _init_state(self, mean: Array, covariance: Array) -> None:
        """Set the internal representation from a Gaussian prior."""

    @property
    @abstractmethod
    def state(self) -> Array:
        """The state estimate (n,) at :attr:`time`."""

    @property
    @abstractmethod
    def covariance(self) -> Array:
        """Its covariance (n, n), symmetric."""

    @abstractmethod
    def _predict(self, dt: float) -> None:
        """Move the estimate ``dt > 0`` seconds forward."""

    @abstractmethod
    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        """Condition on one group of measurements at :attr:`time`."""

    def _skip(self) -> UpdateInfo:
        self.skipped_updates += 1
        return SKIPPED

    def _update_rows(self, rows: MeasurementSet) -> UpdateInfo | None:
        """Condition on rows without a group, where the filter can (None: use a group)."""
        return None

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the state components (``x, y, vx, vy`` or ``x, y, z, vx, vy, vz``)."""
        return state_names(self.dim)

    @classmethod
    def from_estimate(cls, result: EstimateResult, time: float, *, inflate: float = 1.0,
                      **settings: Unpack[FilterSettings]) -> Self:
        """Start a filter from a batch estimate's state, covariance and nuisance values at ``time``.

        Parameters
        ----------
        result : EstimateResult
            A batch estimate with a finite covariance.
        time : float
            Time of the filter's prior (s).
        inflate : float, optional
            Factor on the mapped covariance.
        **settings
            The class's own keywords (:class:`FilterSettings`: ``q``, ``dynamics``,
            ``particles``, ...); ``nuisance`` defaults to the estimate's values.

        Returns
        -------
        TrackingFilter

        Raises
        ------
        ValueError
            If the estimate's covariance is not finite.
        TypeError
            If the class takes no keyword of that name.
        """
        motion = result.motion
        theta = np.asarray(result.estimate, dtype=float)
        dim = 3 if getattr(motion, "dim", 2) == 3 else 2
        keep = [0, 1, 2, 3, 4, 5] if dim == 3 else [0, 1, 3, 4]
        state6 = motion.states(theta, np.array([float(time)]))[0]
        jac = motion.jacobian(theta, np.array([float(time)]))[0][keep]
        cov = inflate * jac @ result.covariance @ jac.T
        if not np.all(np.isfinite(cov)):
            raise ValueError("the batch estimate has no finite covariance (status "
                             f"{result.status!r}); start the filter from a prior instead")
        settings.setdefault("nuisance", {k: v for k, (v, _) in result.nuisance.items()})
        return cls._made(state6[keep], cov, float(time), settings)

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **settings: Unpack[FilterSettings]) -> Self:
        """Start at the first bearing from the prior's mean and covariance (Gaussian filters).

        Parameters
        ----------
        prior : BearingPrior
            Range, speed (and height) intervals.
        first : FirstBearing
            The first bearing (its time is the filter's).
        dim : int
            2 or 3.
        **settings
            The class's own keywords (:class:`FilterSettings`).

        Returns
        -------
        TrackingFilter

        Raises
        ------
        TypeError
            If the class takes no keyword of that name.
        """
        mean, cov = prior.gaussian(first, dim)
        return cls._made(mean, cov, first.time, settings)

    @classmethod
    def _made(cls, mean: ArrayLike, covariance: ArrayLike, time: float,
              settings: FilterSettings) -> Self:
        """Construct with ``settings``: the class's constructor refuses a keyword it lacks."""
        make: Callable[..., Self] = cls
        return make(mean, covariance, time, **settings)

    def group(self, rows: MeasurementSet | MeasurementGroup) -> MeasurementGroup:
        """Wrap measurement rows (any kinds and sensors) as a group at the filter's time.

        Parameters
        ----------
        rows : MeasurementSet or MeasurementGroup
            The rows, or a group at the filter's time (e.g. with a full noise covariance).

        Returns
        -------
        MeasurementGroup
            Their predictions, Jacobians and noise for this filter's state.
        """
        return (rows.at(self.time, self.dim) if isinstance(rows, MeasurementGroup)
                else MeasurementGroup(rows, self.time, self.dim, self.options, self.nuisance))

    def predict(self, time: float) -> None:
        """Move the estimate forward to ``time`` (s).

        Parameters
        ----------
        time : float
            Target time (s), not earlier than :attr:`time` (to :data:`TIME_TOLERANCE`).

        Raises
        ------
        ValueError
            If ``time`` is earlier than the filter's time.
        """
        with one_thread(self.single_blas_thread):
            self._advance(time)

    def _advance(self, time: float) -> None:
        dt = float(time) - self.time
        if dt < -TIME_TOLERANCE:
            raise ValueError(f"filters run forward: cannot predict from t={self.time} s back "
                             f"to t={time} s")
        if dt > TIME_TOLERANCE:
            self._predict(dt)
        self.time = max(self.time, float(time))

    def update(self, rows: MeasurementSet | MeasurementGroup) -> UpdateInfo:
        """Condition on measurement rows (any kinds and sensors) at the current time.

        Parameters
        ----------
        rows : MeasurementSet or MeasurementGroup
            The rows (other times: predicted from the state moved there), or a group.

        Returns
        -------
        UpdateInfo
            NIS, degrees of freedom and log-likelihood of the update.
        """
        with one_thread(self.single_blas_thread):
            info = None
            if isinstance(rows, MeasurementSet) and type(self).group is TrackingFilter.group:
                info = self._update_rows(rows)
            if info is None:
                info = self._update(self.group(rows))
        self.log_likelihood += info.log_likelihood
        return info

    def run(self, meas: MeasurementSet, *, after: float | None = None) -> Track:
        """Predict to, and update with, each distinct measurement time of ``meas`` in turn.

        Parameters
        ----------
        meas : MeasurementSet
            The measurements, none earlier than the filter's time.
        after : float, optional
            Use only the measurement times later than this (s, by more than
            :data:`TIME_TOLERANCE`), as ``run(meas.take(meas.time > after + TIME_TOLERANCE))``
            would, with ``meas`` prepared once for every filter run on it (a filter started
            part way through a set).

        Returns
        -------
        Track
            One row per distinct measurement time.

        Raises
        ------
        TypeError
            If ``meas`` is not a :class:`MeasurementSet`.
        ValueError
            If a row is earlier than the filter's time.
        """
        if not isinstance(meas, MeasurementSet):
            raise TypeError(f"meas must be a MeasurementSet, got {type(meas).__name__}")
        prepared = prepared_for(meas, self.dim, self.options, self.nuisance)
        total = len(prepared)
        earliest = prepared.time[prepared.bounds[:-1]] if total else prepared.time  # per update
        first = 0 if after is None else int(np.searchsorted(
            earliest, float(after) + TIME_TOLERANCE, side="right"))
        if first < total and earliest[first] < self.time - TIME_TOLERANCE:
            raise ValueError(f"measurements start at t={earliest[first]} s, before the "
                             f"filter's prior time t={self.time} s")
        with one_thread(self.single_blas_thread):
            if not self._plain_interface():
                return self.run_groups((float(prepared.times[k]), prepared.rows(k))
                                       for k in range(first, len(prepared)))
            rec = Recorder(2 * self.dim)
            k = first
            while k < total:
                stop = self._run_block(prepared, k, rec)
                if stop is not None:
                    k = stop
                    if k >= total:
                        break
                self._advance(float(prepared.times[k]))
                info = self._update(prepared.group(k, self.time))
                self.log_likelihood += info.log_likelihood
                rec.add(self.time, self.state, self.covariance, info, self.log_likelihood)
                k += 1
            return self._track(rec)

    def _plain_interface(self) -> bool:
        cls = type(self)
        return (cls.predict is TrackingFilter.predict and cls.update is TrackingFilter.update
                and cls.group is TrackingFilter.group)

    def _run_block(self, prepared: PreparedMeasurements, start: int, rec: Recorder
                   ) -> int | None:
        """Run and record updates ``start`` on in one go where the filter can; give the stop."""
        return None

    def run_groups(self, groups: Iterable[tuple[float, MeasurementSet]]) -> Track:
        """Predict to each ``time`` and update with its rows (at any times), in the order given.

        Parameters
        ----------
        groups : iterable of (float, MeasurementSet)
            ``(time, rows)`` pairs; the times (s) must not decrease.

        Returns
        -------
        Track
            One row per group.

        Raises
        ------
        ValueError
            If a time is earlier than the filter's time.
        """
        rec = Recorder(2 * self.dim)
        for time, rows in groups:
            self.predict(time)
            info = self.update(rows)
            rec.add(self.time, self.state, self.covariance, info, self.log_likelihood)
        return self._track(rec)

    def _track(self, rec: Recorder) -> Track:
        t, x, p, nis, dof, ll = rec.parts()
        return Track(self.name, self.state_names, t, x, p, nis, dof, ll,
                     extra=TrackExtras(skipped_updates=int(self.skipped_updates),
                                       history=self.history))
