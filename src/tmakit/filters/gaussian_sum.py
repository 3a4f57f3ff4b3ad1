"""The Gaussian-sum filter: a bank of EKF, UKF or cubature components with weights.

The posterior is ``sum_i w_i N(x; m_i, P_i)``.

References
----------
Alspach & Sorenson (1972), IEEE Trans. Autom. Control 17(4); Peach (1995); Leong,
Arulampalam, Lamahewa & Abhayapala (2014), IEEE SPL 21(5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike

from ..core.linalg import solve_spd
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import Array, KindOptions, ProcessNoise, TrackingFilter, UpdateInfo
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import ExtendedKalmanFilter, skipped
from .general import PreparedMeasurements
from .record import Recorder, RunBlock
from .track import Track
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
#: Linearisations per update of EKF components (the iterated EKF; docs/tracking.md gives
#: what it gains on the scenarios of Ristic et al. 2004).
ITERATIONS = 5


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
        Linearisations per update of EKF components (the iterated EKF, Bell & Cathey 1993;
        1 the plain EKF).  Default :data:`ITERATIONS` for EKF components, else 1.
    split_threshold : float, optional
        Split a component when its largest position std exceeds this fraction of its range
        from the sensor (0: never split).
    prune : float, optional
        Drop components lighter than this fraction of the heaviest.
    merge : float, optional
        Merge components whose means lie within this squared Mahalanobis distance (0: never).
    capacity : int, optional
        Most components held at once (>= 1).
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
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        if component not in COMPONENTS:
            raise ValueError(f"component must be one of {', '.join(COMPONENTS)}; got "
                             f"{component!r}")
        for label, value in (("split_threshold", split_threshold), ("prune", prune),
                             ("merge", merge)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{label} must be >= 0; got {value}")
        if isinstance(capacity, bool) or int(capacity) != capacity or capacity < 1:
            raise ValueError(f"capacity must be a whole number >= 1; got {capacity!r}")
        self.component = component
        self.split_threshold = float(split_threshold)
        self.prune = float(prune)
        self.merge = float(merge)
        self.capacity = int(capacity)
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        if type(self.dynamics) is not NearlyConstantVelocity:
            raise ValueError("the Gaussian-sum filter moves its components with "
                             "NearlyConstantVelocity dynamics")
        if iterations is None:
            iterations = ITERATIONS if component == "ekf" else 1
        if component != "ekf" and iterations != 1:
            raise ValueError(f"iterations apply to EKF components; got {iterations} with "
                             f"{component!r}")
        self._unit = COMPONENTS[component](np.asarray(mean, dtype=float),
                                           np.asarray(covariance, dtype=float), time,
                                           dynamics=self.dynamics, options=self.options,
                                           nuisance=self.nuisance,
                                           **({"iterations": iterations} if component == "ekf"
                                              else {}))
        self.iterations = self._unit.iterations

    # -- the sum ------------------------------------------------------------------------------
    def _init_state(self, mean: Array, covariance: Array) -> None:
        self._set_sum(np.ones(1), mean[None], covariance[None])

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
        self._count = count
        self._moments: tuple[Array, Array] | None = None

    @classmethod
    def from_mixture(cls, weights: ArrayLike, means: ArrayLike, covariances: ArrayLike,
                     time: float = 0.0, **kwargs: object) -> GaussianSumFilter:
        """Start from a Gaussian sum.

        Parameters
        ----------
        weights : array_like
            ``(M,)``, > 0 (normalised here).
        means : array_like
            ``(M, n)`` (m, m/s).
        covariances : array_like
            ``(M, n, n)``, each positive definite.
        time : float
            Its time (s).
        **kwargs
            The filter's settings (``component``, ``q``, ...).

        Returns
        -------
        GaussianSumFilter

        Raises
        ------
        ValueError
            Shapes that do not agree or weights that are not positive.
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
        total_w = w / w.sum()
        mean = total_w @ m
        d = m - mean
        cov = np.einsum("i,ijk->jk", total_w, p + d[:, :, None] * d[:, None, :])
        out = cls(mean, 0.5 * (cov + cov.T), time, **kwargs)  # type: ignore[arg-type]
        out._set_sum(w, m, p)
        return out

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **kwargs: object) -> GaussianSumFilter:
        """Start from the range-parameterised sum of a bearing prior (Peach 1995)."""
        w, m, p = prior.mixture(first, dim)
        return cls.from_mixture(w, m, p, first.time, **kwargs)

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

    def _settings(self) -> Array:
        return np.array([self.split_threshold, self.prune, self.merge, self.iterations])

    # -- predict and update (the general path) ------------------------------------------------
    def _predict(self, dt: float) -> None:
        qa, qd = self.dynamics.axes()
        _sums().predict_sum(self._m, self._p, self._count, float(dt), self.dim, qa, qd)
        self._moments = None

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        sensor = np.zeros(3)
        sensor[:self.dim] = group.sensor_state[0, :self.dim]
        self._count = _sums().split_sum(self._w, self._m, self._p, self._count, sensor, self.dim,
                                        self.split_threshold, self._w.shape[0])
        c = self._count
        log_w = np.full(c, -np.inf)
        nus, covs = [], []
        for i in range(c):
            m, p, nu, s, ll = self._unit.update_gaussian(group, self._m[i], self._p[i])
            if nu.shape[0]:
                self._m[i], self._p[i] = m, p
                log_w[i] = math.log(self._w[i]) + ll
            nus.append(nu)
            covs.append(s)
        top = float(np.max(log_w)) if c else -np.inf
        if not math.isfinite(top):
            self.skipped_updates += 1
            return skipped()
        ok = np.flatnonzero(np.isfinite(log_w))
        w_prior = self._w[ok] / np.sum(self._w[ok])
        nu_ok = np.array([nus[i] for i in ok])
        nbar = w_prior @ nu_ok
        dev = nu_ok - nbar
        sbar = np.einsum("i,ijk->jk", w_prior, np.array([covs[i] for i in ok])
                         + dev[:, :, None] * dev[:, None, :])
        nis = float(nbar @ solve_spd(sbar, nbar)[0])
        w = np.exp(log_w - top)
        total = float(np.sum(w))
        self._w[:c] = w
        self._count = _sums().reduce_sum(self._w, self._m, self._p, c, self.prune, self.merge)
        self._moments = None
        self.component_counts.append(self._count)
        return UpdateInfo(nis, int(nbar.shape[0]), top + math.log(total))

    # -- the compiled run of single bearings in 2-D -------------------------------------------
    def _run_block(self, prepared: PreparedMeasurements, start: int) -> RunBlock | None:
        me = type(self)
        if not (prepared.single_bearing and self.dim == 2
                and me._update is GaussianSumFilter._update
                and me._predict is GaussianSumFilter._predict):
            return None
        times, zs = prepared.time[start:], prepared.values[start:]
        k = times.shape[0]
        if times.shape[0] and times[0] < self.time - 1e-9:
            raise ValueError(f"filters run forward: cannot predict from t={self.time} s back "
                             f"to t={times[0]} s")
        unit = self._unit
        sp = (np.zeros(0) if not isinstance(unit, UnscentedKalmanFilter) else np.array(
            [unit._gamma, unit._wm[0], unit._wc[0], unit._wm[1]]))
        qa, qd = self.dynamics.axes()
        means, covs = np.zeros((k, 4)), np.zeros((k, 4, 4))
        nis, lls, counts = np.zeros(k), np.zeros(k), np.zeros(k)
        count, t, skipped_now = _sums().gsf_bearing_2d(
            self._w, self._m, self._p, self._count, self.time, times, zs,
            prepared.sigmas[start:] ** 2, np.ascontiguousarray(prepared.sensor_state[start:, :2]),
            qa, qd, sp, self._settings(), means, covs, nis, lls, counts)
        self._count, self.time = int(count), float(t)
        self.skipped_updates += int(skipped_now)
        self._moments = None
        self.component_counts.extend(int(c) for c in counts)
        cum = self.log_likelihood + np.cumsum(lls)
        self.log_likelihood = float(cum[-1]) if k else self.log_likelihood
        dof = np.where(np.isfinite(nis), 1.0, 0.0)  # rows per update (the recorder: int)
        return RunBlock(start + k, self.state, self.covariance, self.time,
                        self.log_likelihood, times, means, covs, nis, cum, dof)

    def _track(self, rec: Recorder) -> Track:
        track = super()._track(rec)
        track.extra.components = list(self.component_counts)
        return track

    @property
    def component_counts(self) -> list[int]:
        """Components held after each update of the compiled path (for the track)."""
        counts: list[int] | None = getattr(self, "_counts", None)
        if counts is None:
            counts = []
            self._counts = counts
        return counts


__all__ = ["CAPACITY", "COMPONENTS", "ITERATIONS", "MERGE", "PRUNE", "SPLIT_THRESHOLD",
           "GaussianSumFilter"]
