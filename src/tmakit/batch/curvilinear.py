"""Maximum likelihood for a manoeuvring target: piecewise curvilinear motion with an unknown
number of manoeuvres at unknown times (002_e7269ad11b825346.txt §2, eqs. 1-5, 8).

``estimate_manoeuvres(meas, max_manoeuvres=2)`` fits the models with ``M = 0, 1, ...,
max_manoeuvres`` manoeuvres, no initial guess needed, and chooses ``M`` by a stated criterion.

**The fit for one order M** (the ML estimate is the weighted least-squares fit, 002 eq. 8; any
nuisance parameters — carrier, power constant — are eliminated exactly as in
:mod:`tmakit.batch.solver`):

1. ``M = 0`` starts from tmakit's no-guess constant-velocity fit
   (:func:`tmakit.batch.ml.estimate` with ``cv2d``), whose position, speed and course at the
   first measurement time start a curvilinear fit with zero accelerations.
2. ``M >= 1``: the change-over times are found by **profile likelihood over a grid**.  Every
   ordered tuple ``t_1 < ... < t_M`` of grid times (``grid_step`` apart, at least
   ``min_segment`` from the ends of the data and from each other) gets a fit of all other
   parameters with the change-over times held; the fits run in one batch.  Each is
   warm-started from the order ``M - 1`` profile fit at the tuple with one time removed (the
   best of the ``M`` such tuples), the removed segment split in two with equal accelerations,
   so the start reproduces that fit exactly and the held fit can only improve on it.
3. The best ``refine`` local minima of the profile are **refined with every parameter free**
   (Levenberg–Marquardt, change-over times included; they stay inside the data span and in
   order), together with the order ``M - 1`` fit with its longest segment split in two (the
   same trajectory, so chi2 never grows with the order).  The lowest cost wins.  A finer
   profile of each change-over time around it (4 s steps within one grid step) then catches
   the neighbouring dips of a likelihood that has a corner at every measurement time
   (:meth:`_Search._polish`, :meth:`_Search._settle`).

The likelihood is continuous in the change-over times (position and velocity are continuous
through a change-over; only the acceleration jumps).  Bearings alone make it once
differentiable too, but a predicted azimuth rate depends on the velocity at its sample, whose
derivative with respect to ``t_m`` jumps as ``t_m`` crosses the sample: the likelihood has a
corner at every measurement time and is bumpy on that scale near its minimum.  The grid only
has to land in the right basin (its 40 s spacing is 2-4 times the change-over times' CRB in the
002 scenario, 10-19 s); the refinement, the finer profile and the corner test do the rest.
The search is tested against fits started at the truth in
``benchmarks/montecarlo_hoerst2010.py``.

**The order.**  The models are nested (``M`` manoeuvres contain ``M - 1`` as equal neighbouring
accelerations), each manoeuvre adds three unknowns ``a_t, a_n, t_m``.  Two criteria:

* ``"bic"`` (default): minimise ``chi2_M + k_M ln N`` (Schwarz's Bayesian information
  criterion; ``k_M`` unknowns, ``N`` independent measurements) — a manoeuvre must lower chi2
  by ``3 ln N`` (22.5 for the 1802 measurements of the 002 scenario).
* ``"lrt"``: sequential likelihood-ratio tests: ``M + 1`` replaces ``M`` while
  ``chi2_M - chi2_{M+1}`` exceeds the ``1 - alpha`` quantile of chi-square with 3 degrees of
  freedom.  The reference distribution is approximate: under ``M`` the extra change-over time
  is not identified (Davies' problem), and the supremum over it makes the statistic larger than
  chi-square(3), so the test is liberal (it finds spurious manoeuvres more often than
  ``alpha``).  BIC's threshold is well above that supremum for realistic data sizes.

**The accelerations** (``accelerations="select"``, the default).  Each segment's ``a_t`` and
``a_n`` are unknowns of 002's model, but most legs are straight or turn at constant speed.
After each order's fit, the components the data do not need are held at zero by backward
elimination with the same criterion — one unknown fewer must not raise chi2 by ``ln N`` (BIC)
or by the chi-square(1) quantile (likelihood-ratio test) — and the change-over times are then
profiled again (:meth:`_Search.sparsify`).  It matters: with every acceleration free, a turn
that ends earlier and continues as a gentle turn competes with the true one, and in the 002
scenario the ML change-over times missed their CRB (RMSE 1.6x and 2.2x it); with the
components selected they are at 0.72x and 0.52x it, and within 1.11x of the bound of the
selected model in the runs that select the truth's zeros (``docs/estimation.md``).
``"all"`` fits every component (002 as written).  Held components are listed in the result
(``held``), with value and std 0; the covariance is the inverse information of the fitted
ones.

Every order's chi2, number of unknowns, BIC, likelihood-ratio statistic and p-value are
reported, with the chosen ``M``.  The covariance of the chosen fit is the inverse Fisher
information at the estimate (002 eq. 9, computed with :mod:`tmakit.bounds.fim`), so each
change-over time comes with its standard deviation, and so does the position at any time
(the delta method, :meth:`tmakit.bounds.fim.Bound.derived`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2 as chi2_dist

from ..data import MeasurementSet
from ..motion import ConstantVelocity, PiecewiseCurvilinear
from ..motion.curvilinear_batch import ForwardPiecewise, gram
from ..motion.fixed import FixedParameters
from ..observation import ObservationModel
from ..results.bound import bound_from_information
from ..results.estimate import CONVERGED, DIVERGED, NOT_CONVERGED, UNOBSERVABLE, EstimateResult
from .solver import VarProProblem, levenberg_marquardt

Array = NDArray[np.float64]

CRITERIA = ("bic", "lrt")
ACCELERATIONS = ("select", "all")  # see ManoeuvreSettings
_CHUNK = 256  # held fits per batch on the profile grid
_PROBES = (-3.0, -2.0, -1.0, -0.5, -0.05, 0.05, 0.5, 1.0, 2.0, 3.0)  # s, see _Search._settle


@dataclass(frozen=True)
class ManoeuvreSettings:
    """How the manoeuvre estimator searches (times in seconds).

    ``max_manoeuvres``: the largest order tried (0, 1, ..., max).  ``exact``: fit only
    ``max_manoeuvres``.  ``criterion``: ``"bic"`` or ``"lrt"`` (see the module docstring),
    ``alpha`` the level of the likelihood-ratio tests.  ``grid_step``: spacing of the profile
    grid; ``min_segment``: shortest segment on the grid (and the grid's distance from the ends
    of the data).  ``refine``: profile minima refined per order.  ``profile_iter``: iterations
    of each held fit on the grid.  ``max_tuples``: an order whose grid holds more
    tuples than this is searched only on the tuples that add one grid time to one of the best
    ``refine`` profile minima of the order below.  ``prune``:
    held fits on the grid stop once they cannot come within this much (half chi2) of the
    best grid point (see :func:`_lm`).  ``polish_step``, ``polish_rounds``: the finer
    profile of each change-over time after the refinement (:meth:`_Search._polish`; 0 rounds:
    none).  ``accelerations``: ``"select"`` (default) holds at zero every acceleration
    component the data do not need, by the order criterion (:meth:`_Search.sparsify`);
    ``"all"`` fits every component of every segment.
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
    """The best fit with ``manoeuvres`` manoeuvres (internal parameters: referenced at the
    first measurement time)."""

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

    def free_mask(self) -> NDArray[np.bool_]:
        """Which internal parameters are fitted (the others are accelerations held at 0)."""
        return np.ones(self.theta.shape[0], dtype=bool) if self.free is None else self.free


