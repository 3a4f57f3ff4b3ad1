"""The change-over-time search of the manoeuvre estimator (:mod:`tmakit.batch.manoeuvre`).

Its settings (:class:`ManoeuvreSettings`) and each order's fit (:class:`OrderFit`); the profile
grid of the change-over times (tuples of grid times, their local minima, the warm start that
splits a segment in two); every fit a run of :func:`tmakit.batch.solver.levenberg_marquardt`
with the search's damping and stopping rules (:func:`lm_fit`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from contextlib import nullcontext
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...core import blas
from ...core.arrays import Array
from ...data import MeasurementSet
from ...motion import ConstantVelocity
from ...motion.curvilinear import ForwardPiecewise
from ...observation import ObservationModel
from ...results.nuisance import KnownNuisance
from ..solver import SolveResult, VarProProblem, levenberg_marquardt

CRITERIA = ("bic", "lrt")
"""Criteria for the number of manoeuvres and the accelerations held."""
ACCELERATIONS = ("select", "all")
"""How the accelerations are fitted (see :class:`ManoeuvreSettings`)."""


@dataclass(frozen=True)
class ManoeuvreSettings:
    """How the manoeuvre estimator searches (times in seconds).

    Parameters
    ----------
    max_manoeuvres : int
        The largest order tried.
    exact : bool
        Fit only ``max_manoeuvres``.
    criterion : {"bic", "lrt"}
        How the order and the held accelerations are chosen.
    alpha : float
        Level of the likelihood-ratio tests, in (0, 1).
    grid_step : float
        Spacing of the profile grid, s.
    min_segment : float
        Shortest segment, and the grid's distance from the data's ends, s.
    refine : int
        Profile minima refined per order.
    profile_iter : int
        Iterations of each held fit.
    max_tuples : int
        Beyond this many grid tuples only those extending the order below's best minima are fitted.
    prune : float
        Held fits stop once they cannot come within this (half chi2) of the best.
    polish_step, polish_rounds : float, int
        The finer profile after refinement (s; 0 rounds: none).
    max_iter : int
        Iterations of a refinement with every parameter free.
    accelerations : {"select", "all"}
        Hold unneeded accelerations at zero (default), or fit all.

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
    manoeuvres : int
    theta : ndarray
        Internal parameters (at the first measurement time), SI.
    nuisance : ndarray
    chi2 : float
    unknowns : int
        Motion and nuisance parameters fitted.
    converged : bool
    iterations : int
    starts : int
        Starts of the final refinement.
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
    free: NDArray[np.bool_] | None = None  # internal parameters fitted; None: all
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
    where = {tuple(t): i for i, t in enumerate(tuples)}
    keep = []
    for i, t in enumerate(tuples):
        if not np.isfinite(cost[i]):
            continue
        ok = True
        for k in range(tuples.shape[1]):
            for d in (-1, 1):
                nb = list(t)
                nb[k] += d
                other = where.get(tuple(nb))
                if other is not None and cost[other] < cost[i]:
                    ok = False
        if ok:
            keep.append(i)
    keep_arr = np.array(keep, dtype=np.int64)
    return keep_arr[np.argsort(cost[keep_arr])] if keep_arr.size else keep_arr


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
    """The fits of every order for one data set (shared grid, warm starts between orders).

    Internal parameters are those of ``ForwardPiecewise`` referenced at the first measurement
    time; each order is the weighted least-squares fit of Hörst & Oispuu (2010), eq. 8.
    """

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
            from ..ml import estimate as estimate_cv

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
