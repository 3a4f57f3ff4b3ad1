"""One planning step from the user's own loop: their tracker and platform in, the next action out.

A caller who carries the bound along the flown path (Hurtado & Nehorai (2008), eq. 10;
:meth:`Planner.advance`) passes it instead.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..bounds.pcrb_recursion import PosteriorInformation
from ..core.linalg import symmetrise
from ..filters.base import TrackingFilter
from ..motion.dynamics import NearlyConstantVelocity
from ..sensors.platform import PlatformState
from .belief import Belief, cubature_points
from .planner import Planner, Recommendation

Estimate = TrackingFilter | tuple[ArrayLike, ArrayLike] | Sequence[ArrayLike]


def _gaussian(track: Estimate) -> tuple[np.ndarray, np.ndarray]:
    try:
        mean, cov = track  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError("recommend() takes a TrackingFilter or a (mean, covariance) "
                         "pair") from None
    m = np.asarray(mean, dtype=float).reshape(-1)
    p = np.asarray(cov, dtype=float)
    n = m.shape[0]
    if n not in (4, 6) or p.shape != (n, n) or not (np.all(np.isfinite(m))
                                                     and np.all(np.isfinite(p))):
        raise ValueError(f"the estimate must be a finite mean [x, y, (z,) vx, vy, (vz)] (4 or "
                         f"6 values) and its (n, n) covariance; got {m.shape} and {p.shape}")
    p = symmetrise(p)
    if np.any(np.linalg.eigvalsh(p) <= 0.0):
        raise ValueError("the estimate's covariance must be positive definite (SI: m^2, "
                         "m^2/s^2)")
    return m, p


def _check_types(platform: object, planner: object, posterior: object) -> None:
    """Refuse arguments of the wrong type with their name (not an AttributeError later)."""
    for name, value, cls in (("platform", platform, PlatformState),
                             ("planner", planner, Planner)):
        if not isinstance(value, cls):
            raise TypeError(f"recommend(): {name} must be a {cls.__name__}, not "
                            f"{type(value).__name__}")
    if posterior is not None and not isinstance(posterior, PosteriorInformation):
        raise TypeError(f"recommend(): posterior must be a PosteriorInformation or None, not "
                        f"{type(posterior).__name__}")


def recommend(track: Estimate, platform: PlatformState, planner: Planner,
              posterior: PosteriorInformation | None = None, *, q: float = 0.0,
              cloud: str = "auto") -> Recommendation:
    """Return the planner's next action for a user's tracker and platform (one decision).

    Parameters
    ----------
    track : TrackingFilter or (mean, covariance)
        The tracker after its last update, at the platform's time; or its estimate
        ``[x, y, (z,) vx, vy, (vz)]`` (m, m/s) and covariance (SI).
    platform : PlatformState
        The platform now (one state; its ``time`` is the decision time, s).
    planner : Planner
        Kinematics, actions, interval, sensor plan, criterion, constraints.
    posterior : PosteriorInformation, optional
        ``J_k`` at the platform's time (default: the inverse of the tracker's covariance, with the
        tracker's dynamics, or ``NearlyConstantVelocity(dim, q)`` for a pair).
    q : float, optional
        Process-noise acceleration std (m/s^2) of the target, for a (mean, covariance) pair without
        ``posterior``.
    cloud : {"auto", "particles", "sigma", "mean"}, optional
        The target cloud ``Gamma`` is averaged over with ``planner.gamma = "cloud"``
        (:meth:`Belief.from_filter`); a pair gives its cubature points (``"auto"``, ``"sigma"``) or
        its mean.

    Returns
    -------
    Recommendation
        ``index`` and ``action`` (what to fly), ``bound`` (m, predicted position RMS bound of every
        candidate after one step), ``feasible``, ``violations`` (m), ``cost``.

    Raises
    ------
    ValueError, TypeError
        On a bad estimate or cloud, a tracker or posterior not at the platform's time; a platform,
        planner or posterior not of its type.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13 (the predicted posterior CRB), eq. 12 (the
    criterion ``Tr{Pi J^{-1}}``).
    """
    _check_types(platform, planner, posterior)
    if isinstance(track, TrackingFilter):
        if abs(track.time - platform.time) > 1e-6:
            raise ValueError(f"the tracker is at t = {track.time:g} s and the platform at "
                             f"t = {platform.time:g} s; predict the tracker to the decision "
                             "time first")
        if posterior is None:
            posterior = PosteriorInformation(np.linalg.inv(symmetrise(track.covariance)),
                                             track.dynamics, platform.time)
        return planner.recommend(platform, Belief.from_filter(track, posterior, cloud))
    mean, cov = _gaussian(track)
    if posterior is None:
        posterior = PosteriorInformation(np.linalg.inv(cov),
                                         NearlyConstantVelocity(mean.shape[0] // 2, q),
                                         platform.time)
    if cloud not in ("auto", "particles", "sigma", "mean"):
        raise ValueError(f"cloud must be 'auto', 'sigma' or 'mean'; got {cloud!r}")
    if cloud == "mean":
        belief = Belief(posterior, mean)
    elif cloud == "particles":
        raise ValueError("a (mean, covariance) estimate has no particles")
    else:
        belief = Belief(posterior, *cubature_points(mean, cov))
    return planner.recommend(platform, belief)
