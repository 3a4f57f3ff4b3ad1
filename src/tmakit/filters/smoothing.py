"""Smoothers: every state of a track conditioned on the data after it too.

:func:`smooth` runs the Rauch-Tung-Striebel smoother on a Gaussian track (on a Gaussian sum that
kept its history, each component along its lineage, :mod:`tmakit.filters.sum_smoothing`; on
one that did not, on its moments), or with ``lag=N`` the fixed-lag smoother; on a particle track
that kept its clouds,
forward filtering-backward simulation with the filter's own move as transition density.

References
----------
Rauch, Tung & Striebel (1965); Särkkä (2013), *Bayesian Filtering and Smoothing*, Theorem 8.2
and §9; Godsill, Doucet & West (2004), "Monte Carlo smoothing for nonlinear time series", JASA
99(465), Algorithm 1.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from .gaussian_sum import SumStep
from .sum_smoothing import smooth_sum
from .track import Track

__all__ = ["smooth"]


def _dynamics_of(track: Track) -> NearlyConstantVelocity:
    dim = len(track.state_names) // 2
    q = tuple(track.extra.q) if track.extra.q else 0.0
    qd = tuple(track.extra.q_density) if track.extra.q_density else 0.0
    return NearlyConstantVelocity(dim, q, qd)


def _backward(times: Array, states: Array, covs: Array, dynamics: NearlyConstantVelocity,
              start: int, stop: int) -> tuple[Array, Array]:
    """Run the RTS pass from update ``stop`` (its filtered state) back to ``start``."""
    xs, ps = states[stop].copy(), covs[stop].copy()
    out_x = np.empty((stop - start + 1, states.shape[1]))
    out_p = np.empty((stop - start + 1, states.shape[1], states.shape[1]))
    out_x[-1], out_p[-1] = xs, ps
    for k in range(stop - 1, start - 1, -1):
        dt = float(times[k + 1] - times[k])
        phi = dynamics.transition(dt)
        x, p = states[k], covs[k]
        pred = phi @ p @ phi.T + dynamics.noise(dt)
        pred = 0.5 * (pred + pred.T)
        # C = P Phi^T pred^-1, by a solve with the symmetric pred (pseudo-inverse if singular)
        try:
            gain = np.linalg.solve(pred, phi @ p).T
        except np.linalg.LinAlgError:
            gain = (np.linalg.pinv(pred) @ phi @ p).T
        xs = x + gain @ (xs - phi @ x)
        ps = p + gain @ (ps - pred) @ gain.T
        ps = 0.5 * (ps + ps.T)
        out_x[k - start], out_p[k - start] = xs, ps
    return out_x, out_p


def _history_of(track: Track) -> list | None:
    """Give the particle clouds aligned with the track's rows (None: not a particle track)."""
    history = track.extra.history
    if history is None:
        return None
    if len(history) == len(track) + 1:  # the cloud at the prior's time has no row
        history = history[1:]
    if len(history) != len(track) or not np.allclose([h.time for h in history], track.times):
        raise ValueError("the filter's kept history (particle clouds or Gaussian sums) does not "
                         "match the track's rows (an update was skipped); it cannot be smoothed")
    return list(history)


def _backward_simulation(history: list, dynamics: NearlyConstantVelocity, trajectories: int,
                         rng: np.random.Generator) -> tuple[Array, Array]:
    """Draw paths backwards through the clouds (FFBSi); give their means and covariances."""
    k_all = len(history)
    n = history[0].particles.shape[0]
    paths = np.empty((k_all, trajectories, n))

    def draw(logw: Array) -> Array:
        p = np.exp(logw - logw.max(axis=-1, keepdims=True))
        cum = np.cumsum(p, axis=-1)
        u = rng.random(cum.shape[:-1]) * cum[..., -1]
        return np.minimum((cum < u[..., None]).sum(axis=-1), cum.shape[-1] - 1)

    last = history[-1]
    with np.errstate(divide="ignore"):
        idx = draw(np.log(last.weights)[None, :])[0] if trajectories == 1 else draw(
            np.broadcast_to(np.log(last.weights), (trajectories, last.weights.size)))
    paths[-1] = last.particles[:, idx].T
    for k in range(k_all - 2, -1, -1):
        step = history[k]
        dt = float(history[k + 1].time - step.time)
        phi = dynamics.transition(dt)
        x = step.particles
        if step.centre is not None:
            x = step.shrink * x + ((1.0 - step.shrink) * step.centre)[:, None]
        cov = dynamics.noise(dt) + (0.0 if step.jitter is None
                                    else phi @ step.jitter @ phi.T)
        cov = 0.5 * (cov + cov.T) + 1e-6 * np.eye(n)  # a deterministic move stays drawable
        chol = np.linalg.cholesky(cov)
        a = np.linalg.solve(chol, phi @ x).T           # (N, n) whitened predicted particles
        b = np.linalg.solve(chol, paths[k + 1].T).T    # (M, n) whitened path states
        d2 = (b * b).sum(axis=1)[:, None] + (a * a).sum(axis=1)[None, :] - 2.0 * b @ a.T
        with np.errstate(divide="ignore"):
            logw = np.log(step.weights)[None, :] - 0.5 * d2
        paths[k] = x[:, draw(logw)].T if step.centre is None else \
            step.particles[:, draw(logw)].T
    means = paths.mean(axis=1)
    dev = paths - means[:, None, :]
    covs = np.einsum("kmi,kmj->kij", dev, dev) / max(trajectories - 1, 1)
    return means, covs


