"""The extended Kalman filter: the measurement model linearised at the predicted state."""

from __future__ import annotations

import numpy as np

from .base import Array, TrackingFilter, UpdateInfo
from .linalg import joseph_update, solve_spd, symmetrise
from .measurement_group import MeasurementGroup

LOG_2PI = float(np.log(2.0 * np.pi))


def gaussian_update(mean: Array, cov: Array, residual: Array, h: Array, r: Array
                    ) -> tuple[Array, Array, UpdateInfo]:
    """Kalman update with innovation ``residual``, measurement matrix ``h`` and noise ``r``
    (Joseph form).  Returns the new mean, covariance and the update's NIS/log-likelihood."""
    s = symmetrise(h @ cov @ h.T + r)
    s_inv_ht, log_det = solve_spd(s, h @ cov)
    gain = s_inv_ht.T
    s_inv_nu, _ = solve_spd(s, residual)
    nis = float(residual @ s_inv_nu)
    m = residual.shape[0]
    loglik = -0.5 * (nis + log_det + m * LOG_2PI)
    return mean + gain @ residual, joseph_update(cov, gain, h, r), UpdateInfo(nis, m, loglik)


class ExtendedKalmanFilter(TrackingFilter):
    """EKF with nearly-constant-velocity dynamics (003_e5155d4fe60daef8.txt §2.1, §2.5 with
    the plain Jacobian in place of the modified gain)."""

    name = "ekf"

    def _init_state(self, mean: Array, covariance: Array) -> None:
        self._mean = mean
        self._cov = covariance

    @property
    def state(self) -> Array:
        return self._mean.copy()

    @property
    def covariance(self) -> Array:
        return self._cov.copy()

    def _predict(self, dt: float) -> None:
        phi = self.dynamics.transition(dt)
        self._mean = phi @ self._mean
        self._cov = symmetrise(phi @ self._cov @ phi.T + self.dynamics.noise(dt))

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        residual = group.residual(group.predict(self._mean))
        h = group.jacobian(self._mean)
        self._mean, self._cov, info = gaussian_update(self._mean, self._cov, residual, h,
                                                      group.covariance)
        return info
