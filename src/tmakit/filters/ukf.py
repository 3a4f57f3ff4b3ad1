"""The unscented Kalman filter, wrap-aware.

The scaled unscented transform (Julier 2002; weights of Wan & van der Merwe 2000), by default
``alpha = 1, beta = 2, kappa = 0`` so every weight is non-negative; angle rows take the circular
mean and wrapped deviations.  The dynamics are linear (Chen & Sun, §2.1), so the predict is the
Kalman predict.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg.lapack import dpotrf

from ..core.arrays import Array
from ..core.linalg import safe_cholesky
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from ..observation.rows import Index
from .base import KindOptions, ProcessNoise
from .ekf import LOG_2PI, ExtendedKalmanFilter, Updated
from .general import (
    Step,
    checked_psd,
    innovation_solve,
    predict_rows,
    wrap_small,
)


def unscented_weights(n: int, alpha: float, beta: float, kappa: float
                      ) -> tuple[float, Array, Array]:
    """Give the spread and weights of the scaled unscented transform (Wan & van der Merwe 2000)."""
    for name, value in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite; got {value}")
    if alpha <= 0:
        raise ValueError(f"alpha must be > 0; got {alpha}")
    lam = alpha**2 * (n + kappa) - n
    if n + lam <= 0:
        raise ValueError(f"n + lambda = alpha^2 (n + kappa) must be > 0; got {n + lam} "
                         f"(n={n}, alpha={alpha}, kappa={kappa})")
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = wm[0] + 1.0 - alpha**2 + beta
    return math.sqrt(n + lam), wm, wc


class UnscentedKalmanFilter(ExtendedKalmanFilter):
    """UKF with wrap-aware means and residuals.

    Parameters
    ----------
    mean, covariance, time
        The prior, as for :class:`~tmakit.filters.TrackingFilter` (m, m/s; s).
    alpha, beta, kappa : float, optional
        Sigma-point spread (> 0), prior-distribution parameter (2 for a Gaussian), secondary
        scaling parameter.
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Raises
    ------
    ValueError
        If the sigma-point parameters or the prior are not valid.

    References
    ----------
    Wan & van der Merwe (2000); Julier (2002); Chen & Sun, §2.1 (the dynamics).
    """

    name = "ukf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        n = np.asarray(mean).shape[-1] if np.ndim(mean) else 0
        self.alpha, self.beta, self.kappa = float(alpha), float(beta), float(kappa)
        self._gamma, self._wm, self._wc = unscented_weights(max(n, 1), self.alpha, self.beta,
                                                            self.kappa)
        self._wc_col = self._wc[:, None]
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)

    def sigma_points(self) -> Array:
        """Give the ``2n + 1`` sigma points of the current estimate.

        Returns
        -------
        numpy.ndarray
            ``[x, x + gamma L_j, x - gamma L_j]`` ``(2n+1, n)`` (m, m/s).
        """
        return self._plan_points(self._mean, self._cov)

    def _gaussian_step(self, rows: MeasurementGroup | Step, mean: Array, cov: Array
                       ) -> Updated:
        if isinstance(rows, tuple):
            return self._unscented(predict_rows, rows, rows[1], rows[7], rows[6], mean, cov)
        angle = rows.angle if rows.angle.any() else None
        return self._unscented(MeasurementGroup.predict, rows, rows.values, angle, rows.covariance,
                               mean, cov)

    def _plan_points(self, mean: Array, cov: Array) -> Array:
        chol, info = dpotrf(cov, lower=1, clean=1)
        if info != 0:
            chol = safe_cholesky(cov)
        dev = self._gamma * chol.T
        return np.concatenate((mean[None, :], mean + dev, mean - dev))

    def _unscented(self, predict: Callable[..., Array], arg: object, values: Array,
                   angle: Index | None, r: Array, mean: Array, cov: Array) -> Updated:
        pts = self._plan_points(mean, cov)
        z = predict(arg, pts)
        total = float(z.sum())
        if total - total != 0.0:
            self.skipped_updates += 1
            return mean, cov, float("nan"), 0, 0.0
        wm = self._wm
        zbar = wm.dot(z)
        dz = z - zbar
        nu = values - zbar
        if angle is not None:
            za = z[:, angle]
            zbar[angle] = np.arctan2(wm.dot(np.sin(za)), wm.dot(np.cos(za)))
            dz[:, angle] = wrap_small(za - zbar[angle])
            nu[angle] = wrap_small(values[angle] - zbar[angle])
        dzw = dz * self._wc_col
        pzz = dzw.T.dot(dz)
        pzz += r
        self._innovation = (nu, pzz)
        gain, nis, log_det = innovation_solve(pzz, dzw.T.dot(pts - mean), nu)
        m = nu.shape[0]
        return (mean + gain.dot(nu), checked_psd(cov - gain.dot(pzz).dot(gain.T)), nis, m,
                -0.5 * (nis + log_det + m * LOG_2PI))


class CubatureKalmanFilter(UnscentedKalmanFilter):
    """The cubature Kalman filter: the UKF's arithmetic with ``alpha = 1, beta = 0, kappa = 0``.

    Parameters
    ----------
    mean, covariance, time
        The prior, as for :class:`~tmakit.filters.TrackingFilter` (m, m/s; s).
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    References
    ----------
    Arasaratnam & Haykin (2009), eqs. 33-34 (the third-degree spherical-radial rule).
    """

    name = "ckf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        super().__init__(mean, covariance, time, alpha=1.0, beta=0.0, kappa=0.0, q=q,
                         dynamics=dynamics, options=options, nuisance=nuisance)
