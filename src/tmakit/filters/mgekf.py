"""The modified-gain extended Kalman filter of Chen & Sun, §2.3-2.5.

Bearing rows use the pseudo-linear modified gain of Song & Speyer (``g_i = r_i / (rho_i sin r_i)
H_i(Z^m)``, ``mu_i = 0``: :func:`modified_gain_rows` takes any ``mu``); other rows the EKF
Jacobian (§2.4).  ``gain="paper"`` puts the modified rows in the gain as Chen & Sun print (biased
towards the sensor, docs/tracking.md); ``"song-speyer"`` (default) only in the covariance.  A row
falls back to its EKF row near ``|1 - mu| < MU_FLOOR`` (counted in :attr:`fallbacks`);
``reflect=True`` mirrors an estimate that ends below the sensors' plane.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..data import MeasurementSet
from ..motion.dynamics import NearlyConstantVelocity
from ..observation import MeasurementGroup
from .base import KindOptions, ProcessNoise
from .ekf import ExtendedKalmanFilter, gaussian_update, linearise_group
from .track import UpdateInfo

#: A bearing row with ``|1 - mu|`` below this uses its EKF row instead.
MU_FLOOR = 1e-3


@dataclass(frozen=True)
class ModifiedRows:
    """Modified-gain bearing rows of Chen & Sun, §2.3 (``(m, ...)``; unfilled where not ``ok``)."""

    g: Array  # the rows g' = U g (rad per state unit)
    u: Array  # the diagonal of U (1 where not ok)
    denominator: Array  # H_i(Z^m) X' (m)
    ok: NDArray[np.bool_]  # the row is a modified one


def pseudo_linear_rows(measured: ArrayLike, dt: ArrayLike, dim: int) -> Array:
    """Give the pseudo-linear rows ``H_i(Z^m)`` of measured bearings (Chen & Sun, §2.3, eq. 2)."""
    b = np.asarray(measured, dtype=float)
    dt = np.asarray(dt, dtype=float)
    out = np.zeros((b.shape[0], 2 * dim))
    c, s = np.cos(b), np.sin(b)
    out[:, 0], out[:, 1] = c, -s
    out[:, dim], out[:, dim + 1] = dt * c, -dt * s
    return out


def modified_gain_rows(measured: ArrayLike, rel: ArrayLike, dt: ArrayLike, dim: int,
                       residual: ArrayLike, mu: ArrayLike | None = None) -> ModifiedRows:
    """Compute the WMEKF bearing rows of Chen & Sun, §2.3, in tmakit's bearing convention."""
    b = np.asarray(measured, dtype=float)
    rel = np.asarray(rel, dtype=float).reshape(b.shape[0], 6)
    r = np.asarray(residual, dtype=float)
    mu_v = np.zeros(b.shape) if mu is None else np.broadcast_to(
        np.asarray(mu, dtype=float), b.shape)
    h = pseudo_linear_rows(b, dt, dim)
    denom = np.cos(b) * rel[:, 0] - np.sin(b) * rel[:, 1]
    rho = np.hypot(rel[:, 0], rel[:, 1])
    one_minus = 1.0 - mu_v
    ok = ((rho > 1e-9 * max(1.0, float(np.max(np.abs(rel[:, :3]), initial=0.0))))
          & (np.cos(r) > 0.0) & (np.abs(one_minus) >= MU_FLOOR)
          & np.isfinite(r) & np.isfinite(one_minus))
    # -r / (H X^') = r / (rho sin r): the stable form, 1 / rho at r = 0.
    coef = np.where(ok, 1.0 / (np.where(ok, rho, 1.0) * np.sinc(r / np.pi)), 0.0)
    u = np.where(ok, 1.0 / np.where(ok, one_minus, 1.0), 1.0)
    g = (u * coef)[:, None] * h
    return ModifiedRows(g, u, denom, ok)


