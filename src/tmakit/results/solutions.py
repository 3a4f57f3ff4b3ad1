"""Separated solutions: the fits that explain the data about as well as the one reported.

A fit is kept when its likelihood-ratio statistic against the reported fit,
``Λ = (χ²_k + c u_k) − (χ²_best + c u_best)``, has ``P(χ²_d ≥ Λ) ≥ alpha`` (Wilks; ``c`` the
price of one unknown); fits close at the answer time are one solution, the better one's
covariance widened to cover the other.  docs/estimation.md describes the reported region.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import chi2 as chi2_dist
from ..data import MeasurementSet
from ..motion import MotionModel
from .answers import (
    ELLIPSE_LEVEL,
    Answer,
    covering_scale,
    estimate_answer,
    finite,
    fit_state,
    in_bearing_interval,
)
from .status import Status


class EstimateResult(Protocol):
    """What a solution needs of :class:`tmakit.results.EstimateResult` (which imports this)."""

    parameters: tuple[str, ...]
    estimate: NDArray[np.float64]
    std: NDArray[np.float64]
    covariance: NDArray[np.float64]
    status: Status
    chi2: float
    dof: int
    motion: MotionModel
    bound: Any
    covers: list[Any]


SOLUTION_ALPHA = 0.05
"""Level of the likelihood-ratio test that keeps a separated solution."""

SAME_MINIMUM = 1.01
"""A close fit covered by a variance widened less than this is the same minimum: no widening."""


@dataclass(eq=False)
class Solution:
    """One of the solutions that fit the data about equally well.

    Parameters
    ----------
    result : EstimateResult
    rank : int
        1 for the reported fit.
    lr_statistic, p_value : float
        ``Λ_k`` (at least 0) and ``P(χ²_d ≥ lr_statistic)``.
    """

    result: EstimateResult
    rank: int
    lr_statistic: float
    p_value: float

    def answer(self, meas: MeasurementSet | None = None, time: float | None = None,
               sensor: str | None = None, level: float = ELLIPSE_LEVEL) -> Answer:
        """Return this solution in the user's terms (:meth:`EstimateResult.answer`).

        Parameters
        ----------
        meas, time, sensor, level : optional
            As for :meth:`EstimateResult.answer`.

        Returns
        -------
        Answer
        """
        return estimate_answer(self.result, meas, time, sensor, level)

    def region_contains(self, position: ArrayLike, meas: MeasurementSet | None = None,
                        time: float | None = None, level: float = ELLIPSE_LEVEL) -> bool:
        """Tell whether a horizontal position lies in this solution's ellipse (or bearing interval).

        Parameters
        ----------
        position : array_like
            East, North, m.
        meas, time, level : optional
            As for :meth:`answer`.

        Returns
        -------
        bool
        """
        a = self.answer(meas, time, level=level)
        if not a.position_determined:
            return in_bearing_interval(np.asarray(position, dtype=float), a, meas, level)
        d = np.asarray(position, dtype=float)[:2] - np.array([a.enu[0], a.enu[1]])
        cov = a.covariance[:2, :2]
        if not np.all(np.isfinite(cov)) or not np.all(np.isfinite(d)):
            return False
        try:
            m2 = float(d @ np.linalg.solve(cov, d))
        except np.linalg.LinAlgError:
            return False
        return m2 <= float(chi2_dist.ppf(level, 2))

    def as_dict(self, meas: MeasurementSet | None = None) -> dict[str, object]:
        """Return the JSON form: rank, chi2, the test, estimate, covariance, answer.

        Parameters
        ----------
        meas : MeasurementSet, optional
            For the answer at the last measurement time.

        Returns
        -------
        dict
        """
        r = self.result
        return {"rank": self.rank, "lr_statistic": finite(self.lr_statistic),
                "p_value": finite(self.p_value),
                **fit_fields(r, [finite(v) for v in r.estimate]),
                "covariance": [[finite(c) for c in row] for row in np.asarray(r.covariance)],
                "answer": self.answer(meas).as_dict() if meas is not None else None}


def fit_fields(result: EstimateResult, estimate: list[float | None]) -> dict[str, object]:
    """Give what the JSON of every fit says: parameters, ``estimate``, std, status, chi2, motion."""
    return {"parameters": list(result.parameters), "estimate": estimate,
            "std": [finite(s) for s in result.std],
            "status": result.status, "chi2": finite(result.chi2), "dof": result.dof,
            "motion": result.motion.name}


def _state(result: EstimateResult, meas: MeasurementSet, time: float
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """East/North position and velocity at ``time`` and their covariance; None if not finite."""
    idx = [0, 1, 3, 4]
    full, cov, jac, null = fit_state(result, time)
    state = full[idx]
    if null is not None or not np.any(jac[3:6]):  # what the answer leaves out is not finite
        a = estimate_answer(result, meas, time)
        state = np.array([a.enu[0], a.enu[1], a.velocity[0], a.velocity[1]], dtype=float)
        cov = a.covariance
    cov = cov[np.ix_(idx, idx)]
    if not (np.all(np.isfinite(state)) and np.all(np.isfinite(cov))):
        return None
    return state, cov


def _unknowns(result: EstimateResult) -> int:
    """Count the fitted unknowns of a result (its bound's rank when it has one)."""
    if result.bound is not None:
        return max(int(result.bound.rank), 1)
    return max(int(np.count_nonzero(np.asarray(result.std) > 0)), 1)


def range_spread(solutions: Sequence[Solution], meas: MeasurementSet | None,
                 time: float | None = None, level: float = ELLIPSE_LEVEL
                 ) -> tuple[float, float] | None:
    """Give the smallest and largest range (m) when two solutions' range intervals disjoin."""
    z = float(np.sqrt(chi2_dist.ppf(level, 1)))
    ranges = [(a.range_m, a.range_std) for a in (s.answer(meas, time, level=level)
                                                 for s in solutions)
              if a.range_m is not None and a.range_std is not None]
    if len(ranges) < 2 or (max(r - z * sd for r, sd in ranges)
                           <= min(r + z * sd for r, sd in ranges)):
        return None
    return min(r for r, _ in ranges), max(r for r, _ in ranges)


def separated_solutions(best: EstimateResult, others: Sequence[EstimateResult],
                        meas: MeasurementSet, alpha: float = SOLUTION_ALPHA,
                        price: float = 0.0) -> list[Solution]:
    """Rank the fits that explain the data about as well as the reported one (``best`` first)."""
    d = _unknowns(best)
    out = [Solution(best, 1, 0.0, 1.0)]
    time = float(np.max(meas.time)) if len(meas) else 0.0
    kept = [_state(best, meas, time)]
    if kept[0] is None:
        return out
    same = float(chi2_dist.isf(alpha, 4))
    def statistic(r: EstimateResult) -> float:
        return float(r.chi2 + price * _unknowns(r) - best.chi2 - price * d)

    for r in sorted(others, key=statistic):
        if r.status not in ("converged", "did not converge") or not np.isfinite(r.chi2):
            continue
        lr = max(statistic(r), 0.0)
        p = float(chi2_dist.sf(lr, d))
        if p < alpha:
            continue
        here = _state(r, meas, time)
        if here is None:
            continue
        near = next((i for i, k in enumerate(kept) if _close(here, k, same)), None)
        if near is not None:
            k = kept[near]
            covers = out[near].result.covers
            if (k is not None and covering_scale(k[0], k[1], [here]) > SAME_MINIMUM
                    and not any(c is r for c in covers)):
                covers.append(r)
            continue
        kept.append(here)
        out.append(Solution(r, len(out) + 1, lr, p))
    return out


def _close(a: tuple[NDArray[np.float64], NDArray[np.float64]],
           b: tuple[NDArray[np.float64], NDArray[np.float64]] | None, limit: float) -> bool:
    """Whether two states are within ``limit`` of each other under each one's covariance."""
    if b is None:
        return False
    d = a[0] - b[0]
    try:
        return all(float(d @ np.linalg.solve(c, d)) <= limit for c in (a[1], b[1]))
    except np.linalg.LinAlgError:
        return bool(np.allclose(a[0], b[0]))
