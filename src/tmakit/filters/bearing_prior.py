"""What a single bearing says about an emitter, with the user's range and speed intervals.

References
----------
Peach (1995), "Bearings-only tracking using a set of range-parameterised extended Kalman
filters", IEE Proc. Control Theory Appl. 142(1); Ristic, Arulampalam & Gordon (2004),
*Beyond the Kalman Filter*, ch. 6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.arrays import Array
from ..core.units import REACH_M
from ..data import MeasurementSet
from ..measurements import KINDS
from ..motion.dynamics import state_names
from ..results.checks import FAST_SPEED

__all__ = ["DEFAULT_HEIGHT", "DEFAULT_RANGE", "DEFAULT_SPEED", "MAX_RANGE_CV", "BearingPrior",
           "FirstBearing", "first_bearing", "prior_problems"]

#: Default range interval (m): a surface or air contact held by passive sonar or ESM.
DEFAULT_RANGE = (500.0, 50_000.0)
#: Default largest speed (m/s, about 39 kn): a fast surface vessel.
DEFAULT_SPEED = 20.0
#: Default height interval (m, ENU z) of a 3-D track: from the surface to 12 km.
DEFAULT_HEIGHT = (0.0, 12_000.0)
#: The range interval a prior may state (m): nearer than 1 m is no bearing's emitter (and a
#: component's covariance loses its digits), farther than REACH_M leaves the local frame.
RANGE_LIMITS = (1.0, REACH_M)
#: The largest speed a prior may state (m/s): above the speed no craft near the Earth
#: exceeds, and at least 1 mm/s (a smaller velocity variance is singular beside the range's).
SPEED_LIMITS = (1e-3, FAST_SPEED)
#: Largest coefficient of variation (range std / range) of a component of the range-
#: parameterised sum: the EKF's linearisation holds while it is small (Peach 1995, §3).
MAX_RANGE_CV = 0.12

_BEARING = list(KINDS).index("bearing")


@dataclass(frozen=True)
class FirstBearing:
    """The first bearing of a measurement set: what a :class:`BearingPrior` is centred on.

    Parameters
    ----------
    time : float
        Its time (s).
    bearing, sigma : float
        Its value and standard deviation (rad, clockwise from North).
    sensor : numpy.ndarray
        The sensor's state ``(6,)`` (m, m/s).
    row : int
        Its row in the set.
    """

    time: float
    bearing: float
    sigma: float
    sensor: Array
    row: int


def first_bearing(meas: MeasurementSet) -> FirstBearing:
    """Find the first bearing row of ``meas`` (the earliest; the first row of that time).

    Parameters
    ----------
    meas : MeasurementSet

    Returns
    -------
    FirstBearing

    Raises
    ------
    ValueError
        If the set has no bearing.
    """
    rows = np.flatnonzero(meas.kind_code == _BEARING)
    if rows.size == 0:
        raise ValueError("a start from the first bearing needs a bearing row; the set has "
                         f"only {', '.join(meas.kinds) or 'no rows'}")
    row = int(rows[np.argmin(meas.time[rows])])  # the first of equal times
    return FirstBearing(float(meas.time[row]), float(meas.value_si[row]),
                        float(meas.sigma_si[row]), meas.sensor_state[row].copy(), row)


def prior_problems(range_m: tuple[float, float], speed_max: float,
                   height: tuple[float, float]) -> dict[str, str]:
    """Say what each of ``range``, ``speed`` and ``height`` should have been, if it is not.

    Parameters
    ----------
    range_m : tuple of float
        The range interval (m).
    speed_max : float
        The largest speed (m/s).
    height : tuple of float
        The height interval (m).

    Returns
    -------
    dict of str to str
        The names of the bad ones, each with what was expected (empty when all are good).
    """
    (a, b), (lo, hi), speed = ((float(v) for v in range_m), (float(v) for v in height),
                               float(speed_max))
    found: dict[str, str] = {}
    if not (RANGE_LIMITS[0] <= a < b <= RANGE_LIMITS[1]):
        found["range"] = (f"expected MIN:MAX with {RANGE_LIMITS[0]:g} <= MIN < MAX <= "
                          f"{RANGE_LIMITS[1]:g} (m)")
    if not SPEED_LIMITS[0] <= speed <= SPEED_LIMITS[1]:
        found["speed"] = (f"expected a largest speed within [{SPEED_LIMITS[0]:g}, "
                          f"{SPEED_LIMITS[1]:g}] m/s")
    if not -REACH_M <= lo <= hi <= REACH_M:
        found["height"] = f"expected MIN:MAX with {-REACH_M:g} <= MIN <= MAX <= {REACH_M:g} (m)"
    return found


@dataclass(frozen=True)
class BearingPrior:
    """The prior of a track started at its first bearing.

    Parameters
    ----------
    range_min, range_max : float
        The horizontal range interval at the first bearing (m, ``0 < range_min < range_max``),
        uniform in log-range.
    speed_max : float
        Largest plausible speed (m/s, > 0): the velocity is uniform over the disc of this radius
        (3-D: ``vz`` with the spread of one horizontal axis).
    height : tuple of float, optional
        The emitter's height interval (m, ENU z) of a 3-D track, uniform.
    given : tuple of str, optional
        Which of ``range``, ``speed``, ``height`` the user gave (the others are defaults).

    Raises
    ------
    ValueError
        For an empty or non-finite interval, or one beyond what a prior may state
        (:func:`prior_problems`: a range within 1 m .. 1e9 m, a speed within 1 mm/s .. 10 km/s,
        a height within +-1e9 m).
    """

    range_min: float = DEFAULT_RANGE[0]
    range_max: float = DEFAULT_RANGE[1]
    speed_max: float = DEFAULT_SPEED
    height: tuple[float, float] = DEFAULT_HEIGHT
    given: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Refuse what :func:`prior_problems` finds."""
        given = {"range": f"{self.range_min:g}:{self.range_max:g}",
                 "speed": f"{self.speed_max:g}", "height": "{:g}:{:g}".format(*self.height)}
        found = prior_problems((self.range_min, self.range_max), self.speed_max, self.height)
        if found:
            raise ValueError("; ".join(f"the {k} prior {given[k]}: {v}" for k, v in found.items()))

    def describe(self) -> str:
        """Say the prior in one line, marking the defaults.

        Returns
        -------
        str
            ``range 500..50000 m (default), speed <= 20 m/s (default)``.
        """
        def tag(what: str) -> str:
            return "" if what in self.given else " (default)"
        return (f"range {self.range_min:g}..{self.range_max:g} m{tag('range')}, speed <= "
                f"{self.speed_max:g} m/s{tag('speed')}")

    def as_dict(self) -> dict[str, object]:
        """Give the prior as JSON-ready data.

        Returns
        -------
        dict
            ``range_m``, ``speed_max_m_s``, ``height_m`` and ``given``.
        """
        return {"range_m": [self.range_min, self.range_max], "speed_max_m_s": self.speed_max,
                "height_m": list(self.height), "given": list(self.given)}

    def component_count(self, max_cv: float = MAX_RANGE_CV) -> int:
        """Give the fewest components (>= 1) whose range std is at most ``max_cv`` of their range.

        A sub-interval ``[a, rho a]`` has the coefficient of variation
        ``(rho - 1) / (sqrt(3) (rho + 1))`` (Peach 1995, §3).

        Parameters
        ----------
        max_cv : float
            Largest coefficient of variation (> 0).

        Returns
        -------
        int
        """
        c = math.sqrt(3.0) * max_cv
        rho = (1.0 + c) / (1.0 - c) if c < 1 else math.inf
        return max(1, math.ceil(math.log(self.range_max / self.range_min) / math.log(rho)
                                - 1e-9))

    def _velocity_var(self) -> float:
        return self.speed_max**2 / 4.0  # per axis, uniform over the disc

    def _height_and_velocity(self, mean: Array, cov: Array, dim: int) -> None:
        """Fill the height (3-D) and velocity moments of a mean ``(..., n)`` and covariance."""
        if dim == 3:
            lo, hi = self.height
            mean[..., 2] = 0.5 * (lo + hi)
            cov[..., 2, 2] = max((hi - lo) ** 2 / 12.0, 1e-6)
        cov[..., dim:, dim:] = self._velocity_var() * np.eye(dim)

    def _frame(self, first: FirstBearing, dim: int) -> tuple[Array, Array]:
        """Give the unit line of sight and its normal (horizontal), as ``dim``-vectors."""
        u = np.zeros(dim)
        e = np.zeros(dim)
        u[:2] = math.sin(first.bearing), math.cos(first.bearing)
        e[:2] = math.cos(first.bearing), -math.sin(first.bearing)
        return u, e

    def mixture(self, first: FirstBearing, dim: int = 2, components: int | None = None
                ) -> tuple[Array, Array, Array]:
        """Give the range-parameterised Gaussian sum of the prior (Peach 1995).

        Parameters
        ----------
        first : FirstBearing
            The bearing it is centred on.
        dim : int
            2 or 3.
        components : int, optional
            Number of components; default :meth:`component_count`.

        Returns
        -------
        weights, means, covariances : numpy.ndarray
            ``(M,)`` equal, ``(M, 2 dim)`` (m, m/s) and ``(M, 2 dim, 2 dim)``.

        Raises
        ------
        ValueError
            For ``dim`` other than 2 or 3, or fewer than one component.
        """
        state_names(dim)
        m = self.component_count() if components is None else int(components)
        if m < 1:
            raise ValueError(f"components must be >= 1; got {components}")
        rho = (self.range_max / self.range_min) ** (1.0 / m)
        lows = self.range_min * rho ** np.arange(m)
        r = 0.5 * lows * (1.0 + rho)
        sd_r = lows * (rho - 1.0) / math.sqrt(12.0)
        u, e = self._frame(first, dim)
        n = 2 * dim
        means = np.zeros((m, n))
        means[:, :dim] = first.sensor[:dim] + r[:, None] * u
        covs = np.zeros((m, n, n))
        # Across the line of sight: the bearing's noise at the component's range (and the
        # range spread's own share of bearing uncertainty).
        cross = (r**2 + sd_r**2) * first.sigma**2
        covs[:, :dim, :dim] = (sd_r**2)[:, None, None] * np.outer(u, u) \
            + cross[:, None, None] * np.outer(e, e)
        self._height_and_velocity(means, covs, dim)
        return np.full(m, 1.0 / m), means, covs

    def gaussian(self, first: FirstBearing, dim: int = 2) -> tuple[Array, Array]:
        """Give the prior's mean and covariance (the exact moments of the log-uniform range).

        Parameters
        ----------
        first, dim
            As for :meth:`mixture`.

        Returns
        -------
        mean, covariance : numpy.ndarray
            ``(2 dim,)`` (m, m/s) and ``(2 dim, 2 dim)``.
        """
        a, b = self.range_min, self.range_max
        span = math.log(b / a)
        er = (b - a) / span                      # E[r] of a log-uniform range
        er2 = (b * b - a * a) / (2.0 * span)     # E[r^2]
        u, e = self._frame(first, dim)
        n = 2 * dim
        mean = np.zeros(n)
        mean[:dim] = first.sensor[:dim] + er * u
        cov = np.zeros((n, n))
        cov[:dim, :dim] = (er2 - er * er) * np.outer(u, u) \
            + er2 * first.sigma**2 * np.outer(e, e)
        self._height_and_velocity(mean, cov, dim)
        return mean, cov

    def sample(self, first: FirstBearing, count: int, rng: np.random.Generator,
               dim: int = 2) -> Array:
        """Draw ``count`` states ``(count, 2 dim)`` (m, m/s) from the prior, the bearing normal.

        Parameters
        ----------
        first, dim
            As for :meth:`mixture`.
        count : int
        rng : numpy.random.Generator

        Returns
        -------
        numpy.ndarray
        """
        r = self.range_min * np.exp(rng.random(count) * math.log(self.range_max
                                                                 / self.range_min))
        b = first.bearing + first.sigma * rng.standard_normal(count)
        speed = self.speed_max * np.sqrt(rng.random(count))
        course = 2.0 * math.pi * rng.random(count)
        out = np.zeros((count, 2 * dim))
        out[:, 0] = first.sensor[0] + r * np.sin(b)
        out[:, 1] = first.sensor[1] + r * np.cos(b)
        out[:, dim] = speed * np.sin(course)
        out[:, dim + 1] = speed * np.cos(course)
        if dim == 3:
            lo, hi = self.height
            out[:, 2] = lo + (hi - lo) * rng.random(count)
            out[:, 5] = math.sqrt(self._velocity_var()) * rng.standard_normal(count)
        return out