def smooth(track: Track, *, lag: int | None = None,
           dynamics: NearlyConstantVelocity | None = None, trajectories: int = 200,
           rng: np.random.Generator | int | None = 0) -> Track:
    """Smooth a Gaussian track (RTS; fixed-lag with ``lag``).

    Parameters
    ----------
    track : Track
        A track of a Gaussian filter, of a Gaussian sum (that kept its history: smoothed per
        component; otherwise on its moments) or of a particle filter that kept its clouds.
    lag : int, optional
        Fixed lag N >= 0 (updates); default the whole track (fixed-interval RTS).
    dynamics : NearlyConstantVelocity, optional
        The filter's dynamics; default from the track's ``extra`` (``q``, ``q_density``).
    trajectories : int, optional
        Paths drawn by the particle smoother (>= 2).
    rng : numpy.random.Generator or int, optional
        Their random source or seed (particle smoother only).

    Returns
    -------
    Track
        The smoothed states and covariances (the rest as filtered); ``extra.options["smoother"]``
        says which; for a Gaussian sum's history, ``extra.history`` holds the smoothed sum per
        row (:class:`~tmakit.filters.gaussian_sum.SumStep`).

    Raises
    ------
    ValueError
        A negative lag, a lag for a particle track, clouds that do not match the rows, or an IMM
        filter's track.
    """
    if lag is not None and (isinstance(lag, bool) or int(lag) != lag or lag < 0):
        raise ValueError(f"lag must be a whole number of updates >= 0; got {lag!r}")
    if track.extra.model_probabilities is not None:
        raise ValueError("no smoother for the IMM filter's track: its combined estimate is "
                         "not one Gaussian model's (the IMM smoother is not built)")
    dyn = _dynamics_of(track) if dynamics is None else dynamics
    times, states, covs = track.times, track.states, track.covariances
    n = len(track)
    if n == 0:
        return track
    history = _history_of(track)
    sums = None
    if history is not None and isinstance(history[0], SumStep):
        xs, ps, sums = smooth_sum(history, dyn, lag)
        label = "gaussian-sum " + ("rts" if lag is None else f"fixed-lag {int(lag)}")
    elif history is not None:
        if lag is not None:
            raise ValueError("the particle smoother is fixed-interval; lag applies to the "
                             "Gaussian filters")
        if trajectories < 2:
            raise ValueError(f"trajectories must be >= 2; got {trajectories}")
        xs, ps = _backward_simulation(history, dyn, int(trajectories),
                                      np.random.default_rng(rng))
        label = f"ffbsi {int(trajectories)}"
    elif lag is None:
        xs, ps = _backward(times, states, covs, dyn, 0, n - 1)
        label = "rts"
    else:
        xs, ps = np.empty_like(states), np.empty_like(covs)
        for k in range(n):
            x, p = _backward(times, states, covs, dyn, k, min(k + int(lag), n - 1))
            xs[k], ps[k] = x[0], p[0]
        label = f"fixed-lag {int(lag)}"
    extra = replace(track.extra, smoothed=None, history=sums,
                    options={**track.extra.options, "smoother": label})
    return Track(track.filter_name, track.state_names, times.copy(), xs, ps, track.nis.copy(),
                 track.dof.copy(), track.log_likelihood.copy(), extra)
