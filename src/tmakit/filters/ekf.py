"""The extended Kalman filter: the measurement model linearised at the predicted state."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.linalg import solve_spd
from ..data import MeasurementSet
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import TIME_TOLERANCE, MeasurementGroup
from .base import KindOptions, ProcessNoise, TrackingFilter, whole_number
from .general import (
    DynamicsCache,
    PreparedMeasurements,
    RowSteps,
    Step,
    finite,
    innovation_solve,
    joseph,
    kalman_gain,
    linearise,
    plan_for,
    sym,
    updated_covariance,
)
from .track import Recorder, UpdateInfo

LOG_2PI = float(np.log(2.0 * np.pi))
#: The iterated EKF stops when an iteration moves the position by less than this fraction of
#: the smallest distance to a sensor of the group.
IEKF_TOL = 1e-10
#: What an update gives: mean, covariance, NIS, rows, log-likelihood.
Updated = tuple[Array, Array, float, int, float]


def _range_scale(rows: MeasurementGroup | Step, x: Array, dim: int) -> float:
    """Give the smallest distance (m) from the position ``x[:dim]`` to the rows' sensors."""
    sens = rows[2].reshape(-1, 6) if isinstance(rows, tuple) else rows.sensor_state
    return float(np.min(np.linalg.norm(sens[:, :dim] - x[:dim], axis=1)))


def linearise_group(group: MeasurementGroup, x: Array) -> tuple[Array, Array, bool]:
    """Give the wrapped residual and the Jacobian at ``x``, and whether both are finite."""
    y = group.residual(group.predict(x))
    h = group.jacobian(x)
    return y, h, finite(y, h)


def gaussian_update(mean: Array, cov: Array, residual: Array, h: Array, r: Array,
                    h_cov: Array | None = None) -> tuple[Array, Array, UpdateInfo]:
    """Make a Kalman update (Joseph form with ``h_cov`` if given, checked PSD)."""
    gain, nis, log_det = kalman_gain(cov, h, r, residual)
    m = residual.shape[0]
    loglik = -0.5 * (nis + log_det + m * LOG_2PI)
    g = h if h_cov is None else h_cov
    return mean + gain @ residual, joseph(cov, gain, g, r), UpdateInfo(nis, m, loglik)


