"""Maximum likelihood for a manoeuvring target, manoeuvres unknown in number and times.

Piecewise curvilinear motion (Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9; the covariance eq. 9).
For each order M the change-over times are profiled over a grid (:class:`ManoeuvreSearch`) and
the best minima refined with every parameter free (:func:`lm_fit`); the order is chosen by BIC
(Schwarz 1978) or sequential likelihood-ratio tests (:func:`select_order`), unneeded
accelerations are held at zero (:func:`sparsify`).  docs/estimation.md describes the search.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import blas
from ..core import chi2 as chi2_dist
from ..core.arrays import Array
from ..data import MeasurementSet
from ..motion import (
    ConstantVelocity,
    FixedParameters,
    PiecewiseCurvilinear,
    default_ref_time,
    motion_from_name,
)
from ..motion.curvilinear import ForwardPiecewise
from ..observation import ObservationModel
from ..results.answers import finite
from ..results.checks import wider_undetermined
from ..results.estimate import EstimateResult, assemble_result
from ..results.nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from ..results.solutions import Solution, separated_solutions
from ..results.status import CONVERGED, DIVERGED, NOT_CONVERGED
from .estimator import BatchEstimator, Init, Options, refuse_manoeuvre_options, theta_from_init
from .solver import SolveResult, VarProProblem, levenberg_marquardt

__all__ = ["ACCELERATIONS", "CRITERIA", "ManoeuvreEstimate", "ManoeuvreEstimator",
           "ManoeuvreSettings", "OrderFit", "OrderSelection", "estimate_for",
           "estimate_manoeuvres", "may_hold", "select_order"]


CRITERIA = ("bic", "lrt")
"""Criteria for the number of manoeuvres and the accelerations held."""
ACCELERATIONS = ("select", "all")
"""How the accelerations are fitted (see :class:`ManoeuvreSettings`)."""


@dataclass(frozen=True)
class ManoeuvreSettings:
    """How the manoeuvre estimator searches (times in seconds).

    Parameters
    ----------
    max_manoeuvres, exact, criterion, alpha, accelerations
        As for :func:`estimate_manoeuvres`.
    grid_step, min_segment : float
        Spacing of the profile grid; shortest segment and the grid's distance from the ends, s.
    refine, profile_iter, max_iter : int
        Profile minima refined per order; iterations of a held fit and of a free refinement.
    max_tuples : int
        Beyond this many grid tuples only those extending the order below's best are fitted.
    prune : float
        Held fits stop once they cannot come within this (half chi2) of the best.
    polish_step, polish_rounds : float, int
        The finer profile after refinement (s; 0 rounds: none).

    Raises
    ------
    ValueError
        For a setting out of its range, named.
    """

    max_manoeuvres: int = 2
    exact: bool = False
    criterion: str = "bic"
    alpha: float = 0.01
    grid_step: float = 40.0
    min_segment: float = 20.0
    refine: int = 3
    profile_iter: int = 12
    max_tuples: int = 400
    prune: float = 25.0
    polish_step: float = 4.0
    polish_rounds: int = 2
    max_iter: int = 100
    accelerations: str = "select"

    def __post_init__(self) -> None:
        """Refuse settings out of range."""
        if self.max_manoeuvres < 0 or int(self.max_manoeuvres) != self.max_manoeuvres:
            raise ValueError(f"max_manoeuvres must be a whole number >= 0, got "
                             f"{self.max_manoeuvres!r}")
        if self.criterion not in CRITERIA:
            raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got "
                             f"{self.criterion!r}")
        if not 0.0 < self.alpha < 1.0:
            raise ValueError(f"alpha must lie in (0, 1), got {self.alpha!r}")
        if not self.grid_step > 0 or not self.min_segment > 0:
            raise ValueError("grid_step and min_segment must be positive (seconds)")
        if self.refine < 1 or self.profile_iter < 1 or self.max_iter < 1:
            raise ValueError("refine, profile_iter and max_iter must be at least 1")
        if self.polish_rounds < 0 or not self.polish_step > 0:
            raise ValueError("polish_rounds must be >= 0 and polish_step positive (seconds)")
        if self.max_tuples < 1:
            raise ValueError("max_tuples must be at least 1")
        if self.accelerations not in ACCELERATIONS:
            raise ValueError(f"accelerations must be one of {', '.join(ACCELERATIONS)}, got "
                             f"{self.accelerations!r}")


@dataclass
class OrderFit:
    """The best fit with ``manoeuvres`` manoeuvres.

    Parameters
    ----------
    manoeuvres, unknowns, iterations, starts : int
        Unknowns: motion and nuisance parameters fitted; starts: of the final refinement.
    theta, nuisance : ndarray
        Internal parameters (at the first measurement time) and nuisance, SI.
    chi2 : float
    converged : bool
    note : str
        How the fit was settled, when it matters.
    profile_times, profile_chi2 : ndarray
        The profile grid's change-over times ``(G, M)``, s, and chi2 ``(G,)``.
    free : ndarray of bool, optional
        The internal parameters fitted; None: all.
    alternatives : list of OrderFit
        Other local minima of this order.
    """

    manoeuvres: int
    theta: Array
    nuisance: Array
    chi2: float
    unknowns: int
    converged: bool
    iterations: int
    starts: int
    note: str = ""
    profile_times: Array = field(default_factory=lambda: np.zeros((0, 0)))
    profile_chi2: Array = field(default_factory=lambda: np.zeros(0))
    free: NDArray[np.bool_] | None = None
    alternatives: list[OrderFit] = field(default_factory=list)

    def free_mask(self) -> NDArray[np.bool_]:
        """Which internal parameters are fitted (the others are accelerations held at 0).

        Returns
        -------
        ndarray of bool
        """
        return np.ones(self.theta.shape[0], dtype=bool) if self.free is None else self.free


def grid_tuples(grid: Array, m: int, min_gap: float) -> NDArray[np.int64]:
    """Index tuples ``i_1 < ... < i_m`` into ``grid`` whose times are ``min_gap`` apart."""
    if m == 0:
        return np.zeros((1, 0), dtype=np.int64)
    out = [c for c in itertools.combinations(range(grid.size), m)
           if m == 1 or np.all(np.diff(grid[list(c)]) >= min_gap - 1e-9)]
    return np.array(out, dtype=np.int64).reshape(-1, m)


def split_segment(theta: Array, m_prev: int, j: int, t_new: Array) -> Array:
    """Insert a change-over time into fits, splitting a segment in two."""
    b = theta.shape[0]
    acc = theta[:, 4:6 + 2 * m_prev].reshape(b, m_prev + 1, 2)
    acc = np.concatenate([acc[:, :j + 1], acc[:, j:j + 1], acc[:, j + 1:]], axis=1)
    times = np.insert(theta[:, 6 + 2 * m_prev:], j, t_new, axis=1)
    return np.concatenate([theta[:, :4], acc.reshape(b, -1), times], axis=1)


def local_minima(tuples: NDArray[np.int64], cost: Array) -> NDArray[np.int64]:
    """Find the rows of ``tuples`` that are local minima of the cost, best first."""
    where = {tuple(t): i for i, t in enumerate(tuples.tolist())}

    def lower_neighbour(i: int, t: list[int]) -> bool:
        nbs = (where.get((*t[:k], t[k] + d, *t[k + 1:])) for k in range(len(t)) for d in (-1, 1))
        return any(o is not None and cost[o] < cost[i] for o in nbs)

    keep = np.array([i for i, t in enumerate(tuples.tolist())
                     if np.isfinite(cost[i]) and not lower_neighbour(i, t)], dtype=np.int64)
    return keep[np.argsort(cost[keep])] if keep.size else keep


def lm_fit(problem: VarProProblem, theta0: Array, free: NDArray[np.bool_], max_iter: int,
           rtol: float = 1e-3, atol: float = 0.02, prune: float | None = None,
           best: float = np.inf, max_reject: int = 40, stall: float = 0.0) -> SolveResult:
    """Fit by Levenberg–Marquardt with the search's damping and stopping rules."""
    motion = problem.obs.motion
    # the held parameters' derivatives are not formed (ForwardPiecewise.derivatives_for),
    # unless the rows are summed in chunks (J'J formed over every column)
    held = (isinstance(motion, ForwardPiecewise) and len(problem.obs.meas) <= blas.CHUNKED_ROWS
            and not np.all(free))
    with (motion.derivatives_for(free) if held and isinstance(motion, ForwardPiecewise)
          else nullcontext()):
        return levenberg_marquardt(
            problem, problem.obs.values, theta0, max_iter, ftol=rtol, xtol=0.0, gtol=0.0,
            dtol=atol, ceiling=None if prune is None else np.asarray(best), free=free,
            damping="factors", max_reject=max_reject, stall=stall,
            dominance=(2.0, 0.0 if prune is None else prune))


