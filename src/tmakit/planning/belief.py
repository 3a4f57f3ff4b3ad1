"""What the planner knows at a decision: the bound so far and the tracker's target cloud.

``J_k`` along the path flown (Hurtado & Nehorai (2008), eq. 10) with the tracker's particles,
the sigma points of its Gaussian, or its mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..bounds.pcrb_recursion import PosteriorInformation
from ..core.arrays import Array
from ..core.linalg import safe_cholesky
from ..filters.base import TrackingFilter


def cubature_points(mean: ArrayLike, covariance: ArrayLike) -> tuple[Array, Array]:
    """Return the ``2 n`` equally weighted cubature points of a Gaussian (no negative weight)."""
    m = np.asarray(mean, dtype=float)
    n = m.shape[0]
    spread = np.sqrt(n) * safe_cholesky(np.asarray(covariance, dtype=float)).T  # rows L e_j
    points = np.concatenate([m + spread, m - spread])
    return points, np.full(2 * n, 1.0 / (2 * n))


@dataclass(frozen=True, eq=False)
class Belief:
    """The bound so far and the target cloud, at one time.

    Parameters
    ----------
    posterior : PosteriorInformation
        ``J_k`` (n, n) at the decision time (its ``time``).
    states : array_like, shape (N, n)
        Target states at the same time (particles, sigma points, or the mean as (1, n)).
    weights : array_like, shape (N,), optional
        Normalised weights (default equal).

    Raises
    ------
    ValueError
        If the states do not have ``n`` components, or the weights do not match or do not sum to 1.
    """

    posterior: PosteriorInformation
    states: Array
    weights: Array

    def __init__(self, posterior: PosteriorInformation, states: ArrayLike,
                 weights: ArrayLike | None = None) -> None:
        x = np.atleast_2d(np.asarray(states, dtype=float))
        n = 2 * posterior.dim
        if x.ndim != 2 or x.shape[1] != n or not np.all(np.isfinite(x)):
            raise ValueError(f"belief states must be finite (N, {n}); got shape {x.shape}")
        if weights is None:
            w = np.full(x.shape[0], 1.0 / x.shape[0])
        else:
            w = np.asarray(weights, dtype=float)
            if w.shape != (x.shape[0],) or np.any(w < 0) or abs(w.sum() - 1.0) > 1e-9:
                raise ValueError(f"belief weights must be ({x.shape[0]},), >= 0 and sum "
                                 "to 1")
        object.__setattr__(self, "posterior", posterior)
        object.__setattr__(self, "states", x)
        object.__setattr__(self, "weights", w)

    @classmethod
    def from_filter(cls, tracker: TrackingFilter, posterior: PosteriorInformation,
                    cloud: str = "auto") -> Belief:
        """Take the cloud from a tracker.

        Parameters
        ----------
        tracker : TrackingFilter
            After its update at ``posterior.time``.
        posterior : PosteriorInformation
            ``J_k`` at the same time.
        cloud : {"auto", "particles", "sigma", "mean"}, optional
            ``"auto"``: the particles of a particle filter, else the cubature points of
            the tracker's Gaussian; ``"mean"``: the estimate alone.

        Returns
        -------
        Belief

        Raises
        ------
        ValueError
            For an unknown ``cloud``, or ``"particles"`` from a filter without particles.
        """
        if cloud not in ("auto", "particles", "sigma", "mean"):
            raise ValueError(f"cloud must be 'auto', 'particles', 'sigma' or 'mean'; got "
                             f"{cloud!r}")
        has_particles = hasattr(tracker, "particles") and hasattr(tracker, "weights")
        if cloud == "particles" and not has_particles:
            raise ValueError(f"the {tracker.name} filter has no particles")
        if cloud in ("auto", "particles") and has_particles:
            return cls(posterior, tracker.particles, tracker.weights)  # type: ignore[attr-defined]
        if cloud == "mean":
            return cls(posterior, tracker.state)
        return cls(posterior, *cubature_points(tracker.state, tracker.covariance))

    @property
    def time(self) -> float:
        """The time of the belief, s."""
        return self.posterior.time

    @property
    def mean(self) -> Array:
        """The weighted mean target state (n,), SI."""
        return self.weights @ self.states