@dataclass
class OrderSelection:
    """Chi2 and the criteria of every order tried, and the order chosen."""

    criterion: str
    alpha: float
    n_measurements: int
    orders: list[dict[str, float | int | None]]
    chosen: int

    def as_dict(self) -> dict[str, object]:
        def clean(v: object) -> object:
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {"criterion": self.criterion, "alpha": self.alpha if self.criterion == "lrt"
                else None, "n_measurements": self.n_measurements, "chosen": self.chosen,
                "orders": [{k: clean(v) for k, v in o.items()} for o in self.orders]}

    def summary(self) -> str:
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


@dataclass
class ManoeuvreEstimate(EstimateResult):
    """An :class:`~tmakit.batch.ml.EstimateResult` for the chosen number of manoeuvres, with
    the model-order selection (``selection``), every order's fit (``fits``) and the state at
    the last measurement time (``final``: ``{name: (value, std)}``, SI)."""

    selection: OrderSelection | None = None
    fits: list[OrderFit] = field(default_factory=list)
    held: list[str] = field(default_factory=list)
    final_time: float = float("nan")
    final: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def manoeuvres(self) -> int:
        return int(getattr(self.motion, "manoeuvres", 0))

    def change_over_times(self) -> list[tuple[float, float]]:
        """``(value, std)`` of every change-over time (s)."""
        return [(float(self.estimate[i]), float(self.std[i]))
                for i, n in enumerate(self.parameters) if n.startswith("t_")]

    def as_dict(self) -> dict[str, object]:
        data = super().as_dict()

        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        data["manoeuvres"] = self.manoeuvres
        data["held_at_zero"] = list(self.held)
        data["model_order"] = self.selection.as_dict() if self.selection else None
        data["change_over_times"] = [{"value": num(v), "std": num(s)}
                                     for v, s in self.change_over_times()]
        data["final_state"] = {"time": num(self.final_time),
                               **{k: {"value": num(v), "std": num(s)}
                                  for k, (v, s) in self.final.items()}}
        return data

    def summary(self) -> str:
        parts = [super().summary()]
        if self.selection is not None:
            parts.append(self.selection.summary())
        if self.final:
            x, sx = self.final["x"]
            y, sy = self.final["y"]
            parts.append(f"position at t = {self.final_time:g} s: x = {x:.1f} m (std "
                         f"{sx:.3g}), y = {y:.1f} m (std {sy:.3g})")
        return "\n".join(parts)


# ------------------------------------------------------------------------------------------
# fits with the change-over times held (the profile likelihood)
# ------------------------------------------------------------------------------------------


@dataclass
class _Fits:
    theta: Array
    nuisance: Array
    cost: Array
    converged: NDArray[np.bool_]
    iterations: NDArray[np.int64]


