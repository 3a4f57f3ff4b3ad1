"""Smoothers: every state of a track conditioned on the data after it too.

:func:`smooth` runs the Rauch-Tung-Striebel smoother on a Gaussian track, or with ``lag=N`` the
fixed-lag smoother; on a Gaussian sum that kept its history, the same along each final
component's lineage (docs/tracking.md, "Smoothers": given its hypothesis a component is
linear-Gaussian, and its final weight is the hypothesis' probability, Alspach & Sorenson 1972,
eq. 20); on a particle track that kept its clouds, forward filtering-backward simulation with the
filter's own move as transition density (the model index part of the state for the
multiple-model particle filter); on an IMM track, a backward IMM filter fused with the forward
one (:func:`tmakit.filters.imm.imm_smooth`).

References
----------
Rauch, Tung & Striebel (1965); Särkkä (2013), *Bayesian Filtering and Smoothing*, Theorem 8.2
and §9; Alspach & Sorenson (1972), IEEE Trans. Autom. Control 17(4); Godsill, Doucet & West
(2004), "Monte Carlo smoothing for nonlinear time series", JASA 99(465), Algorithm 1; Helmick,
Blair & Hoffman (1995), IEEE Trans. Inf. Theory 41(6); the two-filter Gaussian-sum smoother of
Kitagawa (1994), Ann. Inst. Statist. Math. 46(4), is the alternative not taken (docs/tracking.md).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import replace
from typing import cast

import numpy as np

from ..core.arrays import Array, IntArray
from ..motion.dynamics import NearlyConstantVelocity
from .base import whole_number
from .gaussian_sum import SumStep, mixture_moments
from .general import DynamicsCache
from .imm import ModelHistory, imm_smooth, models_of
from .track import Track

__all__ = ["smooth"]


def _dynamics_of(track: Track) -> NearlyConstantVelocity:
    dim = len(track.state_names) // 2
    q = tuple(track.extra.q) if track.extra.q else 0.0
    qd = tuple(track.extra.q_density) if track.extra.q_density else 0.0
    return NearlyConstantVelocity(dim, q, qd)


def _lineage_back(steps: list[SumStep], dynamics: DynamicsCache, start: int,
                  stop: int) -> list[SumStep]:
    """Run the RTS pass on the sum of step ``stop`` back along its lineage to ``start``."""
    last = steps[stop]
    xs, ps = last.means.copy(), last.covariances.copy()
    idx: IntArray = np.arange(last.weights.shape[0])
    out = [SumStep(last.time, last.weights, xs, ps, idx)]
    for k in range(stop - 1, start - 1, -1):
        parent = steps[k + 1].origins[idx]
        if np.any(parent < 0):
            raise ValueError("the Gaussian sum's history has no lineage at step "
                             f"{k + 1}; it cannot be smoothed")
        step = steps[k]
        dt = float(steps[k + 1].time - step.time)
        phi, _, q = dynamics.get(dt)
        m, p = step.means[parent], step.covariances[parent]
        pred = phi @ p @ phi.T + q
        pred = 0.5 * (pred + np.swapaxes(pred, -1, -2))
        try:  # the gain P Phi^T pred^-1 (pseudo-inverse if pred is singular)
            gain = np.swapaxes(np.linalg.solve(pred, phi @ p), -1, -2)
        except np.linalg.LinAlgError:
            gain = np.swapaxes(np.linalg.pinv(pred) @ phi @ p, -1, -2)
        xs = m + np.einsum("cij,cj->ci", gain, xs - m @ phi.T)
        ps = p + gain @ (ps - pred) @ np.swapaxes(gain, -1, -2)
        ps = 0.5 * (ps + np.swapaxes(ps, -1, -2))
        idx = parent
        out.append(SumStep(step.time, last.weights, xs, ps, parent))
    return out[::-1]


def smooth_sum(steps: list[SumStep], dynamics: NearlyConstantVelocity,
               lag: int | None = None) -> tuple[Array, Array, list[SumStep]]:
    """Smooth a Gaussian sum's history (fixed-lag with ``lag``): moments and sums per step."""
    k_all, cache = len(steps), DynamicsCache(dynamics)
    if lag is None or lag >= k_all - 1:
        sums = _lineage_back(steps, cache, 0, k_all - 1)
    else:
        sums = [_lineage_back(steps, cache, k, min(k + int(lag), k_all - 1))[0]
                for k in range(k_all)]
    moments = [mixture_moments(s.weights, s.means, s.covariances) for s in sums]
    return (np.array([m for m, _ in moments]), np.array([p for _, p in moments]), sums)


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