_CHUNK = 256  # held fits per batch on the profile grid
PROBES = (-3.0, -2.0, -1.0, -0.5, -0.05, 0.05, 0.5, 1.0, 2.0, 3.0)
"""Moves (s) of a change-over time in the corner test (:meth:`ManoeuvreSearch.settle`)."""


class ManoeuvreSearch:
    """Every order's fit of one data set (eq. 8), in ``ForwardPiecewise`` parameters at t0."""

    def __init__(self, meas: MeasurementSet, options: Mapping[str, Mapping[str, object]] | None,
                 known_nuisance: KnownNuisance | None,
                 settings: ManoeuvreSettings) -> None:
        self.meas = meas
        self.options = options
        self.known = known_nuisance
        self.s = settings
        self.t0 = float(meas.time.min())
        self.t_end = float(meas.time.max())
        lo, hi = self.t0 + settings.min_segment, self.t_end - settings.min_segment
        n = math.floor((hi - lo) / settings.grid_step + 1e-9) + 1 if hi >= lo else 0
        # the grid centred in the span
        pad = (hi - lo - (n - 1) * settings.grid_step) / 2.0 if n else 0.0
        self.grid = np.asarray(lo + pad + settings.grid_step * np.arange(max(n, 0)),
                               dtype=np.float64)
        self.min_gap = max(settings.min_segment, settings.grid_step)
        self._problems: dict[int, VarProProblem] = {}
        self.profiles: dict[int, tuple[NDArray[np.int64], Array, Array]] = {}

    def problem(self, m: int) -> VarProProblem:
        """Give the least-squares problem with ``m`` manoeuvres (cached)."""
        if m not in self._problems:
            model = ForwardPiecewise(m, self.t0, end_time=self.t_end)
            obs = ObservationModel(self.meas, model, self.options)
            fixed = None if self.known is None else obs.nuisance_vector(self.known.values)
            self._problems[m] = VarProProblem(obs, None, fixed)
        return self._problems[m]

    def max_order(self) -> int:
        """Count the most manoeuvres the grid can hold (at most ``max_manoeuvres``)."""
        m = 0
        while m < self.s.max_manoeuvres and grid_tuples(self.grid, m + 1,
                                                        self.min_gap).shape[0] > 0:
            m += 1
        return m

    def unknowns(self, m: int, free: NDArray[np.bool_] | None = None) -> int:
        """Count the unknowns of the order ``m`` model (fitted motion and free nuisance)."""
        pr = self.problem(m)
        p = pr.p if free is None else int(np.count_nonzero(free))
        return p + (0 if pr.fixed is not None else pr.k)

    def fit_zero(self, init: Array | None = None) -> OrderFit:
        """Fit order 0 (one curvilinear segment)."""
        pr = self.problem(0)
        if init is None:
            from .ml import estimate as estimate_cv

            cv = estimate_cv(self.meas, ConstantVelocity(2, self.t0), options=self.options,
                             known_nuisance=self.known)
            x, y, vx, vy = cv.estimate
            init = np.array([x, y, math.hypot(vx, vy), math.atan2(vx, vy), 0.0, 0.0])
        sol = levenberg_marquardt(pr, pr.obs.values, np.atleast_2d(init),
                                  max_iter=self.s.max_iter)
        ok = np.isfinite(sol.cost)
        if not ok[0]:
            raise ValueError("the constant-velocity start gives no finite curvilinear fit")
        grid_idx = np.zeros((1, 0), dtype=np.int64)
        self.profiles[0] = (grid_idx, sol.theta.copy(), sol.cost.copy())
        return OrderFit(0, sol.theta[0], sol.nuisance[0], float(2 * sol.cost[0]),
                        self.unknowns(0), bool(sol.converged[0]), int(sol.iterations[0]), 1)

    def _profile_starts(self, m: int) -> tuple[NDArray[np.int64], Array, Array]:
        """Choose the grid tuples of order ``m`` to profile and their warm starts."""
        tuples = grid_tuples(self.grid, m, self.min_gap)
        prev_idx, prev_theta, prev_cost = self.profiles[m - 1]
        if tuples.shape[0] > self.s.max_tuples:
            seeds = prev_idx[local_minima(prev_idx, prev_cost)[: self.s.refine]]
            keep = np.zeros(tuples.shape[0], dtype=bool)
            for sd in seeds:
                for j in range(m):
                    keep |= np.all(np.delete(tuples, j, axis=1) == sd, axis=1)
            tuples = tuples[keep]
        where = {tuple(t): i for i, t in enumerate(prev_idx)}
        best_cost = np.full(tuples.shape[0], np.inf)
        start = np.full((tuples.shape[0], self.problem(m).p), np.nan)
        for j in range(m):  # drop the j-th time: a tuple of order m - 1
            sub = np.delete(tuples, j, axis=1)
            rows = np.array([where.get(tuple(t), -1) for t in sub])
            have = rows >= 0
            cost = np.where(have, prev_cost[rows], np.inf)
            better = cost < best_cost
            if np.any(better):
                cand = split_segment(prev_theta[rows[better]], m - 1, j,
                                     self.grid[tuples[better, j]])
                start[better] = cand
                best_cost[better] = cost[better]
        return tuples, start, best_cost

    def profile(self, m: int) -> tuple[NDArray[np.int64], Array, Array]:
        """Fit with the change-over times held on the grid tuples of order ``m``, warm-started."""
        tuples, start, best_cost = self._profile_starts(m)
        ok = np.flatnonzero(np.isfinite(best_cost))
        pr = self.problem(m)
        free = np.ones(pr.p, dtype=bool)
        free[6 + 2 * m:] = False
        theta = np.full_like(start, np.nan)
        cost = np.full(tuples.shape[0], np.inf)
        best = np.inf
        for a in range(0, ok.size, _CHUNK):  # chunks bound the memory: (chunk, n, p) arrays
            rows = ok[a:a + _CHUNK]
            sol = lm_fit(pr, start[rows], free, self.s.profile_iter, prune=self.s.prune,
                         best=best)
            theta[rows], cost[rows] = sol.theta, sol.cost
            best = min(best, float(np.min(sol.cost)))
        self.profiles[m] = (tuples, theta, cost)
        return tuples, theta, cost

    def fit(self, m: int, below: OrderFit | None = None) -> OrderFit:
        """Fit order ``m``: profile, then refine its best minima and ``below`` split in two."""
        tuples, theta, cost = self.profile(m)
        minima = local_minima(tuples, cost)[: self.s.refine]
        if minima.size == 0:
            raise ValueError(f"no finite profile fit with {m} manoeuvres")
        starts = theta[minima]
        if below is not None and np.all(np.isfinite(below.theta)):
            edges = np.concatenate([[self.t0], below.theta[6 + 2 * (m - 1):], [self.t_end]])
            j = int(np.argmax(np.diff(edges)))
            nested = split_segment(below.theta[None], m - 1, j,
                                   np.array([edges[j:j + 2].mean()]))
            starts = np.concatenate([starts, nested])
        fit = self.fit_from(m, starts)
        alternatives = fit.alternatives  # the other minima the profile's starts end in
        if self.s.polish_rounds:
            fit = self.polish(fit)
        fit.alternatives = alternatives
        fit.profile_times, fit.profile_chi2 = self.grid[tuples], 2.0 * cost
        return fit

    def _polish_starts(self, fit: OrderFit, offsets: Array) -> tuple[Array, NDArray[np.int64]]:
        """Make the starts of the finer profiles, and say which time each start moves."""
        m, k0 = fit.manoeuvres, 6 + 2 * fit.manoeuvres
        starts, held = [], []
        times = fit.theta[k0:]
        for k in range(m):
            lo = times[k - 1] if k else self.t0
            hi = times[k + 1] if k + 1 < m else self.t_end
            cand = times[k] + offsets
            cand = cand[(cand > lo) & (cand < hi)]
            for c in cand:
                th = fit.theta.copy()
                th[k0 + k] = c
                starts.append(th)
                held.append(k)
        return np.array(starts), np.array(held, dtype=np.int64)

    def polish(self, fit: OrderFit, reach: float | None = None) -> OrderFit:
        """Profile each change-over time finely (``polish_step``) around the refined fit."""
        m = fit.manoeuvres
        if m == 0 or not np.isfinite(fit.chi2):
            return fit
        pr = self.problem(m)
        k0 = 6 + 2 * m
        reach = self.s.grid_step if reach is None else reach
        offsets = np.arange(-reach, reach + 1e-9, self.s.polish_step)
        offsets = offsets[offsets != 0.0]
        for _ in range(self.s.polish_rounds):
            start, held_k = self._polish_starts(fit, offsets)
            if start.size == 0:
                break
            best_theta, best_cost = None, fit.chi2 / 2.0
            for k in range(m):  # one batch per held time (the free columns differ)
                rows = np.flatnonzero(held_k == k)
                if rows.size == 0:
                    continue
                free = fit.free_mask().copy()
                free[k0 + k] = False
                sol = lm_fit(pr, start[rows], free, self.s.profile_iter, prune=0.0, best=best_cost)
                i = int(np.argmin(sol.cost))
                if sol.cost[i] < best_cost - 1e-9:
                    best_theta, best_cost = sol.theta[i], float(sol.cost[i])
            if best_theta is None:
                break
            new = self.fit_from(m, best_theta[None], fit.free)
            if not new.chi2 < fit.chi2:
                break
            new.iterations += fit.iterations
            fit = new
        return fit

    def fit_from(self, m: int, theta0: Array, free: NDArray[np.bool_] | None = None
                 ) -> OrderFit:
        """Fit from the starts ``theta0``; the lowest cost wins, settled on a corner if at one."""
        pr = self.problem(m)
        mask = np.ones(pr.p, dtype=bool) if free is None else free
        sol = lm_fit(pr, np.atleast_2d(theta0), mask, self.s.max_iter, rtol=1e-10, atol=1e-7,
                     prune=self.s.prune, max_reject=8, stall=1e-3)
        c = np.where(np.isfinite(sol.cost), sol.cost, np.inf)
        i = int(np.argmin(c))
        fit = OrderFit(m, sol.theta[i], sol.nuisance[i], float(2 * c[i]),
                       self.unknowns(m, free), bool(sol.converged[i]), int(sol.iterations[i]),
                       int(sol.theta.shape[0]), free=None if free is None else free.copy())
        fit.alternatives = [OrderFit(m, sol.theta[j], sol.nuisance[j], float(2 * c[j]),
                                     fit.unknowns, True, int(sol.iterations[j]), 1,
                                     free=fit.free)
                            for j in range(c.shape[0]) if j != i and sol.converged[j]
                            and np.isfinite(c[j])]
        if not fit.converged and m and np.isfinite(fit.chi2):
            self.settle(fit)
        return fit

    def _probes(self, theta: Array, m: int) -> Array:
        """Make the held starts of the corner test."""
        k0 = 6 + 2 * m
        samples = np.unique(self.meas.time)
        probes = []
        for k in range(m):
            t_k = theta[k0 + k]
            # the corners either side, and steps of 0.05 to 3 s
            below = samples[samples < t_k - 1e-6][-1:]
            above = samples[samples > t_k + 1e-6][:1]
            for target in (*(t_k + d for d in PROBES), *below, *above):
                q = theta.copy()
                q[k0 + k] = target
                probes.append(q)
        return np.array(probes)

    def settle(self, fit: OrderFit, rounds: int = 8, tol: float = 1e-4) -> None:
        """Settle in place a refinement stopped on a corner of the likelihood (a sample time)."""
        m = fit.manoeuvres
        pr = self.problem(m)
        held_free = fit.free_mask().copy()
        held_free[6 + 2 * m:] = False
        for _ in range(rounds):
            held = lm_fit(pr, fit.theta[None], held_free, 50, rtol=1e-10, atol=1e-7)
            if not held.converged[0]:
                break
            c0 = float(held.cost[0])
            ps = lm_fit(pr, self._probes(held.theta[0], m), held_free, 50, rtol=1e-10,
                        atol=1e-7, prune=0.0, best=c0 - tol / 2.0)
            fit.iterations += int(held.iterations[0])
            if np.all(ps.cost >= c0 - tol / 2.0):
                fit.theta, fit.nuisance, fit.chi2 = held.theta[0], held.nuisance[0], 2.0 * c0
                fit.converged = True
                fit.note = ("converged to a corner of the likelihood (it has one at every "
                            "measurement time): moving any change-over time by 0.05 to 3 s, "
                            "or onto the measurement time either side, raises chi2 or "
                            f"lowers it by less than {tol:g}")
                return
            i = int(np.argmin(ps.cost))
            sol = lm_fit(pr, ps.theta[i][None], fit.free_mask(), self.s.max_iter,
                         rtol=1e-10, atol=1e-7, max_reject=8, stall=1e-3)
            better = sol.cost[0] <= ps.cost[i]
            fit.theta = sol.theta[0] if better else ps.theta[i]
            fit.nuisance = sol.nuisance[0] if better else ps.nuisance[i]
            fit.chi2 = float(2.0 * min(sol.cost[0], ps.cost[i]))
            fit.iterations += int(sol.iterations[0])
            if sol.converged[0]:
                fit.converged = True
                return
        fit.note = ("the refinement stopped improving before its convergence tests were met, "
                    "and the change-over times could not be settled on a corner of the "
                    "likelihood")


