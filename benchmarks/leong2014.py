"""The two bearings-only scenarios of Ristic et al. (2004, ch. 6), as Leong et al. coded them.

``moderate`` and ``high`` (highly nonlinear) from their published MATLAB script, in metres,
with their range intervals as range priors.  Used by ``first_bearing.py``,
``first_bearing_exact.py`` and the tests.

Their filters and their bound start from a different, far more informative prior than
tmakit's range interval and largest speed: :func:`gaussian_prior` (a Gaussian in range about
a draw of the true range, the speed known to 2 kn about a draw of the true speed, the course
the reciprocal of the first bearing, Ristic et al. 2004, sec. 6.2); their bound's ``J_0`` is
its inverse covariance, the prior's exact Fisher information.

References
----------
Ristic, Arulampalam & Gordon (2004), *Beyond the Kalman Filter*, ch. 6; Leong, Arulampalam,
Lamahewa & Abhayapala (2014), IEEE SPL 21(5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tmakit.core.arrays import Array
from tmakit.data import MeasurementSet
from tmakit.filters import BearingPrior, FirstBearing

__all__ = ["KNOT", "Q_DENSITY", "SCENARIOS", "Scenario", "gaussian_prior", "simulate"]

#: The knot as Leong et al. code it (5.14e-4 km/s), m/s.
KNOT = 0.514
#: The target's white-noise acceleration density per axis, m^2/s^3.
Q_DENSITY = 9e-6
#: Sampling interval, s.
STEP = 60.0


@dataclass(frozen=True)
class Scenario:
    """One of the two scenarios; lengths m, angles deg."""

    steps: int  # Samples after the first
    sigma_deg: float  # Bearing noise std
    own_course: tuple[float, float]  # The own ship's course before and after its turn
    turn: tuple[int, int]  # First and last sample of the turn (equal steps of course)
    target: tuple[float, float]  # The target's initial position
    #: speed_kn, course: The target's speed (kn) and course
    speed_kn: float
    course: float
    range_prior: tuple[float, float]  # The range interval of the start (m)
    speed_max_kn: float  # The largest speed of the start (kn)
    after: int  # The first sample after the own ship's turn
    sigma_r: float  # The range std of Leong et al.'s Gaussian prior (m)

    def prior(self) -> BearingPrior:
        """Give the start's prior: the range interval and the largest speed."""
        lo, hi = self.range_prior
        return BearingPrior(lo, hi, self.speed_max_kn * KNOT, given=("range", "speed"))

    def own_ship(self) -> Array:
        """Give the own ship's states."""
        c0, c1 = (math.radians(c) for c in self.own_course)
        a, b = self.turn
        own = np.zeros((self.steps + 1, 4))
        own[0, 2:] = 5 * KNOT * np.array([math.sin(c0), math.cos(c0)])
        course = c0
        for k in range(1, self.steps + 1):
            own[k, :2] = own[k - 1, :2] + STEP * own[k - 1, 2:]
            own[k, 2:] = own[k - 1, 2:]
            if a <= k <= b:
                course += (c1 - c0) / (b - a + 1)
                own[k, 2:] = 5 * KNOT * np.array([math.sin(course), math.cos(course)])
        return own


SCENARIOS = {
    "moderate": Scenario(32, 1.5, (140.0, 20.0), (13, 16), (4920.0, 850.0), 4.0, -140.0,
                         (499.0, 10990.0), 10.0, 17, 2000.0),
    "high": Scenario(30, 2.0, (-80.0, 146.0), (15, 15), (7090.9, 7052.6), 15.0, -135.4,
                     (1000.0, 22010.0), 25.0, 16, 4000.0),
}


def simulate(scenario: Scenario, rng: np.random.Generator, q_density: float = Q_DENSITY
             ) -> tuple[MeasurementSet, Array]:
    """Draw one run: the bearings and the target's true states (``q_density`` m^2/s^3)."""
    steps = scenario.steps
    own = scenario.own_ship()
    c = math.radians(scenario.course)
    tgt = np.zeros((steps + 1, 4))
    tgt[0] = [*scenario.target, scenario.speed_kn * KNOT * math.sin(c),
              scenario.speed_kn * KNOT * math.cos(c)]
    chol = math.sqrt(q_density) * np.linalg.cholesky(np.array([[STEP**3 / 3, STEP**2 / 2],
                                                                 [STEP**2 / 2, STEP]]))
    for k in range(1, steps + 1):
        tgt[k, :2] = tgt[k - 1, :2] + STEP * tgt[k - 1, 2:]
        tgt[k, 2:] = tgt[k - 1, 2:]
        for ax in range(2):
            w = chol @ rng.standard_normal(2)
            tgt[k, ax] += w[0]
            tgt[k, 2 + ax] += w[1]
    sigma = math.radians(scenario.sigma_deg)
    rel = tgt - own
    z = np.arctan2(rel[:, 0], rel[:, 1]) + sigma * rng.standard_normal(steps + 1)
    sensor = np.zeros((steps + 1, 6))
    sensor[:, :2] = own[:, :2]
    sensor[:, 3:5] = own[:, 2:]
    meas = MeasurementSet.from_si(np.arange(steps + 1) * STEP, ["own ship"] * (steps + 1),
                                  ["bearing"] * (steps + 1), z, np.full(steps + 1, sigma),
                                  sensor)
    return meas, tgt


def gaussian_prior(scenario: Scenario, first: FirstBearing, rng: np.random.Generator
                   ) -> tuple[Array, Array]:
    """Give Leong et al.'s prior of one run: the Gaussian their CKF starts from and their bound.

    Range ``r ~ N(r_bar, sigma_r)`` with ``r_bar`` the true initial range plus a
    ``N(0, sigma_r)`` draw (redrawn until above 600 m), speed ``N(s_bar, 2 kn)`` with ``s_bar``
    the true speed plus a ``N(0, 2 kn)`` draw (redrawn until above 0.6 kn), course the first
    bearing's reciprocal with std ``pi / sqrt(12)``; bearing and course moments mapped to
    Cartesian coordinates to first order (Ristic et al. 2004, sec. 6.2).  Gives the mean
    ``(4,)`` and covariance ``(4, 4)`` (m, m/s).
    """
    own0 = scenario.own_ship()[0]
    r_true = math.hypot(scenario.target[0] - own0[0], scenario.target[1] - own0[1])
    s_true, sd_s = scenario.speed_kn * KNOT, 2.0 * KNOT
    sd_r, sd_c, sd_b = scenario.sigma_r, math.pi / math.sqrt(12.0), first.sigma
    r_bar = s_bar = -math.inf
    while r_bar <= 600.0:
        r_bar = r_true + sd_r * rng.standard_normal()
    while s_bar <= 0.6 * KNOT:
        s_bar = s_true + sd_s * rng.standard_normal()
    b, c = first.bearing, first.bearing + math.pi
    mean = np.array([own0[0] + r_bar * math.sin(b), own0[1] + r_bar * math.cos(b),
                     s_bar * math.sin(c), s_bar * math.cos(c)])
    cov = np.zeros((4, 4))
    for i, (along, across, angle) in enumerate(((sd_r, r_bar * sd_b, b),
                                                (sd_s, s_bar * sd_c, c))):
        u = np.array([math.sin(angle), math.cos(angle)])  # along the bearing or course
        e = np.array([math.cos(angle), -math.sin(angle)])
        cov[2 * i:2 * i + 2, 2 * i:2 * i + 2] = along**2 * np.outer(u, u) \
            + across**2 * np.outer(e, e)
    return mean, cov