def _backward_simulation(history: list, models: list[NearlyConstantVelocity],
                         trajectories: int, rng: np.random.Generator
                         ) -> tuple[Array, Array, Array | None]:
    """Draw paths backwards through the clouds (FFBSi); give their moments and model shares.

    A multiple-model filter's ``labels`` make the model part of the state (docs/tracking.md).
    """
    k_all = len(history)
    n = history[0].particles.shape[0]
    paths = np.empty((k_all, trajectories, n))
    labelled = getattr(history[-1], "labels", None) is not None
    path_models = np.zeros((k_all, trajectories), dtype=np.int64)
    draw = _compiled_draw()
    factors: dict[tuple[int, float], tuple[Array, Array]] = {}

    def whiten(j: int, dt: float, jitter: Array | None) -> tuple[Array, Array]:
        """Give ``L^-1 Phi_j`` and ``L^-1``, ``L`` the Cholesky factor of model j's move."""
        if jitter is None and (j, dt) in factors:
            return factors[j, dt]
        phi = models[j].transition(dt)
        cov = models[j].noise(dt) + (0.0 if jitter is None else phi @ jitter @ phi.T)
        cov = 0.5 * (cov + cov.T) + 1e-6 * np.eye(n)  # a deterministic move stays drawable
        inverse = np.linalg.inv(np.linalg.cholesky(cov))
        out = (inverse @ phi, inverse)
        if jitter is None:
            factors[j, dt] = out
        return out

    last = history[-1]
    cum = np.cumsum(last.weights)
    idx = np.minimum(np.searchsorted(cum, rng.random(trajectories) * cum[-1]), cum.size - 1)
    paths[-1] = last.particles[:, idx].T
    if labelled:
        path_models[-1] = last.labels[idx]
    for k in range(k_all - 2, -1, -1):
        step = history[k]
        dt = float(history[k + 1].time - step.time)
        x = step.particles
        if step.centre is not None:
            x = step.shrink * x + ((1.0 - step.shrink) * step.centre)[:, None]
        u = rng.random(trajectories)
        pick = np.empty(trajectories, dtype=np.int64)
        with np.errstate(divide="ignore"):
            log_w = np.log(step.weights)
            log_p = np.log(history[k + 1].transition) if labelled else None
        for j in np.unique(path_models[k + 1]):
            to_j = np.flatnonzero(path_models[k + 1] == j)
            move, inverse = whiten(int(j), dt, step.jitter)
            a = move @ x                              # (n, N) whitened predicted particles
            b = paths[k + 1, to_j] @ inverse.T        # (M_j, n) whitened path states
            prior = log_w if log_p is None else log_w + log_p[step.labels, j]
            chosen = np.empty(to_j.size, dtype=np.int64)
            draw(a, prior, b, u[to_j], chosen)
            pick[to_j] = chosen
        paths[k] = x[:, pick].T if step.centre is None else step.particles[:, pick].T
        if labelled:
            path_models[k] = step.labels[pick]
    means = paths.mean(axis=1)
    dev = paths - means[:, None, :]
    covs = np.einsum("kmi,kmj->kij", dev, dev) / max(trajectories - 1, 1)
    shares = None if not labelled else np.stack(
        [np.bincount(row, minlength=len(models)) / trajectories for row in path_models])
    return means, covs, shares


#: A particle whose log backward weight is this far below a path's best adds less than
#: e^-60 = 1e-26 of the best to the sum: below double precision, so it is not exponentiated.
_NEGLIGIBLE = 60.0


def _draw_predecessors(a: Array, prior: Array, b: Array, u: Array,
                       out: IntArray) -> None:  # pragma: no cover - compiled
    """Draw into ``out[m]`` path ``b[m]``'s predecessor, by its cumulative weights at ``u[m]``.

    Particle ``i`` has the weight ``exp(prior_i - |a_i - b_m|^2 / 2)`` (whitened ``a``, ``b``).
    """
    dim, n_p = a.shape
    score = np.empty(n_p)
    for m in range(b.shape[0]):
        for i in range(n_p):  # (element by element: no array assignment's shape check to compile)
            score[i] = prior[i]
        for c in range(dim):
            bc = b[m, c]
            for i in range(n_p):
                e = a[c, i] - bc
                score[i] -= 0.5 * e * e
        top = score.max()
        if top == -np.inf:  # no particle can move there: the weights alone
            for i in range(n_p):
                score[i] = prior[i]
            top = score.max()
        total = 0.0
        for i in range(n_p):
            if score[i] > top - _NEGLIGIBLE:
                total += math.exp(score[i] - top)
            score[i] = total
        target = u[m] * total
        pick = n_p - 1
        for i in range(n_p):
            if score[i] >= target and score[i] > 0.0:
                pick = i
                break
        out[m] = pick


