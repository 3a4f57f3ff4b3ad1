"""The posterior CRB of a Monte Carlo of runs: ``Gamma_k`` averaged over the runs' true states.

Each run of a closed-loop study (:mod:`tmakit.planning.closed_loop`) records, at every update
``k``, the Fisher information ``Xi(x_k, s_k)`` of its measurements at the run's *true* target
state ``x_k`` and its flown sensor state ``s_k``.  The posterior CRB of Tichavský, Muravchik &
Nehorai (1998) (Hurtado & Nehorai (2008), eqs. 10-11) is the recursion

    J_0 = P_0^{-1},    J_{k+1} = (Q + F J_k^{-1} F^T)^{-1} + Gamma_{k+1},
    Gamma_{k+1} = E[ Xi(x_{k+1}, s_{k+1}) ],

with the expectation over the joint distribution of the truth, the noise and — for a path
steered by the measurements — the sensor states.  Steering does not change the recursion: the
sensor state ``s_k`` is a function of the measurements before ``k`` only, so the log-likelihood
of the ``k``-th measurement is differentiated with ``s_k`` held, and its expected Hessian is
still ``E[Xi(x_k, s_k)]``.  The mean over ``R`` runs estimates it; ``J_k^{-1}`` then bounds
the mean-square error matrix of any tracker that uses the same prior ``P_0``, process noise
``Q`` and measurement model as the bound, averaged over the runs.

The Monte Carlo uncertainty of a RMSE held to this bound: :func:`ratio_interval`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from .pcrb_recursion import PosteriorInformation

__all__ = ["pcrb_over_runs", "ratio_interval"]


def pcrb_over_runs(information: ArrayLike, times: ArrayLike, prior_cov: ArrayLike,
                   dynamics: NearlyConstantVelocity, time0: float) -> Array:
    """Return the posterior CRB after each update, ``Gamma`` the mean over the runs.

    Parameters
    ----------
    information : array_like, shape (R, D, n, n)
        ``Xi`` of run ``r``'s measurements at update ``k``, at its true target state and its
        sensor state, SI.
    times : array_like, shape (D,)
        The update times, s (increasing, not before ``time0``).
    prior_cov : array_like, shape (n, n)
        ``P_0``, the trackers' prior covariance at ``time0``, SI.
    dynamics : NearlyConstantVelocity
        The target dynamics (``Q``) the trackers assume and the truth follows.
    time0 : float
        The prior's time, s.

    Returns
    -------
    ndarray, shape (D, n, n)
        ``J_k^{-1}``, the bound on the mean-square error matrix after each update, SI.

    Raises
    ------
    ValueError
        If the shapes do not agree.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998); Hurtado & Nehorai (2008), eqs. 10-11.
    """
    xi = np.asarray(information, dtype=float)
    t = np.asarray(times, dtype=float)
    n = 2 * dynamics.dim
    if xi.ndim != 4 or xi.shape[1:] != (t.shape[0], n, n):
        raise ValueError(f"information must be (runs, {t.shape[0]}, {n}, {n}) for "
                         f"{t.shape[0]} update times; got {xi.shape}")
    gamma = xi.mean(axis=0)
    post = PosteriorInformation.from_prior(prior_cov, dynamics, time0)
    out = np.empty((t.shape[0], n, n))
    for k in range(t.shape[0]):
        post = post.predict_to(t[k]).update(gamma[k])
        out[k] = post.covariance
    return out


def ratio_interval(errors: ArrayLike, bound: ArrayLike, level: float = 0.95
                   ) -> tuple[float, float, float]:
    """Return the RMSE over the bound and its interval, from the runs' final errors.

    If the errors of the ``R`` runs were Gaussian with a covariance shaped as the bound's
    ``P`` (an efficient tracker), their summed squares would be ``c chi^2_m`` with
    ``c = tr(P^2) / tr P`` and ``m = R (tr P)^2 / tr(P^2)`` degrees of freedom
    (Satterthwaite's approximation: ``m = 2 R`` for a round 2-D error, ``R`` for a thin one).
    The interval inverts that: a ratio whose interval lies below 1 is below the bound beyond
    the Monte Carlo uncertainty.  It holds for few runs, where a bootstrap over the runs
    does not (ten runs that happen to have no large error look precise to a bootstrap).

    Parameters
    ----------
    errors : array_like, shape (R,)
        Each run's position error (m).
    bound : array_like, shape (d, d)
        The bound's position block, m^2.
    level : float, optional
        The interval's coverage.

    Returns
    -------
    ratio, low, high : float
        ``RMSE / sqrt(tr P)`` and its interval.
    """
    from scipy.stats import chi2

    e = np.asarray(errors, dtype=float)
    p = np.asarray(bound, dtype=float)
    tr = float(np.trace(p))
    m = e.size * tr**2 / float(np.sum(p * p.T))
    ratio = float(np.sqrt(np.mean(e**2) / tr))
    hi_q, lo_q = chi2.ppf([(1 + level) / 2, (1 - level) / 2], m)
    return ratio, ratio * float(np.sqrt(m / hi_q)), ratio * float(np.sqrt(m / lo_q))