@dataclass
class OrderSelection:
    """Chi2 and the criteria of every order tried, and the order chosen.

    Parameters
    ----------
    criterion, alpha
        As for :func:`select_order`.
    n_measurements : int
        ``N``, the noise covariance's rank.
    orders : list of dict
        Per order: ``manoeuvres``, ``chi2``, ``unknowns``, ``bic``, ``lr_statistic``, ``p_value``
        (None for the first), ``converged``.
    chosen : int
        The number of manoeuvres chosen.
    """

    criterion: str
    alpha: float
    n_measurements: int
    orders: list[dict[str, float | int | None]]
    chosen: int

    def as_dict(self) -> dict[str, object]:
        """Give the selection as JSON-ready data (non-finite numbers as None).

        Returns
        -------
        dict of str to object
        """
        return {"criterion": self.criterion, "alpha": self.alpha if self.criterion == "lrt"
                else None, "n_measurements": self.n_measurements, "chosen": self.chosen,
                "orders": [{k: finite(v) if isinstance(v, float) else v for k, v in o.items()}
                           for o in self.orders]}

    def summary(self) -> str:
        """Tabulate the orders tried, one line each, the chosen one marked.

        Returns
        -------
        str
        """
        lines = [f"number of manoeuvres: {self.chosen} (criterion "
                 + ("BIC" if self.criterion == "bic" else
                    f"likelihood-ratio tests at alpha = {self.alpha:g}") + ")",
                 f"  {'M':>2}  {'chi2':>12}  {'unknowns':>8}  {'BIC':>12}  {'LR vs M-1':>10}"
                 f"  {'p-value':>9}"]
        for o in self.orders:
            lr = o["lr_statistic"]
            pv = o["p_value"]
            lines.append(f"  {o['manoeuvres']:>2}  {o['chi2']:12.3f}  {o['unknowns']:>8}  "
                         f"{o['bic']:12.3f}  "
                         + (f"{lr:10.3f}  {pv:9.3g}" if lr is not None else f"{'':>10}  "
                            f"{'':>9}")
                         + ("  <- chosen" if o["manoeuvres"] == self.chosen else ""))
        return "\n".join(lines)


