"""The Gaussian-sum filter: a bank of weighted EKF, UKF or cubature components.

References
----------
Alspach & Sorenson (1972), IEEE Trans. Autom. Control 17(4); Peach (1995); Leong,
Arulampalam, Lamahewa & Abhayapala (2014), IEEE SPL 21(5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import ModuleType
from typing import Self, Unpack

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array, IntArray
from ..core.linalg import solve_spd
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import FilterSettings, KindOptions, ProcessNoise, TrackingFilter, whole_number
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import ExtendedKalmanFilter
from .general import PreparedMeasurements
from .track import Recorder, Track, UpdateInfo
from .ukf import CubatureKalmanFilter, UnscentedKalmanFilter


def _sums() -> ModuleType:
    """Give the compiled sums (numba is imported when a Gaussian sum first runs)."""
    from . import gaussian_sum_compiled
    return gaussian_sum_compiled


#: Component filters by name.
COMPONENTS: dict[str, type[ExtendedKalmanFilter]] = {
    "ekf": ExtendedKalmanFilter, "ukf": UnscentedKalmanFilter, "ckf": CubatureKalmanFilter}
#: Split a component when its largest position std exceeds this fraction of its range.
SPLIT_THRESHOLD = 0.2
#: Drop components whose weight is below this fraction of the largest.
PRUNE = 1e-5
#: Merge components whose means are within this squared Mahalanobis distance.
MERGE = 0.25
#: Most components held at once.
CAPACITY = 48
#: Linearisations per update of EKF components (the iterated EKF; docs/tracking.md).
ITERATIONS = 5


@dataclass(frozen=True)
class SumStep:
    """The Gaussian sum after one update, and where each of its components came from."""

    time: float  # (s)
    weights: Array  # (M,), normalised
    means: Array  # (M, n) (m, m/s)
    covariances: Array  # (M, n, n)
    origins: IntArray  # (M,): the component of the previous step each descends from (-1: none)

    @classmethod
    def first(cls, time: float, weights: Array, means: Array, covariances: Array,
              origins: IntArray, count: int) -> SumStep:
        """Copy the first ``count`` components, their weights normalised."""
        w = weights[:count]
        return cls(float(time), w / np.sum(w), means[:count].copy(),
                   covariances[:count].copy(), origins[:count].copy())


def component_filter(filt: TrackingFilter, component: str, iterations: int, mean: ArrayLike,
                     covariance: ArrayLike) -> ExtendedKalmanFilter:
    """Give the filter whose arithmetic updates each Gaussian of ``filt`` (EKF: ``iterations``)."""
    if component not in COMPONENTS:
        raise ValueError(f"component must be one of {', '.join(COMPONENTS)}; got "
                         f"{component!r}")
    if component != "ekf" and iterations != 1:
        raise ValueError(f"iterations apply to EKF components; got {iterations} with "
                         f"{component!r}")
    return COMPONENTS[component](np.asarray(mean, dtype=float),
                                 np.asarray(covariance, dtype=float), filt.time,
                                 dynamics=filt.dynamics, options=filt.options,
                                 nuisance=filt.nuisance,
                                 **({"iterations": iterations} if component == "ekf" else {}))


def mixture_moments(weights: Array, means: Array, covs: Array) -> tuple[Array, Array]:
    """Mean and covariance of ``sum_i w_i N(m_i, P_i)`` (normalised weights)."""
    mean = weights @ means
    d = means - mean
    cov = np.einsum("i,ijk->jk", weights, covs + d[:, :, None] * d[:, None, :])
    return mean, 0.5 * (cov + cov.T)


def update_components(unit: ExtendedKalmanFilter, group: MeasurementGroup, means: Array,
                      covs: Array, weights: Array) -> tuple[Array, float, int]:
    """Update each Gaussian in place; give their log-likelihoods (-inf: not made), NIS, dof.

    The NIS is that of the innovations' mixture under the prior ``weights``.
    """
    count = weights.shape[0]
    log_l = np.full(count, -np.inf)
    nus, innovation_covs = [], []
    for i in range(count):
        m, p, nu, s, ll = unit.update_gaussian(group, means[i], covs[i])
        if nu.shape[0]:
            means[i], covs[i] = m, p
            log_l[i] = ll
        nus.append(nu)
        innovation_covs.append(s)
    ok = np.flatnonzero(np.isfinite(log_l))
    if ok.shape[0] == 0:
        return log_l, float("nan"), 0
    prior = weights[ok] / weights[ok].sum()
    nbar, sbar = mixture_moments(prior, np.array([nus[i] for i in ok]),
                                 np.array([innovation_covs[i] for i in ok]))
    return log_l, float(nbar @ solve_spd(sbar, nbar)[0]), int(nbar.shape[0])


class GaussianSumFilter(TrackingFilter):
    """Gaussian-sum filter of EKF, UKF or cubature components.

    Parameters
    ----------
    mean, covariance, time
        A single Gaussian prior, as for :class:`~tmakit.filters.TrackingFilter` (m, m/s; s);
        :meth:`from_mixture` and :meth:`from_first_bearing` start from a sum.
    component : str, optional
        ``"ekf"``, ``"ukf"`` or ``"ckf"`` (cubature): the update of each component.
    iterations : int, optional
        Linearisations per update of EKF components (default :data:`ITERATIONS`; others 1).
    split_threshold : float, optional
        Split a component when its largest position std exceeds this fraction of its range
        from the sensor (0: never split).
    prune : float, optional
        Drop components lighter than this fraction of the heaviest.
    merge : float, optional
        Merge components whose means lie within this squared Mahalanobis distance (0: never).
    capacity : int, optional
        Most components held at once (>= 1).
    history : bool, optional
        Keep the sum after each update with its components' lineage (``track.extra.history``,
        a list of :class:`SumStep`), for the Gaussian-sum smoother
        (:func:`tmakit.filters.smooth`).
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Raises
    ------
    ValueError
        An unknown component, a negative setting, or a prior that is not valid.

    References
    ----------
    Alspach & Sorenson (1972); Peach (1995); Leong et al. (2014); Bell & Cathey (1993).
    """

    name = "gsf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 component: str = "ekf", iterations: int | None = None,
                 split_threshold: float = SPLIT_THRESHOLD,
                 prune: float = PRUNE, merge: float = MERGE, capacity: int = CAPACITY,
                 history: bool = False, q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        for label, value in (("split_threshold", split_threshold), ("prune", prune),
                             ("merge", merge)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{label} must be >= 0; got {value}")
        self.capacity = whole_number(capacity, "capacity", 1)
        self.component = component
        self.split_threshold = float(split_threshold)
        self.prune = float(prune)
        self.merge = float(merge)
        #: The sum after each update (with ``history=True``), for the smoother.
        self.history: list[SumStep] | None = [] if history else None
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        if type(self.dynamics) is not NearlyConstantVelocity:
            raise ValueError("the Gaussian-sum filter moves its components with "
                             "NearlyConstantVelocity dynamics")
        if iterations is None:
            iterations = ITERATIONS if component == "ekf" else 1
        self._unit = component_filter(self, component, iterations, mean, covariance)
        self.iterations = self._unit.iterations

    def _init_state(self, mean: Array, covariance: Array) -> None:
        self._set_sum(np.ones(1), mean[None], covariance[None])
        #: Components held after each update.
        self.component_counts: list[int] = []

    def _set_sum(self, weights: Array, means: Array, covs: Array) -> None:
        n = means.shape[1]
        count = weights.shape[0]
        cap = max(self.capacity, count)
        self._w = np.zeros(cap)
        self._m = np.zeros((cap, n))
        self._p = np.zeros((cap, n, n))
        self._w[:count] = weights / np.sum(weights)
        self._m[:count] = means
        self._p[:count] = covs
        self._origin = np.full(cap, -1, dtype=np.int64)
        self._count = count
        self._moments: tuple[Array, Array] | None = None
        if self.history is not None:
            self.history.clear()
            self._keep()

    def _keep(self) -> None:
        """Record the sum (with ``history``) after an update or at the start."""
        if self.history is not None:
            self.history.append(SumStep.first(self.time, self._w, self._m, self._p,
                                              self._origin, self._count))

    @classmethod
    def from_mixture(cls, weights: ArrayLike, means: ArrayLike, covariances: ArrayLike,
                     time: float = 0.0, **settings: Unpack[FilterSettings]) -> Self:
        """Start from a Gaussian sum.

        Parameters
        ----------
        weights, means, covariances : array_like
            ``(M,)`` > 0 (normalised here), ``(M, n)`` (m, m/s), ``(M, n, n)`` positive definite.
        time : float
            Its time (s).
        **settings
            The filter's keywords (``component``, ``q``, ...: :class:`FilterSettings`).

        Returns
        -------
        GaussianSumFilter

        Raises
        ------
        ValueError
            Shapes that do not agree or weights that are not positive.
        TypeError
            If the class takes no keyword of that name.
        """
        w = np.asarray(weights, dtype=float).reshape(-1)
        m = np.asarray(means, dtype=float)
        p = np.asarray(covariances, dtype=float)
        if m.ndim != 2 or p.shape != (m.shape[0], m.shape[1], m.shape[1]) \
                or w.shape[0] != m.shape[0]:
            raise ValueError(f"a Gaussian sum needs weights (M,), means (M, n) and "
                             f"covariances (M, n, n); got {w.shape}, {m.shape}, {p.shape}")
        if not (np.all(w > 0) and np.all(np.isfinite(w))):
            raise ValueError("the weights of a Gaussian sum must be finite and > 0")
        out = cls._made(*mixture_moments(w / w.sum(), m, p), time, settings)
        out._set_sum(w, m, p)
        return out

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **settings: Unpack[FilterSettings]) -> Self:
        """Start from the range-parameterised sum of a bearing prior (Peach 1995)."""
        w, m, p = prior.mixture(first, dim)
        return cls.from_mixture(w, m, p, first.time, **settings)

    @property
    def components(self) -> tuple[Array, Array, Array]:
        """The sum: weights ``(M,)``, means ``(M, n)``, covariances ``(M, n, n)`` (copies)."""
        c = self._count
        return self._w[:c].copy(), self._m[:c].copy(), self._p[:c].copy()

    def _compute_moments(self) -> tuple[Array, Array]:
        if self._moments is None:
            n = self._m.shape[1]
            mean, cov = np.zeros(n), np.zeros((n, n))
            _sums().sum_moments(self._w, self._m, self._p, self._count, mean, cov)
            self._moments = (mean, cov)
        return self._moments

    @property
    def state(self) -> Array:
        """The sum's mean ``(n,)`` (m, m/s)."""
        return self._compute_moments()[0].copy()

    @property
    def covariance(self) -> Array:
        """The sum's covariance ``(n, n)`` (m^2, m^2/s, m^2/s^2)."""
        return self._compute_moments()[1].copy()

    def _predict(self, dt: float) -> None:
        qa, qd = self.dynamics.axes()
        _sums().predict_sum(self._m, self._p, self._count, float(dt), self.dim, qa, qd)
        self._moments = None

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        self._origin[:self._count] = np.arange(self._count)
        info = self._update_sum(group)
        self._keep()
        return info

    def _update_sum(self, group: MeasurementGroup) -> UpdateInfo:
        sensor = np.zeros(3)
        sensor[:self.dim] = group.sensor_state[0, :self.dim]
        self._count = _sums().split_sum(self._w, self._m, self._p, self._origin, self._count,
                                        sensor, self.dim, self.split_threshold,
                                        self._w.shape[0])
        c = self._count
        log_l, nis, dof = update_components(self._unit, group, self._m, self._p, self._w[:c])
        log_w = np.full(c, -np.inf)
        for i in np.flatnonzero(np.isfinite(log_l)).tolist():
            log_w[i] = math.log(self._w[i]) + log_l[i]
        top = float(np.max(log_w)) if c else -np.inf
        if not math.isfinite(top):
            return self._skip()
        w = np.exp(log_w - top)
        total = float(np.sum(w))
        self._w[:c] = w
        self._count = _sums().reduce_sum(self._w, self._m, self._p, self._origin, c,
                                         self.prune, self.merge)
        self._moments = None
        self.component_counts.append(self._count)
        return UpdateInfo(nis, dof, top + math.log(total))

    def _run_block(self, prepared: PreparedMeasurements, start: int, rec: Recorder
                   ) -> int | None:
        """Run single bearings in 2-D in one compiled call."""
        me = type(self)
        if not (prepared.single_bearing and self.dim == 2
                and me._update is GaussianSumFilter._update
                and me._predict is GaussianSumFilter._predict):
            return None
        times, zs = prepared.time[start:], prepared.values[start:]
        k = int(times.shape[0])
        unit = self._unit
        sp = (np.zeros(0) if not isinstance(unit, UnscentedKalmanFilter) else np.array(
            [unit._gamma, unit._wm[0], unit._wc[0], unit._wm[1]]))
        qa, qd = self.dynamics.axes()
        means, covs = np.zeros((k, 4)), np.zeros((k, 4, 4))
        nis, lls, counts = np.zeros(k), np.zeros(k), np.zeros(k)
        cap = self._w.shape[0] if self.history is not None else 0
        rows = k if cap else 0
        kept = (np.zeros((rows, cap)), np.zeros((rows, cap, 4)), np.zeros((rows, cap, 4, 4)),
                np.zeros((rows, cap), dtype=np.int64))
        count, t, skipped_now = _sums().gsf_bearing_2d(
            self._w, self._m, self._p, self._origin, self._count, self.time, times, zs,
            prepared.sigmas[start:] ** 2, np.ascontiguousarray(prepared.sensor_state[start:, :2]),
            qa, qd, sp, np.array([self.split_threshold, self.prune, self.merge, self.iterations]),
            means, covs, nis, lls, counts, kept)
        if self.history is not None:
            self.history += [SumStep.first(times[j], kept[0][j], kept[1][j], kept[2][j],
                                           kept[3][j], int(counts[j])) for j in range(k)]
        self._count, self.time = int(count), float(t)
        self.skipped_updates += int(skipped_now)
        self._moments = None
        self.component_counts.extend(int(c) for c in counts)
        cum = self.log_likelihood + np.cumsum(lls)
        self.log_likelihood = float(cum[-1]) if k else self.log_likelihood
        rec.add_block(times, means, covs, nis, np.where(np.isfinite(nis), 1, 0), cum)
        return start + k

    def _track(self, rec: Recorder) -> Track:
        track = super()._track(rec)
        track.extra.components = list(self.component_counts)
        return track


__all__ = ["CAPACITY", "COMPONENTS", "ITERATIONS", "MERGE", "PRUNE", "SPLIT_THRESHOLD",
           "GaussianSumFilter", "SumStep"]