@functools.cache
def _compiled_draw() -> Callable[..., None]:
    """Give :func:`_draw_predecessors` compiled (numba is imported at the first use)."""
    import numba

    return cast(Callable[..., None],
                numba.njit(cache=True, nogil=True, error_model="numpy")(_draw_predecessors))


def smooth(track: Track, *, lag: int | None = None,
           dynamics: NearlyConstantVelocity | None = None, trajectories: int = 200,
           rng: np.random.Generator | int | None = 0) -> Track:
    """Smooth a track: RTS (fixed-lag with ``lag``), the IMM's, or backward simulation.

    Parameters
    ----------
    track : Track
        A track of a Gaussian filter, of a Gaussian sum (that kept its history: smoothed per
        component; otherwise on its moments), of the IMM filter or of a particle filter (``pf``,
        ``mmpf``) that kept its history.
    lag : int, optional
        Fixed lag N >= 0 (updates), for the Gaussian filters; default the whole track
        (fixed-interval).
    dynamics : NearlyConstantVelocity, optional
        The filter's dynamics; default from the track's ``extra`` (``q``, ``q_density``; a
        multiple-model track's ``models``).
    trajectories : int, optional
        Paths drawn by the particle smoother (>= 2).
    rng : numpy.random.Generator or int, optional
        Their random source or seed (particle smoother only).

    Returns
    -------
    Track
        The smoothed states and covariances (the rest as filtered); ``extra.options["smoother"]``
        says which; a multiple-model track's smoothed model probabilities in
        ``extra.model_probabilities``; for a Gaussian sum's history, ``extra.history`` holds the
        smoothed sum per row (:class:`~tmakit.filters.gaussian_sum.SumStep`).

    Raises
    ------
    ValueError
        A negative lag, a lag for a particle or IMM track, clouds or model states that do not
        match the rows, or a multiple-model particle track without its clouds.

    References
    ----------
    The IMM's: Helmick, Blair & Hoffman (1995), :func:`~tmakit.filters.imm.imm_smooth`.
    """
    lag = None if lag is None else whole_number(lag, "lag", 0, " of updates")
    if len(track) == 0:
        return track
    multiple = track.extra.model_probabilities is not None
    probabilities = sums = None
    imm = isinstance(track.extra.history, ModelHistory)
    history = None if imm else _history_of(track)
    summed = history is not None and isinstance(history[0], SumStep)
    if lag is not None and (imm or (history is not None and not summed)):
        raise ValueError(f"the {'IMM' if imm else 'particle'} smoother is fixed-interval; lag "
                         "applies to the Gaussian filters (ekf, ukf, ckf, gsf)")
    dynamics = _dynamics_of(track) if dynamics is None else dynamics
    if imm:
        xs, ps, probabilities = imm_smooth(track)
        label = "imm two-filter"
    elif history is not None and not summed:
        if trajectories < 2:
            raise ValueError(f"trajectories must be >= 2; got {trajectories}")
        models = models_of(track) if multiple else [dynamics]
        xs, ps, probabilities = _backward_simulation(history, models, int(trajectories),
                                                     np.random.default_rng(rng))
        label = f"ffbsi {int(trajectories)}"
    elif multiple:
        raise ValueError(f"the {track.filter_name} filter's track kept no history: run it "
                         "with history=True (settings={'history': True}) to smooth it")
    else:  # RTS along each lineage of a sum's history, or of the track as a one-term sum
        one, zero = np.ones(1), np.zeros(1, dtype=np.int64)
        steps = history if history is not None else [
            SumStep(float(t), one, x[None], p[None], zero)
            for t, x, p in zip(track.times, track.states, track.covariances, strict=True)]
        xs, ps, kept = smooth_sum(steps, dynamics, lag)
        sums = kept if summed else None
        label = ("gaussian-sum " if summed else "") + (
            "rts" if lag is None else f"fixed-lag {int(lag)}")
    extra = replace(track.extra, smoothed=None, history=sums,
                    options={**track.extra.options, "smoother": label},
                    model_probabilities=None if probabilities is None
                    else probabilities.tolist())
    return Track(track.filter_name, track.state_names, track.times.copy(), xs, ps,
                 track.nis.copy(), track.dof.copy(), track.log_likelihood.copy(), extra)