def select_order(fits: list[OrderFit], n: int, criterion: str = "bic", alpha: float = 0.01
                 ) -> OrderSelection:
    """Choose the number of manoeuvres from fits of consecutive orders.

    Parameters
    ----------
    fits : list of OrderFit
        Orders ``0, 1, ...``.
    n : int
        ``N``, independent measurements.
    criterion : {"bic", "lrt"}
        ``"bic"`` minimises ``chi2 + k ln N``; ``"lrt"`` adds a manoeuvre while the
        likelihood-ratio test rejects at level ``alpha``.
    alpha : float

    Returns
    -------
    OrderSelection

    Raises
    ------
    ValueError
        For an unknown criterion.

    References
    ----------
    Schwarz (1978) (BIC).
    """
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    orders: list[dict[str, float | int | None]] = []
    for i, f in enumerate(fits):
        lr = pv = None
        if i > 0 and fits[i - 1].manoeuvres == f.manoeuvres - 1:
            lr = max(fits[i - 1].chi2 - f.chi2, 0.0)
            dof = f.unknowns - fits[i - 1].unknowns
            # with accelerations selected, a manoeuvre can come with fewer unknowns than the
            # order below holds: any chi2 drop then favours it outright
            pv = float(chi2_dist.sf(lr, dof)) if dof > 0 else (0.0 if lr > 0 else 1.0)
        orders.append({"manoeuvres": f.manoeuvres, "chi2": f.chi2, "unknowns": f.unknowns,
                       "bic": f.chi2 + f.unknowns * math.log(n), "lr_statistic": lr,
                       "p_value": pv, "converged": f.converged})
    if criterion == "bic":
        bic = [f.chi2 + f.unknowns * math.log(n) if np.isfinite(f.chi2) else np.inf
               for f in fits]  # (the orders' "bic")
        chosen = fits[int(np.argmin(bic))].manoeuvres
    else:
        chosen = fits[0].manoeuvres
        for i in range(1, len(fits)):
            pv = orders[i]["p_value"]
            if pv is None or pv >= alpha:
                break
            chosen = fits[i].manoeuvres
    return OrderSelection(criterion, alpha, n, orders, chosen)


