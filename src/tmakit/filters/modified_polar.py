"""The EKF in modified polar coordinates for 2-D tracking from bearings (Aidala & Hammel 1983).

The state relative to the sensor is ``[beta, beta_dot, r_dot / r, 1 / r]`` (bearing clockwise
from North, rad; rad/s; 1/s; 1/m): the bearing is a state, and 1/r, unobservable before the
own ship manoeuvres, is decoupled from the rest (Aidala & Hammel 1983, eq. 12).

References
----------
Aidala & Hammel (1983), "Utilization of modified polar coordinates for bearings-only
tracking", IEEE Trans. Autom. Control 28(3).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import Array, KindOptions, ProcessNoise, TrackingFilter, UpdateInfo
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import gaussian_update
from .general import DynamicsCache, finite


def from_modified_polar(mp: ArrayLike) -> tuple[Array, Array]:
    """Give the relative Cartesian state of a modified polar state and ``d rel / d mp`` (eq. 12)."""
    b, bd, rr, ir = (float(v) for v in np.asarray(mp, dtype=float))
    s, c = math.sin(b), math.cos(b)
    rel = np.array([s, c, rr * s + bd * c, rr * c - bd * s]) / ir
    jac = np.array([[c, 0.0, 0.0, 0.0], [-s, 0.0, 0.0, 0.0],
                    [rr * c - bd * s, c, s, 0.0], [-rr * s - bd * c, -s, c, 0.0]]) / ir
    jac[:, 3] = -rel / ir
    return rel, jac


def to_modified_polar(rel: ArrayLike) -> Array:
    """Give the modified polar state of a relative Cartesian state ``[x, y, vx, vy]``."""
    x, y, vx, vy = (float(v) for v in np.asarray(rel, dtype=float))
    r2 = x * x + y * y
    return np.array([math.atan2(x, y), (vx * y - vy * x) / r2, (x * vx + y * vy) / r2,
                     1.0 / math.sqrt(r2)])


class ModifiedPolarEKF(TrackingFilter):
    """EKF in modified polar coordinates about the sensor (2-D; Aidala & Hammel 1983).

    The estimate is held relative to a reference (the last update's sensor, moving at its
    velocity); the prediction, and the move of the reference to each update's sensor, are the
    exact nonlinear maps through Cartesian coordinates with their Jacobians.  :attr:`state`
    and :attr:`covariance` are Cartesian (the covariance through the transform's Jacobian).

    Parameters
    ----------
    mean, covariance, time
        A Cartesian prior, as for :class:`~tmakit.filters.TrackingFilter` (2-D only);
        :meth:`from_first_bearing` starts from the bearing prior in modified polar terms.
    origin : array_like, optional
        The reference ``[x, y, vx, vy]`` at the prior's time (m, m/s); each update moves it
        to its sensor.
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Raises
    ------
    ValueError
        If the prior is not 2-D or its mean lies at the origin.

    References
    ----------
    Aidala & Hammel (1983).
    """

    name = "mpekf"
    dims = (2,)

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 origin: ArrayLike = (0.0, 0.0, 0.0, 0.0), q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self._ref = np.asarray(origin, dtype=float).reshape(4)
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        self._cache = DynamicsCache(self.dynamics)

    def _init_state(self, mean: Array, covariance: Array) -> None:
        if mean.shape[0] != 4:
            raise ValueError("mpekf (modified polar coordinates) tracks in 2-D only; the "
                             "state is 3-D: use ekf, ukf, ckf, gsf or pf")
        rel = mean - self._ref
        if not np.hypot(rel[0], rel[1]) > 0:
            raise ValueError("mpekf: the prior's position is at its origin (range 0)")
        self._mp = to_modified_polar(rel)
        g = np.linalg.inv(from_modified_polar(self._mp)[1])
        self._p = g @ covariance @ g.T

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **kwargs: Any) -> ModifiedPolarEKF:
        """Start at the first bearing with the prior's exact modified polar moments.

        ``1 / r`` has the moments of the log-uniform range; ``beta_dot`` and ``r_dot / r``
        those of the relative velocity over the range.

        Raises
        ------
        ValueError
            If ``dim`` is not 2.
        """
        if dim != 2:
            raise ValueError("mpekf (modified polar coordinates) tracks in 2-D only; the "
                             "data are 3-D: use ekf, ukf, ckf, gsf or pf")
        a, b = prior.range_min, prior.range_max
        span = math.log(b / a)
        m1, m2 = (1 / a - 1 / b) / span, (1 / a**2 - 1 / b**2) / (2 * span)  # E[1/r], E[1/r^2]
        sb, cb = math.sin(first.bearing), math.cos(first.bearing)
        vs = first.sensor[3:5]
        c = np.array([-(vs[0] * cb - vs[1] * sb), -(vs[0] * sb + vs[1] * cb), 1.0])
        origin = first.sensor[[0, 1, 3, 4]]
        filt = cls(origin + np.array([sb, cb, 0, 0]) / m1, np.eye(4), first.time,
                   origin=origin, **kwargs)
        filt._mp = np.array([first.bearing, c[0] * m1, c[1] * m1, m1])
        filt._p = np.zeros((4, 4))
        filt._p[0, 0] = first.sigma**2
        filt._p[1:, 1:] = np.outer(c, c) * (m2 - m1 * m1) \
            + np.diag([1.0, 1.0, 0.0]) * prior.speed_max**2 / 4.0 * m2
        return filt

    @property
    def state(self) -> Array:
        """The Cartesian state ``(4,)`` at :attr:`time` (m, m/s)."""
        return self._ref + from_modified_polar(self._mp)[0]

    @property
    def covariance(self) -> Array:
        """Its covariance ``(4, 4)``, through the transform's Jacobian."""
        j = from_modified_polar(self._mp)[1]
        return j @ self._p @ j.T

    @property
    def modified_polar(self) -> tuple[Array, Array]:
        """The modified polar mean ``(4,)`` and covariance ``(4, 4)``, about the reference."""
        return self._mp.copy(), self._p.copy()

    def _move(self, rel: Array, a_pre: Array, q: Array | None = None) -> None:
        """Set the estimate to ``rel``, its error ``a_pre`` times the old one, plus noise ``q``."""
        self._mp = to_modified_polar(rel)
        g = np.linalg.inv(from_modified_polar(self._mp)[1])
        a = g @ a_pre
        p = a @ self._p @ a.T
        if q is not None:
            p += g @ q @ g.T
        self._p = 0.5 * (p + p.T)

    def _predict(self, dt: float) -> None:
        phi, _, q = self._cache.get(dt)
        rel, j = from_modified_polar(self._mp)
        self._ref = phi @ self._ref  # the reference moves at its velocity
        self._move(phi @ rel, phi @ j, q)

    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        sensor = np.asarray(group.sensor_state).reshape(-1, 6)[0, [0, 1, 3, 4]]
        rel, j = from_modified_polar(self._mp)
        self._move(rel + self._ref - sensor, j)
        self._ref = sensor
        rel, j = from_modified_polar(self._mp)
        x = self._ref + rel
        y = group.residual(group.predict(x))
        h = group.jacobian(x) @ j
        if not finite(y, h):
            return self._skip()
        mp, p, info = gaussian_update(self._mp, self._p, y, h, group.covariance)
        if not mp[3] > 0:  # 1/r <= 0: past the sensor; keep the prediction
            return self._skip()
        mp[0] = math.remainder(mp[0], 2 * math.pi)
        self._mp, self._p = mp, p
        return info
