"""The Gaussian-sum smoother: each component smoothed along its own lineage.

A Gaussian-sum filter is a bank of hypotheses ``h`` (a range sub-interval of the prior, then
one side of each split): given ``h`` the model is linear-Gaussian, so

    p(x_k | y_1:K) = sum_h P(h | y_1:K) p(x_k | h, y_1:K),

with ``P(h | y_1:K)`` the filter's final weight of the component that carries ``h`` (the
weights' recursion of Alspach & Sorenson 1972, eq. 20, is Bayes' rule over the hypotheses)
and ``p(x_k | h, y_1:K)`` the Rauch-Tung-Striebel smoother along the filtered moments of
``h``'s ancestors (Särkkä 2013, Theorem 8.2):

    G_k = P_k Phi^T (Phi P_k Phi^T + Q)^-1
    m_k^s = m_k + G_k (m_{k+1}^s - Phi m_k)
    P_k^s = P_k + G_k (P_{k+1}^s - Phi P_k Phi^T - Q) G_k^T

where ``m_k, P_k`` are the filtered moments of the ancestor at step ``k``.  The lineage is the
filter's own (:class:`~tmakit.filters.gaussian_sum.SumStep`): a split component's children
descend from it (the split changes the predicted marginal, not the transition, so the
ancestor's gain is exact); a pruned component has no descendants (its weight was below the
filter's threshold); a merged component descends from its heaviest member (the others' pasts
are dropped: the approximation of the merge, made again backwards).  The backward pass is
vectorised over the final components; the smoothed sum at step ``k`` has as many components
as the final sum, with its weights.

References
----------
Alspach & Sorenson (1972), IEEE Trans. Autom. Control 17(4); Rauch, Tung & Striebel (1965);
Särkkä (2013), *Bayesian Filtering and Smoothing*, Theorem 8.2; the two-filter Gaussian-sum
smoother of Kitagawa (1994), Ann. Inst. Statist. Math. 46(4), is the alternative not taken
(docs/tracking.md says why).
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import Array, IntArray
from ..motion.dynamics import NearlyConstantVelocity
from .gaussian_sum import SumStep, mixture_moments

__all__ = ["smooth_sum"]


def _lineage_back(steps: list[SumStep], dynamics: NearlyConstantVelocity, start: int,
                  stop: int) -> list[SumStep]:
    """Smooth the sum of step ``stop`` back along its lineage to ``start`` (inclusive)."""
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
        phi, q = dynamics.transition(dt), dynamics.noise(dt)
        m, p = step.means[parent], step.covariances[parent]
        pred = phi @ p @ phi.T + q
        pred = 0.5 * (pred + np.swapaxes(pred, -1, -2))
        gain = np.swapaxes(np.linalg.solve(pred, phi @ p), -1, -2)  # P Phi^T pred^-1
        xs = m + np.einsum("cij,cj->ci", gain, xs - m @ phi.T)
        ps = p + gain @ (ps - pred) @ np.swapaxes(gain, -1, -2)
        ps = 0.5 * (ps + np.swapaxes(ps, -1, -2))
        idx = parent
        out.append(SumStep(step.time, last.weights, xs, ps, parent))
    return out[::-1]


def smooth_sum(steps: list[SumStep], dynamics: NearlyConstantVelocity,
               lag: int | None = None) -> tuple[Array, Array, list[SumStep]]:
    """Smooth a Gaussian sum's history, each final component along its lineage.

    Parameters
    ----------
    steps : list of SumStep
        The filter's sum after each update (``GaussianSumFilter(history=True)``).
    dynamics : NearlyConstantVelocity
        The filter's dynamics.
    lag : int, optional
        Fixed lag N >= 0 (updates): step k smoothed from the sum of step k + N; default the
        whole history.

    Returns
    -------
    means : numpy.ndarray
        The smoothed sum's mean per step ``(K, n)`` (m, m/s).
    covariances : numpy.ndarray
        Its covariance ``(K, n, n)``.
    sums : list of SumStep
        The smoothed sum per step (``origins``: the filtered component at that step each
        smoothed component runs through).

    Raises
    ------
    ValueError
        If a step's components have no lineage.
    """
    k_all = len(steps)
    if lag is None or lag >= k_all - 1:
        sums = _lineage_back(steps, dynamics, 0, k_all - 1)
    else:
        sums = [_lineage_back(steps, dynamics, k, min(k + int(lag), k_all - 1))[0]
                for k in range(k_all)]
    moments = [mixture_moments(s.weights, s.means, s.covariances) for s in sums]
    return (np.array([m for m, _ in moments]), np.array([p for _, p in moments]), sums)