def fit_criterion(s: ManoeuvreSettings) -> str:
    """Say in words the rule that holds an acceleration at zero (for result messages)."""
    return ("BIC: holding one raised chi2 by less than ln N" if s.criterion == "bic" else
            f"holding one raised chi2 by less than {unknown_price(s, 1):.4g}, the chi-square(1) "
            f"quantile exceeded with probability {s.alpha:g}")


def unknown_price(s: ManoeuvreSettings, n: int) -> float:
    """Give what one unknown must lower chi2 by to be kept, by the settings' criterion."""
    # (isf, not ppf(1 - alpha): 1 - 1e-17 is 1, whose quantile is inf)
    return math.log(n) if s.criterion == "bic" else float(chi2_dist.isf(s.alpha, 1))


def may_hold(free: NDArray[np.bool_], i: int, m: int) -> bool:
    """Whether acceleration ``i`` may be held at zero (not leaving two straight legs side by side).

    Parameters
    ----------
    free : ndarray of bool
        The internal parameters fitted now.
    i, m : int
        Internal index ``4 + 2 * segment + {0: a_t, 1: a_n}``; the number of manoeuvres.

    Returns
    -------
    bool
    """
    mask = free.copy()
    mask[i] = False
    seg = (i - 4) // 2
    both_held = [not mask[4 + 2 * s] and not mask[5 + 2 * s] for s in range(m + 1)]
    return not any(both_held[s] and both_held[seg] for s in (seg - 1, seg + 1) if 0 <= s <= m)


def hold_starts(search: ManoeuvreSearch, theta: Array, i: int, m: int) -> Array:
    """Make starts for a fit with acceleration ``i`` held at zero."""
    s = search.s
    base = theta.copy()
    base[i] = 0.0
    out = [base]
    seg = (i - 4) // 2
    k0 = 6 + 2 * m
    for k in (seg - 1, seg):  # change-over times t_seg (index seg - 1) and t_{seg+1}
        if not 0 <= k < m:
            continue
        lo = theta[k0 + k - 1] if k else search.t0
        hi = theta[k0 + k + 1] if k + 1 < m else search.t_end
        for d in (-1.0, 1.0):
            t = theta[k0 + k] + d * s.grid_step
            if lo + s.min_segment / 2 < t < hi - s.min_segment / 2:
                q = base.copy()
                q[k0 + k] = t
                out.append(q)
    return np.array(out)


def _best_hold(search: ManoeuvreSearch, current: OrderFit, free: NDArray[np.bool_],
               price: float) -> tuple[float, int, Array, Array] | None:
    """Find the acceleration whose hold raises chi2 least."""
    m = current.manoeuvres
    pr = search.problem(m)
    best: tuple[float, int, Array, Array] | None = None
    for i in range(4, 6 + 2 * m):
        if not free[i] or not may_hold(free, i, m):
            continue
        mask = free.copy()
        mask[i] = False
        starts = hold_starts(search, current.theta, i, m)
        # ranking holds needs chi2 to ~0.04; a start that cannot come within the price of the
        # current fit is dropped early
        sol = lm_fit(pr, starts, mask, 30, rtol=0.0, atol=0.02, max_reject=8, stall=1e-2,
                     prune=price / 2.0, best=current.chi2 / 2.0)
        j = int(np.argmin(np.where(np.isfinite(sol.cost), sol.cost, np.inf)))
        if best is None or 2.0 * sol.cost[j] < best[0]:
            best = (float(2.0 * sol.cost[j]), i, sol.theta[j], sol.nuisance[j])
    return best


