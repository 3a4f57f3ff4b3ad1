"""The posterior CRB of a Monte Carlo of runs: ``Gamma_k`` averaged over the runs' true states.

The recursion of Tichavský, Muravchik & Nehorai (1998) (Hurtado & Nehorai (2008), eqs. 10-11)
with ``Gamma_k`` the mean over runs of the Fisher information at each run's true state and
flown sensor state; a path steered by past measurements does not change it.
:func:`ratio_interval` gives the Monte Carlo uncertainty of a RMSE held to it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from .pcrb_recursion import PosteriorInformation

__all__ = ["MIN_RUNS", "pcrb_over_runs", "ratio_interval"]


def pcrb_over_runs(information: ArrayLike, times: ArrayLike, prior_cov: ArrayLike,
                   dynamics: NearlyConstantVelocity, time0: float) -> Array:
    """Return the posterior CRB ``J_k^{-1}`` (D, n, n), SI, per update, ``Gamma`` the runs' mean.

    Parameters
    ----------
    information : array_like, shape (R, D, n, n)
        ``Xi`` of run ``r`` at update ``k``, at its true target and sensor states, SI.
    times : array_like, shape (D,)
        s, increasing, not before ``time0``.
    prior_cov : array_like, shape (n, n)
        ``P_0`` at ``time0``, SI.
    dynamics : NearlyConstantVelocity
    time0 : float
        s.

    Returns
    -------
    ndarray

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


#: Fewest runs for an interval of RMSE over the bound (a few runs of a heavy-tailed error
#: say nothing about its tail).
MIN_RUNS = 10
#: Bootstrap resamples of the runs.
RESAMPLES = 2000


def ratio_interval(errors: ArrayLike, bound: ArrayLike, level: float = 0.95,
                   seed: int = 0) -> tuple[float, float | None, float | None]:
    """Return the RMSE over the bound and its Monte Carlo interval, from the runs' errors."""
    from ..core import chi2

    e2 = np.asarray(errors, dtype=float) ** 2
    p = np.asarray(bound, dtype=float)
    tr = float(np.trace(p))
    r = e2.size
    ratio = float(np.sqrt(e2.mean() / tr))
    if r < MIN_RUNS:
        return ratio, None, None
    m = r * tr**2 / float(np.sum(p * p.T))
    hi_q, lo_q = chi2.ppf([(1 + level) / 2, (1 - level) / 2], m)
    rng = np.random.default_rng([seed, r])
    boot = np.sqrt(rng.multinomial(r, np.full(r, 1.0 / r), size=RESAMPLES) @ e2 / (r * tr))
    b_lo, b_hi = np.quantile(boot, [(1 - level) / 2, (1 + level) / 2])
    return (ratio, min(ratio * float(np.sqrt(m / hi_q)), float(b_lo)),
            max(ratio * float(np.sqrt(m / lo_q)), float(b_hi)))