def _lm(problem: VarProProblem, y: Array, theta0: Array, free: Array, max_iter: int,
        rtol: float = 1e-3, atol: float = 0.02, prune: float | None = None,
        best: float = np.inf, max_reject: int = 40, stall: float = 0.0) -> _Fits:
    """Batched Levenberg–Marquardt (Marquardt's scaling, as :func:`tmakit.batch.solver.
    levenberg_marquardt`) over the columns ``free`` only, the others held, for grouped data
    ``y`` ``(n,)`` and starts ``theta0`` ``(B, p)``.

    Converged: the Gauss–Newton decrement (the cost decrease an undamped step predicts) below
    ``rtol * cost + atol``.  The default (within ~0.05 of the held minimum in chi2) suffices to
    rank grid points; refinements ask for ``rtol=1e-10, atol=1e-7`` as the house solver.  A fit
    stops unconverged after ``max_reject`` rejected steps in a row: on a corner of the
    likelihood (see :meth:`_Search._settle`) no damping helps, and waiting for the damping to
    grow by 1e15 costs ~25 evaluations.  With ``stall`` > 0 a fit also stops once six
    iterations in a row lowered its cost by less than ``stall`` in all (a fit creeping along
    corners, or along the flat valley of a change-over time the data hardly see).

    ``prune`` (a cost, half chi2): a fit stops early once even twice its Gauss–Newton
    decrement could not bring it within ``prune`` of the best current cost of the batch (or
    ``best``, a cost reached elsewhere) — it cannot be a profile minimum that matters, and its
    current cost (an upper bound) is kept."""
    theta = np.array(theta0, dtype=float)
    b = theta.shape[0]
    yb = np.broadcast_to(y, (b, y.shape[-1]))
    nu_star = problem.reference_nuisance(yb)
    cur = problem.evaluate(theta, yb, nu_star)
    lam = np.full(b, 1e-3)
    active = np.isfinite(cur.cost)
    converged = np.zeros(b, dtype=bool)
    iterations = np.zeros(b, dtype=np.int64)
    rejected = np.zeros(b, dtype=np.int64)
    history = [cur.cost.copy()]
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        jr = cur.jacobian[idx][:, :, free]
        r = cur.residual[idx]
        jtj = gram(jr)
        grad = (np.swapaxes(jr, 1, 2) @ r[..., None])[..., 0]
        scale = np.sqrt(np.maximum(np.diagonal(jtj, axis1=1, axis2=2), 1e-300))
        w, v = np.linalg.eigh(jtj / (scale[:, :, None] * scale[:, None, :]))
        w = np.maximum(w, 1e-12 * w[:, -1:])
        vg = np.einsum("bpq,bp->bq", v, grad / scale)
        lam_i = lam[idx]
        step = np.einsum("bpq,bq->bp", v, vg / (w + lam_i[:, None])) / scale
        decrement = 0.5 * np.sum(vg * vg / w, axis=1)
        done = decrement <= rtol * cur.cost[idx] + atol
        converged[idx[done]] = True
        active[idx[done]] = False
        keep = ~done
        if prune is not None:
            top = min(best, float(np.min(cur.cost)))
            hopeless = cur.cost[idx] - 2.0 * decrement > top + prune
            active[idx[hopeless & keep]] = False
            keep &= ~hopeless
        idx, step, lam_i = idx[keep], step[keep], lam_i[keep]
        if idx.size == 0:
            break
        full = np.zeros((idx.size, theta.shape[1]))
        full[:, free] = step
        trial = problem.evaluate(cur.theta[idx] + full, yb[idx], nu_star[idx])
        better = trial.cost < cur.cost[idx]
        where = idx[better]
        cur.theta[where] = trial.theta[better]
        cur.nuisance[where] = trial.nuisance[better]
        cur.residual[where] = trial.residual[better]
        cur.cost[where] = trial.cost[better]
        cur.jacobian[where] = trial.jacobian[better]
        iterations[idx] += 1
        lam[idx] = np.where(better, np.maximum(lam_i / 3.0, 1e-12), lam_i * 4.0)
        rejected[idx] = np.where(better, 0, rejected[idx] + 1)
        active[idx] = (rejected[idx] < max_reject) & (lam[idx] <= 1e12)
        history.append(cur.cost.copy())
        if stall > 0 and len(history) > 6:
            with np.errstate(invalid="ignore"):  # inf - inf: a start that never had a cost
                active &= ~(history[-7] - history[-1] < stall)
    return _Fits(cur.theta, cur.nuisance, cur.cost, converged, iterations)


def _grid_tuples(grid: Array, m: int, min_gap: float) -> NDArray[np.int64]:
    """Index tuples ``i_1 < ... < i_m`` into ``grid`` whose times are ``min_gap`` apart."""
    if m == 0:
        return np.zeros((1, 0), dtype=np.int64)
    out = [c for c in itertools.combinations(range(grid.size), m)
           if m == 1 or np.all(np.diff(grid[list(c)]) >= min_gap - 1e-9)]
    return np.array(out, dtype=np.int64).reshape(-1, m)


def _split(theta: Array, m_prev: int, j: int, t_new: Array) -> Array:
    """Insert change-over time ``t_new`` as the ``j``-th (0-based) into fits with ``m_prev``
    manoeuvres ``(B, p)``, splitting segment ``j`` into two with its accelerations: the
    trajectory is unchanged."""
    b = theta.shape[0]
    acc = theta[:, 4:6 + 2 * m_prev].reshape(b, m_prev + 1, 2)
    acc = np.concatenate([acc[:, :j + 1], acc[:, j:j + 1], acc[:, j + 1:]], axis=1)
    times = np.insert(theta[:, 6 + 2 * m_prev:], j, t_new, axis=1)
    return np.concatenate([theta[:, :4], acc.reshape(b, -1), times], axis=1)