def sparsify(search: ManoeuvreSearch, fit: OrderFit) -> OrderFit:
    """Hold at zero, by backward elimination, the accelerations the data do not pay for."""
    m = fit.manoeuvres
    if not np.isfinite(fit.chi2):
        return fit
    s = search.s
    n = search.problem(m).noise.rank
    price = unknown_price(s, n)
    free = fit.free_mask().copy()
    current, held = fit, False
    ahead: list[OrderFit] = []
    while True:
        chain = _hold_chain(search, current, free, price)
        if not chain:
            break
        rise = chain[-1].chi2 - current.chi2
        if not rise < price * len(chain):
            ahead = chain  # the sparser patterns the data do not pay for: candidates
            break
        current, free, held = chain[-1], chain[-1].free_mask().copy(), True
    if not held:
        fit.alternatives = [*fit.alternatives, *_refit(search, ahead)]
        return fit
    out = search.fit_from(m, current.theta[None], free)
    out.iterations += fit.iterations
    if s.polish_rounds and m:
        out = search.polish(out, reach=2.0 * s.grid_step)
    out.profile_times, out.profile_chi2 = fit.profile_times, fit.profile_chi2
    out.alternatives = [*out.alternatives, *_refit(search, ahead)]
    return out


LOOK_AHEAD = 2  # holds tried together by sparsify when one alone does not pay for itself


def _hold_chain(search: ManoeuvreSearch, current: OrderFit, free: NDArray[np.bool_],
                price: float) -> list[OrderFit]:
    """Hold the cheapest acceleration, then (while the holds do not pay) the next, greedily."""
    m = current.manoeuvres
    chain: list[OrderFit] = []
    mask = free.copy()
    at = current
    for _ in range(LOOK_AHEAD):
        best = _best_hold(search, at, mask, price)
        if best is None:
            break
        mask = mask.copy()
        mask[best[1]] = False
        at = OrderFit(m, best[2], best[3], best[0], search.unknowns(m, mask), False,
                      at.iterations, at.starts, free=mask.copy())
        chain.append(at)
        if at.chi2 - current.chi2 < price * len(chain):
            break
    return chain


def _refit(search: ManoeuvreSearch, fits: list[OrderFit]) -> list[OrderFit]:
    """Refit to convergence the sparser patterns the elimination looked at and left."""
    refits = (search.fit_from(f.manoeuvres, f.theta[None], f.free_mask()) for f in fits)
    return [r for r in refits if r.converged and np.isfinite(r.chi2)]


@dataclass
class ManoeuvreEstimate(EstimateResult):
    """An :class:`~tmakit.results.estimate.EstimateResult` for the chosen manoeuvres.

    Parameters
    ----------
    selection : OrderSelection, optional
        None when one order was fitted.
    fits : list of OrderFit
        Every order's fit.
    held : list of str
        The accelerations held at zero (value and std 0).
    final_time : float
        The last measurement time, s.
    final : dict
        The state at ``final_time``: ``{name: (value, std)}``, SI.
    """

    selection: OrderSelection | None = None
    fits: list[OrderFit] = field(default_factory=list)
    held: list[str] = field(default_factory=list)
    final_time: float = float("nan")
    final: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def manoeuvres(self) -> int:
        """The number of manoeuvres of the chosen model."""
        return int(getattr(self.motion, "manoeuvres", 0))

    def change_over_times(self) -> list[tuple[float, float]]:
        """List ``(value, std)`` of every change-over time, s.

        Returns
        -------
        list of tuple of float
        """
        return [(float(self.estimate[i]), float(self.std[i]))
                for i, n in enumerate(self.parameters) if n.startswith("t_")]

    def _fields(self) -> dict[str, object]:
        """Add the manoeuvres, held accelerations, order selection and final state."""
        data = super()._fields()
        data["manoeuvres"] = self.manoeuvres
        data["held_at_zero"] = list(self.held)
        data["model_order"] = self.selection.as_dict() if self.selection else None
        data["change_over_times"] = [{"value": finite(v), "std": finite(s)}
                                     for v, s in self.change_over_times()]
        data["final_state"] = {"time": finite(self.final_time),
                               **{k: {"value": finite(v) if np.isfinite(s) else None,
                                      "std": finite(s)}
                                  for k, (v, s) in self.final.items()}}
        return data

    def summary(self, units: str = "si") -> str:
        """Describe the estimate, the order selection and the final position (m), as text."""
        parts = [super().summary(units)]
        if self.selection is not None:
            parts.append(self.selection.summary())
        if self.final and self.status in ("converged", "unobservable"):
            x, sx = self.final["x"]
            y, sy = self.final["y"]
            if np.isfinite(sx) and np.isfinite(sy):  # no number for what is unobservable
                parts.append(f"position at t = {self.final_time:g} s: x = {x:.1f} m (std "
                             f"{sx:.3g}), y = {y:.1f} m (std {sy:.3g})")
            else:
                parts.append(f"position at t = {self.final_time:g} s: unobservable")
        return "\n".join(parts)


def reference(model: ForwardPiecewise, theta: Array, ref_time: float) -> Array:
    """Give the same trajectory in :class:`PiecewiseCurvilinear` parameters at ``ref_time``."""
    state = model.segment_states(theta, np.array([ref_time]))[0]
    out = np.array(theta, dtype=float)
    out[:4] = state
    out[3] = (state[3] + math.pi) % (2 * math.pi) - math.pi
    if out[3] == -math.pi:
        out[3] = math.pi
    return out