class ExtendedKalmanFilter(TrackingFilter):
    """EKF with nearly-constant-velocity dynamics.

    ``iterations`` > 1 makes it the iterated EKF, relinearised at the updated state until the
    change is below :data:`IEKF_TOL` of the range; NIS and log-likelihood are those of the first
    linearisation.  An update whose prediction or Jacobian is not finite is skipped and counted in
    :attr:`skipped_updates`.

    Parameters
    ----------
    mean, covariance, time
        The prior, as for :class:`~tmakit.filters.TrackingFilter` (m, m/s; s).
    iterations : int, optional
        Linearisations per update (>= 1; 1 is the plain EKF).
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Raises
    ------
    ValueError
        If ``iterations`` is not a whole number >= 1, or the prior is not valid.

    References
    ----------
    Chen & Sun, §2.1 and §2.5 (with the plain Jacobian); Bell & Cathey (1993), the iterated update.
    """

    name = "ekf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 iterations: int = 1, q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self.iterations = whole_number(iterations, "iterations", 1)
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)

    def _init_state(self, mean: Array, covariance: Array) -> None:
        self._mean = mean
        self._cov = covariance
        self._dyn_cache = DynamicsCache(self.dynamics)
        self._steps = RowSteps(self.dim, self.options, self.nuisance)

    @property
    def state(self) -> Array:
        """The state estimate ``(n,)`` at :attr:`time` (m, m/s), a copy."""
        return self._mean.copy()

    @property
    def covariance(self) -> Array:
        """Its covariance ``(n, n)`` (m^2, m^2/s, m^2/s^2), a copy."""
        return self._cov.copy()

    def _predict(self, dt: float) -> None:
        phi, phit, q = self._dyn_cache.get(dt)
        self._mean = phi.dot(self._mean)
        cov = phi.dot(self._cov).dot(phit)
        cov += q
        self._cov = sym(cov)

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        self._mean, self._cov, nis, m, ll = self._gaussian_step(group, self._mean, self._cov)
        return UpdateInfo(nis, m, ll)

    def update_gaussian(self, group: MeasurementGroup, mean: Array, cov: Array
                        ) -> tuple[Array, Array, Array, Array, float]:
        """Update a given Gaussian with this filter's arithmetic, its own state left as it is.

        Parameters
        ----------
        group : MeasurementGroup
            The rows, at the Gaussian's time.
        mean, cov : numpy.ndarray
            The predicted Gaussian ``(n,)``, ``(n, n)`` (m, m/s).

        Returns
        -------
        mean, cov : numpy.ndarray
            The updated Gaussian (unchanged when the update cannot be made).
        innovation, innovation_cov : numpy.ndarray
            The wrapped innovation ``(m,)`` (empty when not made) and its covariance ``(m, m)``;
            the iterated EKF's last linearisation's (a Laplace approximation).
        log_likelihood : float
            ``log N(innovation; 0, innovation_cov)`` (nats; 0 when not made).
        """
        self._innovation = (np.zeros(0), np.zeros((0, 0)))
        new, new_cov, _, _, ll = self._gaussian_step(group, mean, cov)
        y, s = self._innovation
        if self.iterations > 1 and y.shape[0]:  # the last linearisation's (Laplace)
            ll = -0.5 * (float(y @ solve_spd(s, y)[0]) + np.linalg.slogdet(s)[1]
                         + y.shape[0] * LOG_2PI)
        return new, new_cov, y, s, ll

    def _gaussian_step(self, rows: MeasurementGroup | Step, mean: Array, cov: Array
                       ) -> Updated:
        """Update with a group or a plan's step."""
        if isinstance(rows, tuple):
            return self._kalman(linearise, rows, rows[6], mean, cov)
        return self._kalman(linearise_group, rows, rows.covariance, mean, cov)

    def _update_rows(self, rows: MeasurementSet) -> UpdateInfo | None:
        if type(self)._update is not ExtendedKalmanFilter._update:
            return None
        step = self._steps.step(rows, self.time)
        if step is None:
            return None
        self._mean, self._cov, nis, m, ll = self._gaussian_step(step, self._mean, self._cov)
        return UpdateInfo(nis, m, ll)

    def _kalman(self, lin: Callable[..., tuple[Array, Array, bool]],
                arg: MeasurementGroup | Step, r: Array, mean: Array, cov: Array) -> Updated:
        y, h, ok = lin(arg, mean)
        if not ok:
            self.skipped_updates += 1
            return mean, cov, float("nan"), 0, 0.0
        new = mean
        for i in range(self.iterations):
            if i:
                y, h, ok = lin(arg, new)
                if not ok:
                    break
                y = y - h.dot(mean - new)
            hp = h.dot(cov)
            s = hp.dot(h.T)
            s += r
            self._innovation = (y, s)
            gain, nis_i, log_det_i = innovation_solve(s, hp, y)
            nxt = mean + gain.dot(y)
            size = float(np.linalg.norm((nxt - new)[:self.dim])) if i else 0.0
            new, new_cov = nxt, updated_covariance(cov, gain, hp, h, r)
            if not i:
                nis, log_det, m = nis_i, log_det_i, y.shape[0]
            elif size <= IEKF_TOL * _range_scale(arg, new, self.dim):
                break
        return new, new_cov, nis, m, -0.5 * (nis + log_det + m * LOG_2PI)

    def _run_block(self, prepared: PreparedMeasurements, start: int, rec: Recorder
                   ) -> int | None:
        """Run updates ``start`` on of the set's plan (when neither step is overridden)."""
        me = type(self)
        if (type(self.dynamics) is not NearlyConstantVelocity
                or me._update is not ExtendedKalmanFilter._update
                or me._predict is not ExtendedKalmanFilter._predict):
            return None
        plan = plan_for(prepared)
        if not plan.ok:
            return None
        put = rec.rows.append
        get = self._dyn_cache.get
        update = self._gaussian_step
        mean, cov, t, ll = self._mean, self._cov, self.time, self.log_likelihood
        for step in plan.steps[start:]:
            tk = step[0]
            dt = tk - t
            if dt > TIME_TOLERANCE:
                phi, phit, q = get(dt)
                cov = phi.dot(cov).dot(phit)
                cov += q
                mean, t = phi.dot(mean), tk
            elif tk > t:  # (never earlier: run checked the first time, and the times increase)
                t = tk
            mean, cov, nis, m, lli = update(step, mean, cov)
            ll += lli
            put((t, mean, cov, nis, m, ll))
        self._mean, self._cov, self.time, self.log_likelihood = mean, cov, t, ll
        return len(prepared)