def _local_minima(tuples: NDArray[np.int64], cost: Array) -> NDArray[np.int64]:
    """Rows of ``tuples`` whose cost is at most that of every grid neighbour (one index
    moved by one), best first."""
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


# ------------------------------------------------------------------------------------------
# the search over orders
# ------------------------------------------------------------------------------------------


def _may_hold(free: NDArray[np.bool_], i: int, m: int) -> bool:
    """Whether acceleration ``i`` (internal index, ``4 + 2 * segment + {0: a_t, 1: a_n}``) may
    be held at zero: not if a neighbouring segment would then also have both held — a
    change-over between two straight legs is no manoeuvre."""
    mask = free.copy()
    mask[i] = False
    seg = (i - 4) // 2
    both_held = [not mask[4 + 2 * s] and not mask[5 + 2 * s] for s in range(m + 1)]
    return not any(both_held[s] and both_held[seg] for s in (seg - 1, seg + 1) if 0 <= s <= m)


class _Search:
    """The fits of every order for one data set (shared grid, warm starts between orders)."""

    def __init__(self, meas: MeasurementSet, options, fixed_nuisance: Mapping | None,
                 settings: ManoeuvreSettings) -> None:
        self.meas = meas
        self.options = options
        self.fixed = fixed_nuisance
        self.s = settings
        self.t0 = float(meas.time.min())
        self.t_end = float(meas.time.max())
        lo, hi = self.t0 + settings.min_segment, self.t_end - settings.min_segment
        n = math.floor((hi - lo) / settings.grid_step + 1e-9) + 1 if hi >= lo else 0
        # the grid centred in the span
        pad = (hi - lo - (n - 1) * settings.grid_step) / 2.0 if n else 0.0
        self.grid = lo + pad + settings.grid_step * np.arange(max(n, 0))
        self.min_gap = max(settings.min_segment, settings.grid_step)
        self._problems: dict[int, VarProProblem] = {}
        self.profiles: dict[int, tuple[NDArray[np.int64], Array, Array]] = {}

    def problem(self, m: int) -> VarProProblem:
        """The least-squares problem with ``m`` manoeuvres (internal parameters)."""
        if m not in self._problems:
            model = ForwardPiecewise(m, self.t0, end_time=self.t_end)
            obs = ObservationModel(self.meas, model, self.options)
            fixed = None if self.fixed is None else obs.nuisance_vector(self.fixed)
            self._problems[m] = VarProProblem(obs, None, fixed)
        return self._problems[m]

    def max_order(self) -> int:
        """The most manoeuvres the grid can hold."""
        m = 0
        while m < self.s.max_manoeuvres and _grid_tuples(self.grid, m + 1,
                                                         self.min_gap).shape[0] > 0:
            m += 1
        return m

    def unknowns(self, m: int, free: NDArray[np.bool_] | None = None) -> int:
        """Unknowns of the order ``m`` model: the fitted motion parameters (all, or those in
        ``free``) and the nuisance parameters unless they are known."""
        pr = self.problem(m)
        p = pr.p if free is None else int(np.count_nonzero(free))
        return p + (0 if pr.fixed is not None else pr.k)

    def fit_zero(self, init: Array | None = None) -> OrderFit:
        pr = self.problem(0)
        if init is None:
            from .ml import estimate as estimate_cv

            cv = estimate_cv(self.meas, ConstantVelocity(2, self.t0), options=self.options,
                             known_nuisance=self.fixed)
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

    def profile(self, m: int) -> tuple[NDArray[np.int64], Array, Array]:
        """Held fits on the grid tuples of order ``m`` (needs the order ``m - 1`` profile):
        all of them, or, beyond ``max_tuples``, those extending the best ``refine`` minima of
        order ``m - 1`` by one grid time."""
        tuples = _grid_tuples(self.grid, m, self.min_gap)
        prev_idx, prev_theta, prev_cost = self.profiles[m - 1]
        if tuples.shape[0] > self.s.max_tuples:
            seeds = prev_idx[_local_minima(prev_idx, prev_cost)[: self.s.refine]]
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
                cand = _split(prev_theta[rows[better]], m - 1, j, self.grid[tuples[better, j]])
                start[better] = cand
                best_cost[better] = cost[better]
        ok = np.flatnonzero(np.isfinite(best_cost))
        pr = self.problem(m)
        y = pr.group(pr.obs.values)
        free = np.ones(pr.p, dtype=bool)
        free[6 + 2 * m:] = False
        theta = np.full_like(start, np.nan)
        cost = np.full(tuples.shape[0], np.inf)
        best = np.inf
        for a in range(0, ok.size, _CHUNK):  # chunks bound the memory: (chunk, n, p) arrays
            rows = ok[a:a + _CHUNK]
            sol = _lm(pr, y, start[rows], free, self.s.profile_iter, prune=self.s.prune,
                      best=best)
            theta[rows], cost[rows] = sol.theta, sol.cost
            best = min(best, float(np.min(sol.cost)))
        self.profiles[m] = (tuples, theta, cost)
        return tuples, theta, cost

    def fit(self, m: int, below: OrderFit | None = None) -> OrderFit:
        """The order ``m`` fit: profile, refinement of its best minima and, given the order
        ``m - 1`` fit ``below``, of that fit with its longest segment split in two (equal
        accelerations: the same trajectory), so that chi2 never grows with the order."""
        tuples, theta, cost = self.profile(m)
        minima = _local_minima(tuples, cost)[: self.s.refine]
        if minima.size == 0:
            raise ValueError(f"no finite profile fit with {m} manoeuvres")
        starts = theta[minima]
        if below is not None and np.all(np.isfinite(below.theta)):
            edges = np.concatenate([[self.t0], below.theta[6 + 2 * (m - 1):], [self.t_end]])
            j = int(np.argmax(np.diff(edges)))
            nested = _split(below.theta[None], m - 1, j, np.array([edges[j:j + 2].mean()]))
            starts = np.concatenate([starts, nested])
        fit = self.fit_from(m, starts)
        if self.s.polish_rounds:
            fit = self._polish(fit)
        fit.profile_times, fit.profile_chi2 = self.grid[tuples], 2.0 * cost
        return fit

    def _polish(self, fit: OrderFit, reach: float | None = None) -> OrderFit:
        """Finer profiles of each change-over time around the refined fit.

        The likelihood has a corner at every measurement time (see :meth:`_settle`), so
        near its minimum it is bumpy on the scale of the sampling interval and the refinement
        can stop in a dip next to the deepest one.  Each ``t_m`` in turn is held on a grid of
        ``polish_step`` spacing within ``grid_step`` of its estimate (every other parameter,
        the other change-over times included, free: its profile likelihood); if a grid point
        beats the fit, everything is refined again from it.  At most ``polish_rounds``
        rounds.  ``reach`` (s) widens the held grid (default ``grid_step``); parameters the
        fit holds stay held."""
        m = fit.manoeuvres
        if m == 0 or not np.isfinite(fit.chi2):
            return fit
        pr = self.problem(m)
        y = pr.group(pr.obs.values)
        k0 = 6 + 2 * m
        reach = self.s.grid_step if reach is None else reach
        offsets = np.arange(-reach, reach + 1e-9, self.s.polish_step)
        offsets = offsets[offsets != 0.0]
        for _ in range(self.s.polish_rounds):
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
            if not starts:
                break
            start = np.array(starts)
            held_k = np.array(held)
            best_theta, best_cost = None, fit.chi2 / 2.0
            for k in range(m):  # one batch per held time (the free columns differ)
                rows = np.flatnonzero(held_k == k)
                if rows.size == 0:
                    continue
                free = fit.free_mask().copy()
                free[k0 + k] = False
                sol = _lm(pr, y, start[rows], free, self.s.profile_iter, prune=self.s.prune)
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

    def sparsify(self, fit: OrderFit) -> OrderFit:
        """The accelerations the data need (the ``accelerations="select"`` setting).

        Backward elimination: each step holds at zero, in turn, every acceleration component
        still fitted (every other parameter refitted, change-over times included, from the
        fit and from starts with the change-over times bounding its segment moved by one
        ``grid_step`` either way), and keeps the hold that raises chi2 least if the rise is
        below the criterion's price of one unknown: ``ln N`` for BIC, the chi-square(1) quantile
        ``1 - alpha`` for the likelihood-ratio test.  Two neighbouring segments are never
        both held at zero (their change-over time would not exist).  After any hold, each
        change-over time is profiled again within two grid steps (:meth:`_polish`): with
        fewer accelerations the likelihood in ``t_m`` has fewer competing basins, and its
        best one can move.

        Why: a turn that ends at ``t_m`` and one that ends earlier and continues as a gentle
        turn fit nearly as well when the last leg's accelerations are free, and in the 002
        scenario the ML change-over time picks the wrong one in ~1 run in 5 (see
        ``docs/estimation.md``)."""
        m = fit.manoeuvres
        if not np.isfinite(fit.chi2):
            return fit
        pr = self.problem(m)
        y = pr.group(pr.obs.values)
        n = pr.noise.rank
        price = (math.log(n) if self.s.criterion == "bic"
                 else float(chi2_dist.ppf(1.0 - self.s.alpha, 1)))
        k0 = 6 + 2 * m
        free = fit.free_mask().copy()
        current, held = fit, False
        while True:
            best: tuple[float, int, Array, Array] | None = None
            for i in range(4, k0):
                if not free[i] or not _may_hold(free, i, m):
                    continue
                mask = free.copy()
                mask[i] = False
                starts = self._hold_starts(current.theta, i, m)
                # ranking holds needs chi2 to ~0.04; a start that cannot come within the
                # price of the current fit is dropped early
                sol = _lm(pr, y, starts, mask, 30, rtol=0.0, atol=0.02, max_reject=8,
                          stall=1e-2, prune=price / 2.0, best=current.chi2 / 2.0)
                j = int(np.argmin(np.where(np.isfinite(sol.cost), sol.cost, np.inf)))
                if best is None or 2.0 * sol.cost[j] < best[0]:
                    best = (float(2.0 * sol.cost[j]), i, sol.theta[j], sol.nuisance[j])
            if best is None or not best[0] - current.chi2 < price:
                break
            free[best[1]] = False
            current = OrderFit(m, best[2], best[3], best[0], self.unknowns(m, free), False,
                               current.iterations, current.starts, free=free.copy())
            held = True
        if not held:
            return fit
        out = self.fit_from(m, current.theta[None], free)
        out.iterations += fit.iterations
        if self.s.polish_rounds and m:
            out = self._polish(out, reach=2.0 * self.s.grid_step)
        out.profile_times, out.profile_chi2 = fit.profile_times, fit.profile_chi2
        return out

    def _hold_starts(self, theta: Array, i: int, m: int) -> Array:
        """Starts for a fit with acceleration ``i`` held at zero: ``theta`` with it zeroed,
        and with each change-over time bounding its segment moved by one grid step either
        way (kept in order and inside the data span)."""
        base = theta.copy()
        base[i] = 0.0
        out = [base]
        seg = (i - 4) // 2
        k0 = 6 + 2 * m
        for k in (seg - 1, seg):  # change-over times t_seg (index seg - 1) and t_{seg+1}
            if not 0 <= k < m:
                continue
            lo = theta[k0 + k - 1] if k else self.t0
            hi = theta[k0 + k + 1] if k + 1 < m else self.t_end
            for d in (-1.0, 1.0):
                t = theta[k0 + k] + d * self.s.grid_step
                if lo + self.s.min_segment / 2 < t < hi - self.s.min_segment / 2:
                    q = base.copy()
                    q[k0 + k] = t
                    out.append(q)
        return np.array(out)

    def fit_from(self, m: int, theta0: Array, free: NDArray[np.bool_] | None = None
                 ) -> OrderFit:
        """Every parameter (or those in ``free``, the others held) fitted from the starts
        ``theta0`` ``(B, p)``; the lowest cost wins, settled at a corner of the likelihood if
        it ends on one (:meth:`_settle`)."""
        pr = self.problem(m)
        mask = np.ones(pr.p, dtype=bool) if free is None else free
        sol = _lm(pr, pr.group(pr.obs.values), np.atleast_2d(theta0), mask,
                  self.s.max_iter, rtol=1e-10, atol=1e-7, prune=self.s.prune, max_reject=8,
                  stall=1e-3)
        c = np.where(np.isfinite(sol.cost), sol.cost, np.inf)
        i = int(np.argmin(c))
        fit = OrderFit(m, sol.theta[i], sol.nuisance[i], float(2 * c[i]),
                       self.unknowns(m, free), bool(sol.converged[i]), int(sol.iterations[i]),
                       int(sol.theta.shape[0]), free=None if free is None else free.copy())
        if not fit.converged and m and np.isfinite(fit.chi2):
            self._settle(fit)
        return fit

    def _settle(self, fit: OrderFit, rounds: int = 8, tol: float = 1e-4) -> None:
        """A refinement that stopped without meeting the smooth convergence tests.

        The likelihood has a corner at every measurement time: a sample's predicted velocity
        (hence its azimuth rate) follows the old or the new acceleration depending on which
        side of ``t_m`` it lies, so the derivative with respect to ``t_m`` jumps there, and
        near its minimum Levenberg–Marquardt stops on or next to a corner, where its tests
        cannot be met.  The fit is accepted as converged when, the change-over times held, the
        other parameters converge and no held fit with one change-over time moved by
        :data:`_PROBES` (0.05 to 3 s either way) or onto the measurement time either side
        lowers chi2 by more than ``tol`` — far below anything that matters statistically.
        Otherwise everything is refined again from the best such fit, at most ``rounds``
        times."""
        m = fit.manoeuvres
        pr = self.problem(m)
        k0 = 6 + 2 * m
        y = pr.group(pr.obs.values)
        held_free = fit.free_mask().copy()
        held_free[k0:] = False
        samples = np.unique(self.meas.time)
        for _ in range(rounds):
            held = _lm(pr, y, fit.theta[None], held_free, 50, rtol=1e-10, atol=1e-7)
            if not held.converged[0]:
                break
            probes = []
            for k in range(m):
                t_k = held.theta[0, k0 + k]
                # the corners either side, and steps of 0.05 to 3 s
                below = samples[samples < t_k - 1e-6][-1:]
                above = samples[samples > t_k + 1e-6][:1]
                for target in (*(t_k + d for d in _PROBES), *below, *above):
                    q = held.theta[0].copy()
                    q[k0 + k] = target
                    probes.append(q)
            ps = _lm(pr, y, np.array(probes), held_free, 50, rtol=1e-10, atol=1e-7)
            c0 = float(held.cost[0])
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
            sol = _lm(pr, y, ps.theta[i][None], fit.free_mask(), self.s.max_iter,
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


def select_order(fits: list[OrderFit], n: int, criterion: str = "bic", alpha: float = 0.01
                 ) -> OrderSelection:
    """Choose the number of manoeuvres from fits of consecutive orders (see the module
    docstring): ``"bic"`` minimises ``chi2 + k ln n``; ``"lrt"`` adds a manoeuvre while the
    likelihood-ratio statistic exceeds the chi-square(3) quantile ``1 - alpha``."""
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
        bic = [o["bic"] if np.isfinite(o["chi2"]) else np.inf for o in orders]  # type: ignore
        chosen = fits[int(np.argmin(bic))].manoeuvres
    else:
        chosen = fits[0].manoeuvres
        for i in range(1, len(fits)):
            pv = orders[i]["p_value"]
            if pv is None or pv >= alpha:
                break
            chosen = fits[i].manoeuvres
    return OrderSelection(criterion, alpha, n, orders, chosen)


# ------------------------------------------------------------------------------------------
# the public entry points
# ------------------------------------------------------------------------------------------


def _reference(model: ForwardPiecewise, theta: Array, ref_time: float) -> Array:
    """The same trajectory in :class:`PiecewiseCurvilinear` parameters referenced at
    ``ref_time`` (course wrapped to (-pi, pi])."""
    state = model.segment_states(theta, np.array([ref_time]))[0]
    out = np.array(theta, dtype=float)
    out[:4] = state
    out[3] = (state[3] + math.pi) % (2 * math.pi) - math.pi
    if out[3] == -math.pi:
        out[3] = math.pi
    return out


def _report(search: _Search, fit: OrderFit, ref_time: float, selection: OrderSelection | None,
            fits: list[OrderFit]) -> ManoeuvreEstimate:
    """The chosen fit in the user's parameterisation, with its covariance (inverse Fisher
    information at the estimate, nuisance parameters included when unknown)."""
    m = fit.manoeuvres
    motion = PiecewiseCurvilinear(m, ref_time)
    pr = search.problem(m)
    known = pr.fixed is not None
    names_nu = pr.obs.nuisance_names
    n = pr.noise.rank
    theta = _reference(pr.obs.motion, fit.theta, ref_time)
    common = dict(method="ml", motion=motion, selection=selection, fits=fits,
                  final_time=search.t_end, iterations=fit.iterations, starts=fit.starts)
    if not np.all(np.isfinite(theta)) or not np.isfinite(fit.chi2):
        nan = np.full(motion.n_params, np.nan)
        return ManoeuvreEstimate(motion.param_names, nan, nan,
                                 np.full((motion.n_params,) * 2, np.nan),
                                 {k: (np.nan, np.nan) for k in names_nu}, DIVERGED,
                                 chi2=np.inf, dof=n - fit.unknowns,
                                 message="the solve left the region where the model is "
                                         "defined (non-finite predictions)", **common)
    obs = ObservationModel(search.meas, motion, search.options)
    j_theta, j_nu = obs.jacobian_grouped(theta, fit.nuisance)
    free = fit.free_mask()
    held = [n for n, f in zip(motion.param_names, free, strict=True) if not f]
    # the information of the fitted parameters only: a held acceleration is no unknown
    fitted = FixedParameters(motion, dict.fromkeys(held, 0.0)) if held else motion
    j_theta = j_theta[:, free]
    jac = j_theta if known else np.concatenate([j_theta, j_nu], axis=-1)
    w = pr.noise.whiten(jac, axis=-2)
    info = w.T @ w
    names = fitted.param_names + (() if known else names_nu)
    values = theta[free] if known else np.concatenate([theta[free], fit.nuisance])
    bound = bound_from_information(info, names, values, search.meas, fitted, known,
                                   dict(zip(names_nu, fit.nuisance, strict=True)))
    q = fitted.n_params
    nuis = {k: (float(fit.nuisance[i]), 0.0 if known else float(bound.std[q + i]))
            for i, k in enumerate(names_nu)}
    p = motion.n_params
    std = np.zeros(p)
    std[free] = bound.std[:q]
    cov = np.zeros((p, p))
    cov[np.ix_(free, free)] = bound.covariance[:q, :q]
    status = CONVERGED if fit.converged else NOT_CONVERGED
    message = ""
    if not bound.observability.full_rank:
        status = UNOBSERVABLE
        message = (f"the data determine only {bound.rank} of the {len(names)} unknowns; "
                   "parameters marked unobservable are not estimates")
    elif not fit.converged and not fit.note:
        message = "the iteration limit was reached before the convergence tests were met"
    if fit.note:
        message = f"{message}; {fit.note}" if message else fit.note
    if held:
        note = (f"held at zero as the data do not need them ({fit_criterion(search.s)}): "
                f"{', '.join(held)}")
        message = f"{message}; {note}" if message else note
    final = bound.derived(search.t_end)
    return ManoeuvreEstimate(motion.param_names, theta, std, cov, nuis, status,
                             chi2=fit.chi2, dof=n - len(names), bound=bound, message=message,
                             final=final, held=held, **common)


def fit_criterion(s: ManoeuvreSettings) -> str:
    """The rule that holds an acceleration at zero, in words."""
    return ("BIC: holding one raised chi2 by less than ln N" if s.criterion == "bic" else
            f"holding one raised chi2 by less than the chi-square(1) quantile "
            f"{1 - s.alpha:g}")


def estimate_manoeuvres(meas: MeasurementSet, max_manoeuvres: int = 2, *,
                        exact: bool = False, criterion: str = "bic", alpha: float = 0.01,
                        accelerations: str | None = None, ref_time: float | None = None,
                        init: Mapping[str, float] | ArrayLike | None = None,
                        options: Mapping[str, Mapping[str, object]] | None = None,
                        known_nuisance: Mapping[str, float] | None = None,
                        settings: ManoeuvreSettings | None = None) -> ManoeuvreEstimate:
    """Maximum-likelihood piecewise curvilinear motion with ``0 .. max_manoeuvres``
    manoeuvres (or exactly ``max_manoeuvres`` with ``exact=True``), no initial guess needed.

    ``criterion`` (``"bic"`` or ``"lrt"``) and ``alpha`` choose the order (module docstring).
    ``accelerations``: ``"select"`` holds at zero the acceleration components the data do
    not need, by the same criterion, ``"all"`` fits them all (default: ``settings``', which
    is ``"select"``); held ones are listed in the result's ``held``.
    ``ref_time`` (s) references the reported position, speed and course (default: the first
    measurement time).  ``init`` (by name or as a vector of ``curvilinear:max_manoeuvres``
    parameters referenced at ``ref_time``) fits exactly that order from that start, no search;
    its change-over times must lie inside the data span.  ``options`` and ``known_nuisance`` as
    for :func:`tmakit.batch.ml.estimate`.  ``settings`` overrides the search (grid spacing,
    shortest segment, ...); its order and criterion fields are replaced by the arguments.
    """
    from dataclasses import replace

    base = settings or ManoeuvreSettings()
    s = replace(base, max_manoeuvres=max_manoeuvres, exact=exact, criterion=criterion,
                alpha=alpha, accelerations=accelerations or base.accelerations)
    if len(meas) == 0:
        raise ValueError("the measurement set is empty")
    search = _Search(meas, options, known_nuisance, s)
    ref = search.t0 if ref_time is None else float(ref_time)
    n = search.problem(0).noise.rank
    if init is not None:
        m = s.max_manoeuvres
        user = PiecewiseCurvilinear(m, ref)
        theta0 = (user.theta(init) if isinstance(init, Mapping)
                  else np.asarray(init, dtype=float).reshape(-1))
        if theta0.shape != (user.n_params,):
            raise ValueError(f"init must give {user.n_params} values "
                             f"({', '.join(user.param_names)})")
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
            fit = search.sparsify(fit)
        return _report(search, fit, ref, None, [fit])
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
            fits[i] = search.sparsify(full[i])
    if s.exact:
        chosen = fits[-1]
        selection = None
    else:
        selection = select_order(fits, n, s.criterion, s.alpha)
        chosen = fits[selection.chosen]
    res = _report(search, chosen, ref, selection, fits)
    if selection is not None and top and selection.chosen == top == s.max_manoeuvres:
        more = (f"the largest number of manoeuvres tried ({top}) was chosen: more may fit "
                f"better (try curvilinear:{top + 1})")
        note = f"{note}; {more}" if note else more
    if note:
        res.message = f"{res.message}; {note}" if res.message else note
    return res


def parse_motion(motion: str) -> int:
    """The largest number of manoeuvres of a motion name: ``"curvilinear"`` -> 2,
    ``"curvilinear:M"`` -> M (both search 0..M)."""
    key = motion.strip().lower()
    rest = key[len("curvilinear"):] if key.startswith("curvilinear") else None
    if rest == "":
        return 2
    if rest is not None and rest[:1] == ":" and rest[1:].isdigit():
        return int(rest[1:])
    raise ValueError(f"motion {motion!r}: expected curvilinear (0 to 2 manoeuvres) or "
                     "curvilinear:M (0 to M manoeuvres, M a whole number)")


def estimate_for(meas: MeasurementSet, motion: PiecewiseCurvilinear | str,
                 init: Mapping[str, float] | ArrayLike | None = None,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 known_nuisance: Mapping[str, float] | None = None,
                 max_iter: int = 100, **kw: Any) -> EstimateResult:
    """The hook of :func:`tmakit.batch.ml.estimate` for motion given by name or as a
    :class:`PiecewiseCurvilinear`.

    A :class:`PiecewiseCurvilinear` with ``M`` manoeuvres searches ``0..M`` (parameters
    referenced at its reference time); ``"curvilinear:M"`` likewise (at ``ref_time`` if given,
    else the first measurement time) and ``"curvilinear"`` searches ``0..2``.  ``exact=True``
    fits exactly ``M``; with ``init`` exactly ``M`` is fitted from it.  Other keywords go to
    :func:`estimate_manoeuvres`.  Any other name (``"cv2d"``, ...) is the model of
    :func:`tmakit.motion.motion_from_name`, estimated by :func:`tmakit.batch.ml.estimate`."""
    if isinstance(motion, str) and not motion.strip().lower().startswith("curvilinear"):
        from ..motion import motion_from_name
        from .ml import estimate

        ref = kw.pop("ref_time", None)
        model = motion_from_name(motion, 0.0 if ref is None else float(ref))
        return estimate(meas, model, init=init, options=options,
                        known_nuisance=known_nuisance, max_iter=max_iter, **kw)
    if isinstance(motion, str):
        m = parse_motion(motion)
        ref = kw.pop("ref_time", None)
    else:
        m, ref = motion.manoeuvres, kw.pop("ref_time", motion.ref_time)
    settings = kw.pop("settings", None) or ManoeuvreSettings()
    from dataclasses import replace

    settings = replace(settings, max_iter=max_iter)
    return estimate_manoeuvres(meas, m, ref_time=ref, init=init, options=options,
                               known_nuisance=known_nuisance, settings=settings, **kw)


__all__ = ["ACCELERATIONS", "CRITERIA", "ManoeuvreEstimate", "ManoeuvreSettings", "OrderFit",
           "OrderSelection", "estimate_for", "estimate_manoeuvres", "parse_motion", "select_order"]