def report(search: ManoeuvreSearch, fit: OrderFit, ref_time: float,
           selection: OrderSelection | None, fits: list[OrderFit]) -> ManoeuvreEstimate:
    """Report a fit in the user's parameterisation, with its covariance (eq. 9)."""
    m = fit.manoeuvres
    motion = PiecewiseCurvilinear(m, ref_time)
    pr = search.problem(m)
    assert isinstance(pr.obs.motion, ForwardPiecewise)  # the search fits in that form
    theta = reference(pr.obs.motion, fit.theta, ref_time)
    if not np.all(np.isfinite(theta)) or not np.isfinite(fit.chi2):
        nan = np.full(motion.n_params, np.nan)
        return ManoeuvreEstimate(motion.param_names, nan, nan,
                                 np.full((motion.n_params,) * 2, np.nan),
                                 {k: (np.nan, np.nan) for k in pr.obs.nuisance_names},
                                 DIVERGED, chi2=np.inf, dof=pr.noise.rank - fit.unknowns,
                                 message="the solve left the region where the model is "
                                         "defined (non-finite predictions)", method="ml",
                                 motion=motion, selection=selection, fits=fits,
                                 final_time=search.t_end, iterations=fit.iterations,
                                 starts=fit.starts)
    free = fit.free_mask()
    held = [n for n, f in zip(motion.param_names, free, strict=True) if not f]
    # the information of the fitted parameters only: a held acceleration is no unknown
    fitted = FixedParameters(motion, dict.fromkeys(held, 0.0)) if held else motion
    # a fit settled on a corner of the likelihood says so in its note, not as "iteration limit"
    res = assemble_result(ObservationModel(search.meas, fitted, search.options), pr.noise,
                          theta[free], fit.nuisance, fit.chi2 / 2.0, fit.iterations,
                          fit.converged or bool(fit.note), "ml", fit.starts,
                          search.known, fit.note)
    status = res.status if fit.converged or res.status != CONVERGED else NOT_CONVERGED
    p = motion.n_params
    std = np.zeros(p)
    std[free] = res.std
    cov = np.zeros((p, p))
    cov[np.ix_(free, free)] = res.covariance
    message = res.message
    if held:
        note = (f"held at zero as the data do not need them ({fit_criterion(search.s)}): "
                f"{', '.join(held)}")
        message = f"{message}; {note}" if message else note
    assert res.bound is not None
    return ManoeuvreEstimate(motion.param_names, theta, std, cov, res.nuisance, status,
                             chi2=fit.chi2, dof=res.dof, bound=res.bound, message=message,
                             final=res.bound.derived(search.t_end), held=held, method="ml",
                             motion=motion, selection=selection, fits=fits,
                             final_time=search.t_end, iterations=fit.iterations,
                             starts=fit.starts)


def _fit_from_start(search: ManoeuvreSearch, ref: float,
                    init: Mapping[str, float] | ArrayLike) -> ManoeuvreEstimate:
    """Fit exactly ``max_manoeuvres`` from ``init`` (user parameters at ``ref``), no search."""
    s = search.s
    m = s.max_manoeuvres
    user = PiecewiseCurvilinear(m, ref)
    theta0 = theta_from_init(user, init)
    if m and (np.any(np.diff(theta0[6 + 2 * m:]) <= 0)
              or theta0[6 + 2 * m] <= search.t0 or theta0[-1] >= search.t_end):
        raise ValueError("init: the change-over times must increase and lie inside the "
                         f"data span ({search.t0:g} s, {search.t_end:g} s)")
    state = user.states(theta0, np.array([search.t0]))[0]
    internal = np.array(theta0, dtype=float)
    internal[:4] = (state[0], state[1], math.hypot(state[3], state[4]),
                    math.atan2(state[3], state[4]))
    fit = search.fit_from(m, internal)
    if s.accelerations == "select":
        fit = sparsify(search, fit)
    return report(search, fit, ref, None, [fit])


def _solutions_of(search: ManoeuvreSearch, res: ManoeuvreEstimate, others: list[OrderFit],
                 ref: float, selection: OrderSelection | None, fits: list[OrderFit]
                 ) -> list[Solution]:
    """Give the separated solutions among the search's fits (empty when ``res`` is the one)."""
    if not res.converged:
        return []
    alternatives = [report(search, f, ref, selection, fits) for f in others
                    if np.isfinite(f.chi2)]
    found = separated_solutions(res, alternatives, search.meas,
                                price=unknown_price(search.s, search.problem(0).noise.rank))
    return found if len(found) > 1 else []


def _wider(wider: ManoeuvreEstimate, res: ManoeuvreEstimate, meas: MeasurementSet
           ) -> ManoeuvreEstimate | None:
    """Give the widest model's fit when it leaves the final position undetermined, not ``res``."""
    if (not res.converged or wider.status == DIVERGED
            or not res.answer(meas).position_determined):
        return None
    return wider if wider_undetermined(wider, meas) else None


def _search_orders(search: ManoeuvreSearch, ref: float) -> ManoeuvreEstimate:
    """Fit every order the data span holds, select the accelerations, choose the order."""
    s = search.s
    n = search.problem(0).noise.rank
    top = search.max_order()
    note = ""
    if top < s.max_manoeuvres:
        note = (f"the data span {search.t_end - search.t0:g} s holds at most {top} "
                f"manoeuvres {s.min_segment:g} s apart on a {s.grid_step:g} s grid")
        if s.exact:
            raise ValueError(note)
    full = [search.fit_zero()]  # every acceleration fitted: the warm starts of the search
    for m in range(1, top + 1):
        full.append(search.fit(m, full[-1]))
    fits = list(full)
    if s.accelerations == "select":
        for i in (range(len(full)) if not s.exact else [len(full) - 1]):
            fits[i] = sparsify(search, full[i])
    if s.exact:
        chosen = fits[-1]
        selection = None
    else:
        selection = select_order(fits, n, s.criterion, s.alpha)
        chosen = fits[selection.chosen]
    res = report(search, chosen, ref, selection, fits)
    others = [f for f in (*fits, *full, *(a for f in {id(f): f for f in (*full, *fits)}
                                               .values() for a in f.alternatives))
              if f is not chosen]
    res.solutions = _solutions_of(search, res, others, ref, selection, fits)
    if full[-1] is not chosen:
        res.wider = _wider(report(search, full[-1], ref, selection, fits), res, search.meas)
    if selection is not None and top and selection.chosen == top == s.max_manoeuvres:
        more = (f"the largest number of manoeuvres tried ({top}) was chosen: more may fit "
                f"better (try curvilinear:{top + 1})")
        note = f"{note}; {more}" if note else more
    if note:
        res.message = f"{res.message}; {note}" if res.message else note
    return res


