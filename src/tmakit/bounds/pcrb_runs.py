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

``weights`` gives several recursions at once, each with its own mean over the runs (rows of
bootstrap resampling weights: the Monte Carlo uncertainty of the bound, resampled together
with the errors of the same runs).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from .pcrb_recursion import PosteriorInformation

__all__ = ["pcrb_over_runs"]


def pcrb_over_runs(information: ArrayLike, times: ArrayLike, prior_cov: ArrayLike,
                   dynamics: NearlyConstantVelocity, time0: float,
                   weights: ArrayLike | None = None) -> Array:
    """Return the position RMS posterior CRB after each update, ``Gamma`` the mean over runs.

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
    weights : array_like, shape (B, R), optional
        Rows of weights over the runs (each summing to 1): one recursion per row.  Default:
        one recursion with equal weights.

    Returns
    -------
    ndarray, shape (D,) or (B, D)
        ``sqrt(trace)`` of the position block of ``J_k^{-1}``, m.

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
    one = weights is None
    w = np.full((1, xi.shape[0]), 1.0 / xi.shape[0]) if one else np.asarray(weights, float)
    if w.ndim != 2 or w.shape[1] != xi.shape[0]:
        raise ValueError(f"weights must be (B, {xi.shape[0]}); got {w.shape}")
    post = PosteriorInformation.from_prior(prior_cov, dynamics, time0)
    post = PosteriorInformation(np.broadcast_to(post.information, (w.shape[0], n, n)),
                                dynamics, time0)
    out = np.empty((w.shape[0], t.shape[0]))
    for k in range(t.shape[0]):
        post = post.predict_to(t[k]).update(np.einsum("br,rij->bij", w, xi[:, k]))
        out[:, k] = post.position_rms
    return out[0] if one else out
