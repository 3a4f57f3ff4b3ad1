"""The EKF in modified polar (2-D) and modified spherical (3-D) coordinates about the sensor.

The state relative to the sensor is ``[beta, beta_dot, r_dot / r, 1 / r]`` in 2-D (Aidala &
Hammel 1983, eq. 12) and ``[beta, epsilon, omega, epsilon_dot, r_dot / r, 1 / r]``,
``omega = beta_dot cos(epsilon)``, in 3-D (Stallard 1991; Mallick et al. 2012), bearing
clockwise from North, elevation above the horizontal (rad; rad/s; 1/s; 1/m); the 2-D form is the
3-D one at ``epsilon = epsilon_dot = 0`` (docs/tracking.md, "modified polar coordinates").

References
----------
Aidala & Hammel (1983), "Utilization of modified polar coordinates for bearings-only
tracking", IEEE Trans. Autom. Control 28(3); Stallard (1991), "Angle-only tracking filter in
modified spherical coordinates", J. Guid. Control Dyn. 14(3); Mallick, Morelande, Mihaylova,
Arulampalam & Yan (2012), "Angle-only filtering in three dimensions", in *Integrated Tracking,
Classification, and Sensor Management*, Wiley, ch. 1.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import cache
from typing import Any, Self, Unpack

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import FilterSettings, KindOptions, ProcessNoise, TrackingFilter
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import gaussian_update
from .general import DynamicsCache, finite
from .track import UpdateInfo

#: The 2-D state's places in the 3-D one, and the Cartesian 2-D state's in ``[x, y, z, vx, vy,
#: vz]``.
_MP_IN_MSC = [0, 2, 4, 5]
_XY_IN_XYZ = [0, 1, 3, 4]
_ALL = list(range(6))
_TAKE: dict[int, tuple[Any, Any]] = {4: (np.array(_XY_IN_XYZ), np.ix_(_XY_IN_XYZ, _MP_IN_MSC)),
         6: (slice(None), slice(None))}
#: Nodes of the prior's moments (:meth:`ModifiedPolarEKF.from_first_bearing`): log-range,
#: height, bearing.
_NODES = (48, 12, 5)


@cache
def _nodes(kind: str, count: int) -> tuple[Array, Array]:
    """Gauss-Legendre (on [-1, 1]) or Gauss-Hermite (standard normal) nodes and weights."""
    if kind == "legendre":
        x, w = np.polynomial.legendre.leggauss(count)
        return x, w / 2.0
    x, w = np.polynomial.hermite_e.hermegauss(count)
    return x, w / math.sqrt(2.0 * math.pi)


def _line_of_sight(b: ArrayLike, e: ArrayLike) -> tuple[Array, Array, Array]:
    """Give ``u``, ``e_beta``, ``e_eps`` ``(..., 3)`` at bearings ``b`` and elevations ``e``."""
    b, e = np.broadcast_arrays(np.asarray(b, dtype=float), np.asarray(e, dtype=float))
    sb, cb, se, ce = np.sin(b), np.cos(b), np.sin(e), np.cos(e)
    return (np.stack([sb * ce, cb * ce, se], -1), np.stack([cb, -sb, np.zeros_like(b)], -1),
            np.stack([-sb * se, -cb * se, ce], -1))


def _msc_to_cartesian(msc: list[float], keep: list[int]) -> tuple[Array, Array]:
    """Give rows/columns ``keep`` of the relative Cartesian state and ``d rel / d msc`` (floats)."""
    b, e, w, ed, g, rho = msc
    sb, cb, se, ce = math.sin(b), math.cos(b), math.sin(e), math.cos(e)
    r = 1.0 / rho
    u0, u1, u2 = sb * ce * r, cb * ce * r, se * r  # u, e_beta, e_eps: the frame, times r
    b0, b1 = cb * r, -sb * r
    e0, e1, e2 = -sb * se * r, -cb * se * r, ce * r
    v0, v1, v2 = g * u0 + w * b0 + ed * e0, g * u1 + w * b1 + ed * e1, g * u2 + ed * e2
    turn = g * ce - ed * se  # d u / d beta = cos(e) e_beta; d e_eps / d beta = -sin(e) e_beta
    jac = np.array([
        [ce * b0, e0, 0.0, 0.0, 0.0, -u0 * r],
        [ce * b1, e1, 0.0, 0.0, 0.0, -u1 * r],
        [0.0, e2, 0.0, 0.0, 0.0, -u2 * r],
        [turn * b0 - w * sb * r, g * e0 - ed * u0, b0, e0, u0, -v0 * r],
        [turn * b1 - w * cb * r, g * e1 - ed * u1, b1, e1, u1, -v1 * r],
        [0.0, g * e2 - ed * u2, 0.0, e2, u2, -v2 * r]])
    rows, columns = _TAKE[len(keep)]
    return np.array([u0, u1, u2, v0, v1, v2])[rows], jac[columns]


def from_modified_polar(mp: ArrayLike) -> tuple[Array, Array]:
    """Give the relative Cartesian state of a modified polar/spherical one, and ``d rel / d mp``."""
    values = np.asarray(mp, dtype=float).tolist()
    if len(values) == 6:
        return _msc_to_cartesian(values, _ALL)
    b, w, g, rho = values
    return _msc_to_cartesian([b, 0.0, w, 0.0, g, rho], _XY_IN_XYZ)


def to_modified_polar(rel: ArrayLike) -> Array:
    """Give the modified polar (2-D) or spherical (3-D) state of a relative Cartesian state."""
    values = np.asarray(rel, dtype=float).tolist()
    flat = len(values) == 4
    x, y, z, vx, vy, vz = ((values[0], values[1], 0.0, values[2], values[3], 0.0) if flat
                           else values)
    h2 = x * x + y * y
    r2 = h2 + z * z
    r, h = math.sqrt(r2), math.sqrt(h2)
    b, e = math.atan2(x, y), math.atan2(z, h)
    sb, cb, se, ce = math.sin(b), math.cos(b), math.sin(e), math.cos(e)
    omega = (vx * cb - vy * sb) / r  # v . e_beta / r
    if flat:
        return np.array([b, omega, (x * vx + y * vy) / r2, 1.0 / r])
    return np.array([b, e, omega, (ce * vz - se * (vx * sb + vy * cb)) / r,
                     (x * vx + y * vy + z * vz) / r2, 1.0 / r])


def prior_moments(prior: BearingPrior, first: FirstBearing, dim: int) -> tuple[Array, Array]:
    """Give the bearing prior's mean and covariance in these coordinates, by quadrature.

    Gauss-Legendre over the log-uniform range and the uniform height, Gauss-Hermite over the
    bearing's error; the rates' moments given the position are exact (linear in the velocity).
    """
    leg = _nodes("legendre", _NODES[0])
    log_r = math.log(prior.range_min) + 0.5 * (leg[0] + 1.0) * math.log(prior.range_max
                                                                       / prior.range_min)
    lo, hi = prior.height if dim == 3 else (first.sensor[2], first.sensor[2])
    hl = _nodes("legendre", _NODES[1]) if hi > lo else (np.zeros(1), np.ones(1))
    heights = lo + 0.5 * (hl[0] + 1.0) * (hi - lo)
    her = _nodes("hermite", _NODES[2])
    bearings = first.bearing + first.sigma * her[0]
    weights = leg[1][:, None, None] * hl[1][None, :, None] * her[1][None, None, :]
    velocity = prior.gaussian(first, dim)[1][dim:, dim:]
    v_cov = np.zeros((3, 3))
    v_cov[:dim, :dim] = velocity
    horizontal = np.exp(log_r)[:, None, None]
    dz = (heights - first.sensor[2])[None, :, None]
    e = np.broadcast_to(np.arctan2(dz, horizontal), weights.shape).reshape(-1)
    b = np.broadcast_to(bearings[None, None, :], weights.shape).reshape(-1)
    rho = np.broadcast_to(1.0 / np.hypot(horizontal, dz), weights.shape).reshape(-1)
    frame = np.stack(_line_of_sight(b, e), -1)  # columns u, e_beta, e_eps
    w = weights.reshape(-1)
    m = np.zeros((w.shape[0], 6))
    m[:, 0], m[:, 1], m[:, 5] = b, e, rho
    rates = [4, 2, 3]  # r_dot/r, omega, epsilon_dot: along u, e_beta, e_eps
    m[:, rates] = -rho[:, None] * (first.sensor[3:] @ frame)
    mean = w @ m
    d = m - mean
    cov = (d.T * w) @ d
    given_position = np.swapaxes(frame, 1, 2) @ v_cov @ frame
    cov[np.ix_(rates, rates)] += np.tensordot(w * rho**2, given_position, 1)
    keep = _MP_IN_MSC if dim == 2 else _ALL
    return mean[keep], 0.5 * (cov + cov.T)[np.ix_(keep, keep)]


class ModifiedPolarEKF(TrackingFilter):
    """EKF in modified polar (2-D) or modified spherical (3-D) coordinates about the sensor.

    The estimate is held relative to a reference (the last update's sensor, moving at its
    velocity); the prediction and the move of the reference to each update's sensor are exact
    maps through Cartesian coordinates, the covariance carried by their Jacobians.
    :attr:`state` and :attr:`covariance` are Cartesian.

    Parameters
    ----------
    mean, covariance, time
        A Cartesian prior, as for :class:`~tmakit.filters.TrackingFilter`;
        :meth:`from_first_bearing` starts from the bearing prior in these coordinates.
    origin : array_like, optional
        The reference ``[x, y, (z), vx, vy, (vz)]`` at the prior's time (m, m/s; default the
        ENU origin at rest); each update moves it to its sensor.
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Raises
    ------
    ValueError
        If the prior's position is at the origin, or the origin's size is not the state's.

    References
    ----------
    Aidala & Hammel (1983); Stallard (1991); Mallick et al. (2012).
    """

    name = "mpekf"

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 origin: ArrayLike | None = None, q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self._ref = np.zeros(0) if origin is None else np.asarray(origin, dtype=float).ravel()
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        self._cache = DynamicsCache(self.dynamics)
        self._sensor_part = _XY_IN_XYZ if self.dim == 2 else _ALL

    def _init_state(self, mean: Array, covariance: Array) -> None:
        if self._ref.shape[0] == 0:
            self._ref = np.zeros(mean.shape[0])
        if self._ref.shape != mean.shape:
            raise ValueError(f"mpekf: the origin has {self._ref.shape[0]} components; the "
                             f"state has {mean.shape[0]}")
        rel = mean - self._ref
        if not np.linalg.norm(rel[:self.dim]) > 0:
            raise ValueError("mpekf: the prior's position is at its origin (range 0)")
        self._mp = to_modified_polar(rel)
        g = np.linalg.inv(from_modified_polar(self._mp)[1])
        self._p = g @ covariance @ g.T

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **settings: Unpack[FilterSettings]) -> Self:
        """Start at the first bearing with the prior's moments in these coordinates.

        ``1 / r`` has the moments of the log-uniform range (and, in 3-D, the uniform height);
        the rates those of the relative velocity over the range (:func:`prior_moments`); the
        origin is the first bearing's sensor.

        Takes the base's parameters (:meth:`TrackingFilter.from_first_bearing`), but
        ``origin``.

        Raises
        ------
        TypeError
            If ``origin`` is given too, or the class takes no keyword of that name.
        """
        if "origin" in settings:
            raise TypeError("from_first_bearing() got origin: the origin is the first "
                            "bearing's sensor")
        mean, cov = prior_moments(prior, first, dim)
        origin = first.sensor[_XY_IN_XYZ if dim == 2 else slice(None)]
        filt = cls._made(origin + from_modified_polar(mean)[0], np.eye(2 * dim), first.time,
                         {**settings, "origin": origin})
        filt._mp, filt._p = mean, cov
        return filt

    @property
    def state(self) -> Array:
        """The Cartesian state ``(n,)`` at :attr:`time` (m, m/s)."""
        return self._ref + from_modified_polar(self._mp)[0]

    @property
    def covariance(self) -> Array:
        """Its covariance ``(n, n)``, through the transform's Jacobian."""
        j = from_modified_polar(self._mp)[1]
        return j @ self._p @ j.T

    @property
    def modified_polar(self) -> tuple[Array, Array]:
        """The modified polar/spherical mean ``(n,)`` and covariance, about the reference."""
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
        sensor = np.asarray(group.sensor_state).reshape(-1, 6)[0, self._sensor_part]
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
        if not mp[-1] > 0:  # 1/r <= 0: past the sensor; keep the prediction
            return self._skip()
        mp[0] = math.remainder(mp[0], 2 * math.pi)
        self._mp, self._p = mp, p
        return info