def estimate_manoeuvres(meas: MeasurementSet, max_manoeuvres: int = 2, *,
                        exact: bool = False, criterion: str = "bic", alpha: float = 0.01,
                        accelerations: str | None = None, ref_time: float | None = None,
                        init: Mapping[str, float] | ArrayLike | None = None,
                        options: Mapping[str, Mapping[str, object]] | None = None,
                        known_nuisance: KnownNuisanceLike = None,
                        settings: ManoeuvreSettings | None = None) -> ManoeuvreEstimate:
    """Estimate piecewise curvilinear motion by maximum likelihood, no initial guess needed.

    Parameters
    ----------
    meas : MeasurementSet
    max_manoeuvres : int
        The most manoeuvres tried (orders ``0 .. max_manoeuvres``).
    exact, criterion, alpha, accelerations, options, known_nuisance, settings : optional
        As for :func:`tmakit.batch.estimate` (``accelerations``: default ``settings``').
    ref_time : float, optional
        Reference time of the reported state, s; default the first measurement time.
    init : mapping or array_like, optional
        Parameters at ``ref_time``, SI: that order alone is fitted from it.

    Returns
    -------
    ManoeuvreEstimate

    Raises
    ------
    ValueError
        For an empty set, bad settings, a bad ``init``, or ``exact`` with more manoeuvres than
        the span holds.
    """
    base = settings or ManoeuvreSettings()
    s = replace(base, max_manoeuvres=max_manoeuvres, exact=exact, criterion=criterion,
                alpha=alpha, accelerations=accelerations or base.accelerations)
    if len(meas) == 0:
        raise ValueError("the measurement set is empty")
    search = ManoeuvreSearch(meas, options, as_known_nuisance(known_nuisance), s)
    ref = search.t0 if ref_time is None else float(ref_time)
    if init is not None:
        return _fit_from_start(search, ref, init)
    return _search_orders(search, ref)


def estimate_for(meas: MeasurementSet, motion: PiecewiseCurvilinear | str,
                 init: Mapping[str, float] | ArrayLike | None = None,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 known_nuisance: KnownNuisanceLike = None,
                 max_iter: int = 100, *, exact: bool | None = None,
                 criterion: str | None = None, alpha: float | None = None,
                 accelerations: str | None = None, ref_time: float | None = None,
                 settings: ManoeuvreSettings | None = None) -> EstimateResult:
    """Estimate motion given by name or as a piecewise curvilinear model.

    Parameters
    ----------
    meas, motion, init, options, known_nuisance, max_iter
        As for :func:`tmakit.batch.estimate` (other motion names go to ``ml.estimate``).
    exact, criterion, alpha, accelerations, ref_time, settings : optional
        As for :func:`tmakit.batch.estimate`.

    Returns
    -------
    EstimateResult

    Raises
    ------
    TypeError
        For manoeuvre settings with a motion without manoeuvres.
    ValueError
        For an unknown motion name, and as :func:`estimate_manoeuvres`.
    """
    given = {k: v for k, v in (("exact", exact), ("criterion", criterion), ("alpha", alpha),
                               ("accelerations", accelerations), ("settings", settings))
             if v is not None}
    if isinstance(motion, str):
        ref = ref_time
        model = motion_from_name(motion, default_ref_time(meas.time) if ref is None
                                 else float(ref))
        if not isinstance(model, PiecewiseCurvilinear):
            refuse_manoeuvre_options(given, motion)
            from .ml import estimate

            return estimate(meas, model, init=init, options=options,
                            known_nuisance=known_nuisance, max_iter=max_iter)
        m = model.manoeuvres
    else:
        m, ref = motion.manoeuvres, motion.ref_time if ref_time is None else ref_time
    search = replace(settings or ManoeuvreSettings(), max_iter=max_iter)
    return estimate_manoeuvres(
        meas, m, exact=bool(exact), criterion="bic" if criterion is None else criterion,
        alpha=0.01 if alpha is None else alpha, accelerations=accelerations, ref_time=ref,
        init=init, options=options, known_nuisance=known_nuisance, settings=search)


@dataclass(frozen=True, eq=False)
class ManoeuvreEstimator(BatchEstimator):
    """Maximum likelihood for a manoeuvring target, ``0..M`` manoeuvres, no initial guess.

    Parameters
    ----------
    init, options, known_nuisance, max_iter, exact, criterion, alpha : optional
        As for :func:`tmakit.batch.estimate`.
    accelerations, ref_time, settings : optional
        As for :func:`tmakit.batch.estimate`.
    """

    init: Init = None
    options: Options = None
    known_nuisance: KnownNuisanceLike = None
    max_iter: int = 100
    exact: bool | None = None
    criterion: str | None = None
    alpha: float | None = None
    accelerations: str | None = None
    ref_time: float | None = None
    settings: ManoeuvreSettings | None = None

    name: ClassVar[str] = "ml"
    takes_known_nuisance: ClassVar[bool] = True

    def __post_init__(self) -> None:
        """Convert ``known_nuisance``."""
        object.__setattr__(self, "known_nuisance", as_known_nuisance(self.known_nuisance))

    def fit(self, meas: MeasurementSet, motion: PiecewiseCurvilinear | str  # type: ignore[override]
            ) -> EstimateResult:
        """Estimate the manoeuvring target's motion."""
        return estimate_for(meas, motion, init=self.init, options=self.options,
                            known_nuisance=self.known_nuisance,
                            max_iter=self.max_iter, exact=self.exact,
                            criterion=self.criterion, alpha=self.alpha,
                            accelerations=self.accelerations, ref_time=self.ref_time,
                            settings=self.settings)