class MirrorReflectMixin:
    """Keep a 3-D Gaussian estimate above the sensors' plane while the data cannot tell."""

    reflect_default = False
    dim: int
    _mean: Array
    _cov: Array

    def _start_reflecting(self, reflect: bool | None) -> None:
        self.reflect = self.reflect_default if reflect is None else bool(reflect)
        self.reflections = 0
        self._plane: float | None = None
        self._symmetric = True

    def update(self, rows: MeasurementSet | MeasurementGroup) -> UpdateInfo:
        """Update as the filter does, then reflect the estimate if the mirror rule says so."""
        info: UpdateInfo = super().update(rows)  # type: ignore[misc]
        if not (self.reflect and self._symmetric) or isinstance(rows, MeasurementGroup):
            return info
        plane = rows.mirror_plane()
        if plane is None or (self._plane is not None and abs(plane - self._plane) > 1e-6):
            self._symmetric = False
        elif self._plane is None:
            self._plane = plane
        if self._symmetric and self._plane is not None and self.dim == 3 \
                and self._mean[2] < self._plane:
            m = np.array([1.0, 1.0, -1.0, 1.0, 1.0, -1.0])
            mean = self._mean * m
            mean[2] += 2.0 * self._plane
            self._mean = mean
            self._cov = self._cov * m[:, None] * m[None, :]
            self.reflections += 1
        return info


class ModifiedGainEKF(MirrorReflectMixin, ExtendedKalmanFilter):
    """The modified-gain EKF (WMEKF) of Chen & Sun, §2.3-2.5 (module text).

    Parameters
    ----------
    mean, covariance, time
        The prior, as for :class:`~tmakit.filters.TrackingFilter` (m, m/s; s).
    gain : {"song-speyer", "paper"}, optional
        ``"paper"`` (Chen & Sun, §2.5: the modified rows in the gain and the covariance update)
        or ``"song-speyer"`` (Song & Speyer's MGEKF: the gain from the EKF rows).
    reflect : bool, optional
        Mirror an estimate that falls below the sensors' plane while the data cannot tell the two
        sides apart (default off).
    iterations, q, dynamics, options, nuisance
        As for :class:`ExtendedKalmanFilter`.

    Attributes
    ----------
    fallbacks : int
        Bearing rows that used the EKF row.
    bearing_rows : int
        All bearing rows seen.

    Raises
    ------
    ValueError
        If ``gain`` is neither ``"paper"`` nor ``"song-speyer"``, or the prior is not valid.

    References
    ----------
    Chen & Sun, §2.3-2.5.
    """

    name = "mgekf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 gain: str = "song-speyer", reflect: bool | None = None, iterations: int = 1,
                 q: ProcessNoise = 0.0, dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        if gain not in ("paper", "song-speyer"):
            raise ValueError(f"gain must be 'paper' (Chen & Sun, §2.5: modified rows in the gain "
                             f"and the covariance) or 'song-speyer' (EKF rows in the gain); "
                             f"got {gain!r}")
        self.gain = gain
        self.fallbacks = 0
        self.bearing_rows = 0
        self._start_reflecting(reflect)
        super().__init__(mean, covariance, time, iterations=iterations, q=q, dynamics=dynamics,
                         options=options, nuisance=nuisance)

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        x = self._mean
        residual, h_ekf, ok = linearise_group(group, x)
        if not ok:
            return self._skip()  # the estimate on top of a sensor (as the EKF does)
        h = h_ekf.copy()
        r = group.covariance
        where = group.index.get("bearing")
        idx = None if where is None else np.arange(residual.shape[0])[where]
        if idx is not None:
            rel = group.relative(x)[0][idx]
            mod = modified_gain_rows(group.values[idx], rel, group.dt[idx], self.dim,
                                     residual[idx])
            h[idx[mod.ok]] = mod.g[mod.ok]  # mu = 0: U = I, g' = g and R' = R
            self.fallbacks += int(np.count_nonzero(~mod.ok))
            self.bearing_rows += int(idx.size)
        if self.gain == "paper" or idx is None:
            self._mean, self._cov, info = gaussian_update(x, self._cov, residual, h, r)
            return info
        # Song & Speyer (1985): the gain from the EKF rows, the modified rows in the covariance.
        self._mean, self._cov, info = gaussian_update(x, self._cov, residual, h_ekf, r, h_cov=h)
        return info


class ReflectingEKF(MirrorReflectMixin, ExtendedKalmanFilter):
    """The plain EKF with the mirror rule of :class:`ModifiedGainEKF` on by default."""

    name = "ekf"
    reflect_default = True

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 reflect: bool | None = None, iterations: int = 1, q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self._start_reflecting(reflect)
        super().__init__(mean, covariance, time, iterations=iterations, q=q, dynamics=dynamics,
                         options=options, nuisance=nuisance)
