"""Maximum-likelihood batch estimation: ``tk.estimate(meas, motion)`` with no initial guess.

The weighted least-squares fit (:mod:`tmakit.batch.solver`) from the likelihood grid
(:mod:`tmakit.batch.init`), many rows solved on a subset first; sensor position errors (Ho, Lu &
Kovavisaruch (2007)) integrated out by :func:`estimate_with_sensor_errors`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from ..core import chi2 as chi2_dist
from ..core.frames import wrap_angle_own
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import effective_noise
from ..observation.planar import gradient_of_rows, planar_gradient_rows
from ..results.estimate import EstimateResult, assemble_result
from ..results.nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from ..results.observability import full_rank
from ..results.solutions import SOLUTION_ALPHA, Solution, separated_solutions
from .estimator import BatchEstimator, Init, Options, theta_from_init
from .hyperbolic import closed_form_starts
from .init import GridSettings, Starts, best_starts_many, first_of_many, subsample
from .solver import Fallback, SolveResult, VarProProblem, information_of, levenberg_marquardt


@dataclass(frozen=True, eq=False)
class MaximumLikelihood(BatchEstimator):
    """Maximum likelihood of tmakit for one motion model without manoeuvres, no guess needed."""

    init: Init = None
    options: Options = None
    known_nuisance: KnownNuisanceLike = None
    grid: GridSettings | None = None
    max_iter: int = 100
    #: look for separated solutions among the no-guess starts' other ends (``solutions``)
    solutions: bool = True

    name: ClassVar[str] = "ml"
    takes_known_nuisance: ClassVar[bool] = True

    def __post_init__(self) -> None:
        """Convert ``known_nuisance``."""
        object.__setattr__(self, "known_nuisance", as_known_nuisance(self.known_nuisance))

    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Estimate the motion parameters from a measurement set by maximum likelihood."""
        res = self.fit_many([meas], motion)[0]
        if isinstance(res, Exception):
            raise res
        return res

    def fit_many(self, sets: Sequence[MeasurementSet], motion: MotionModel
                 ) -> list[EstimateResult | Exception]:
        """Fit many data sets, batched where they share their rows: :meth:`fit` of each."""
        if isinstance(motion, str) or getattr(motion, "manoeuvres", None) is not None:
            raise TypeError(f"MaximumLikelihood fits one motion model; the motion {motion!r} "
                            "is a manoeuvring target's: use ManoeuvreEstimator "
                            "(tmakit.batch.manoeuvre) or tmakit.batch.estimate")
        sets = list(sets)
        if len(sets) > 1 and not same_rows(sets):
            return [r for m in sets for r in self.fit_many([m], motion)]
        theta0 = None if self.init is None else self._start(motion)
        if not sets:
            return []
        known = as_known_nuisance(self.known_nuisance)  # (no-op: __post_init__ converted it)
        obs = ObservationModel(sets[0], motion, self.options)
        fixed = None if known is None else obs.nuisance_vector(known.values)
        problem = VarProProblem(obs, None, fixed)
        ys = np.array([m.value_si for m in sets])  # (writeable: the solver takes it as it is)
        bests = self._solve(problem, ys, theta0)
        jacobians = _jacobians(problem.obs, bests)
        out: list[EstimateResult | Exception] = []
        for meas, best in zip(sets, bests, strict=True):
            if isinstance(best, Exception):
                out.append(best)
                continue
            try:
                res = assemble_result(problem.obs, problem.noise, best.theta, best.nuisance,
                                      best.cost, best.iterations, best.converged, self.name,
                                      best.starts, known, best.note,
                                      jacobian=jacobians.get(id(best)),
                                      information=best.information,
                                      decomposition=best.decomposition)
                if self.solutions:
                    res.solutions = _solutions(problem, res, best, known, meas)
                out.append(res)
            except FIT_ERRORS as e:  # pragma: no cover - the bound of a finite fit
                out.append(e)
        return out

    def _start(self, motion: MotionModel) -> NDArray[np.float64]:
        """``init`` as a ``(1, p)`` parameter vector (SI); refuse a wrong length."""
        return theta_from_init(motion, self.init)[None]  # type: ignore[arg-type]

    def _solve(self, problem: VarProProblem, ys: NDArray[np.float64],
               theta0: NDArray[np.float64] | None) -> list[Best | Exception]:
        """Solve every data set from ``theta0``, else without a guess; errors per set."""
        if theta0 is not None:
            starts = theta0 if ys.shape[0] == 1 else np.repeat(theta0, ys.shape[0], 0)
            sol = levenberg_marquardt(problem, ys, starts, max_iter=self.max_iter)
            return [Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]),
                         int(sol.iterations[i]), bool(sol.converged[i]), 1,
                         information=information_of(problem, sol.evaluation, i,
                                                    sol.information),
                         decomposition=sol.decomposition)
                    for i in range(ys.shape[0])]
        try:
            found: list[Best | Exception | None] = list(
                solve_without_guess(problem, ys, self.grid, self.max_iter))
        except FIT_ERRORS as e:
            if ys.shape[0] == 1:
                return [e]
            found = [self._solve(problem, ys[i:i + 1], None)[0] for i in range(ys.shape[0])]
        return [ValueError("no starting point gives finite predictions; check the data")
                if b is None else b for b in found]


def _solutions(problem: VarProProblem, res: EstimateResult, best: Best,
               known: KnownNuisance | None, meas: MeasurementSet) -> list[Solution]:
    """Give the separated solutions among the starts' other ends (empty: ``res`` alone)."""
    if not res.converged or not best.others:
        return []
    limit = float(chi2_dist.isf(SOLUTION_ALPHA, max(res.bound.rank if res.bound else 1, 1)))
    taken = [best.theta]
    candidates = []
    # ends within a tenth of a std of one taken are that one (solver tolerance, not a minimum)
    tol = np.where(np.isfinite(res.std), 0.1 * res.std, 1e-6 * np.maximum(np.abs(best.theta), 1))
    for theta, nu, cost in sorted(best.others, key=lambda e: e[2]):
        if 2.0 * (cost - best.cost) > limit:
            break
        if any(np.all(np.abs(theta - t) <= tol) for t in taken):
            continue
        taken.append(theta)
        alt = assemble_result(problem.obs, problem.noise, theta, nu, cost, 0, True, res.method,
                              best.starts, known)
        candidates.append(alt)
    found = separated_solutions(res, candidates, meas) if candidates else []
    return found if len(found) > 1 else []


def _jacobians(obs: ObservationModel, bests: Sequence[Best | Exception]
               ) -> dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Return the grouped Jacobians at several finite fits in one evaluation, by ``id(fit)``."""
    if len(bests) < 2:
        return {}
    fits = [b for b in bests if isinstance(b, Best) and b.information is None
            and np.all(np.isfinite(b.theta)) and np.isfinite(b.cost)]
    if len(fits) < 2:
        return {}
    j_theta, j_nu = obs.jacobian_grouped(np.stack([b.theta for b in fits]),  # each bit for
                                         np.stack([b.nuisance for b in fits]), each=True)  # bit
    j_nu = np.broadcast_to(j_nu, (len(fits), *j_nu.shape[-2:]))
    return {id(b): (j_theta[i], j_nu[i]) for i, b in enumerate(fits)}


FIT_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)
"""Errors a fit may raise on one data set."""


def same_rows(sets: Sequence[MeasurementSet]) -> bool:
    """Tell whether every set has the rows of the first, so that one problem serves them all."""
    a = sets[0]
    for b in sets[1:]:
        if len(b) != len(a) or a.sensor_names != b.sensor_names or not (  # codes: no text
                np.array_equal(a.time, b.time) and np.array_equal(a.sensor_code, b.sensor_code)
                and np.array_equal(a.kind_code, b.kind_code)
                and np.array_equal(a.sigma_si, b.sigma_si)
                and np.array_equal(a.sensor_state, b.sensor_state)
                and np.array_equal(a.time_ref, b.time_ref, equal_nan=True)
                and np.array_equal(a.ref_sensor_state, b.ref_sensor_state, equal_nan=True)):
            return False
    return True


def estimate(meas: MeasurementSet, motion: MotionModel, init: Init = None,
             options: Options = None, known_nuisance: KnownNuisanceLike = None,
             grid: GridSettings | None = None, max_iter: int = 100) -> EstimateResult:
    """Fit by maximum likelihood: ``MaximumLikelihood(...).fit(meas, motion)``, short form."""
    return MaximumLikelihood(init, options, known_nuisance, grid, max_iter).fit(meas, motion)


DENSE_GRID = GridSettings(n_ranges=20, n_bearings=24,
                          speeds=(0.0, 5.0, 10.0, 20.0, 40.0, 80.0, 150.0, 300.0, 450.0),
                          n_courses=16, max_rows=60, starts=12, coarse_rows=20, refine=1024)
"""The last resort of :func:`solve_without_guess`."""


@dataclass
class Best:
    """The best fit found for one data set (SI), and how many starting points were solved."""

    theta: NDArray[np.float64]
    nuisance: NDArray[np.float64]
    cost: float  # half the weighted sum of squares
    iterations: int
    converged: bool
    starts: int
    note: str = ""  # a sentence for the message
    information: NDArray[np.float64] | None = None  # the Fisher information from the solve
    #: ``information`` decomposed as the solver left it (SolveResult.decomposition), or None
    decomposition: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = (
        None)
    others: list[tuple[NDArray[np.float64], NDArray[np.float64], float]] = field(
        default_factory=list)  # other converged ends (theta, nuisance, cost)

    def end(self) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """Give this fit as one of the ends :attr:`others` lists."""
        return self.theta.copy(), self.nuisance.copy(), self.cost


def solve_without_guess(problem: VarProProblem, ys: NDArray[np.float64],
                        grid: GridSettings | None = None, max_iter: int = 100
                        ) -> list[Best | None]:
    """Fit each data set globally, no guess (same times, sensors, noise for all)."""
    g = grid or GridSettings()
    ys = np.ascontiguousarray(np.atleast_2d(np.asarray(ys, dtype=float)))  # (read, not written)
    if subset_first(problem):  # correlated and many rows: every start on a subset only
        return solve_on_subset_first(
            problem, ys, lambda small, y: solve_without_guess(small, y, g, max_iter), max_iter)
    b = ys.shape[0]
    dof = problem.noise.rank - problem.p - (0 if problem.fixed is not None else problem.k)
    has_bearings = "bearing" in problem.obs.models  # (the kinds present)
    subset = presolve_subset(problem)  # many rows: the grid and the presolve on one subset
    best: list[Best | None] = [None] * b

    def solve(blocks: dict[int, NDArray[np.float64]]) -> None:
        runs = [r for r, th in blocks.items() if th.shape[0]]
        if not runs:
            return
        theta = np.concatenate([blocks[r] for r in runs])
        owner = np.concatenate([np.full(blocks[r].shape[0], r) for r in runs])
        # Starts bound for a worse minimum than one already reached stop early.
        reached = np.array([np.inf if f is None else f.cost for f in best])
        data = ys if np.array_equal(owner, np.arange(b)) else ys[owner]  # (1 start a set: no copy)
        sol = solve_all_rows(problem, data, theta, max_iter, owner, reached[owner], subset)
        for r in runs:
            best[r] = _better(problem, best[r], sol, np.flatnonzero(owner == r))

    def unsettled() -> list[int]:
        return [r for r, f in enumerate(best) if f is None or not (
            f.converged and plausible_chi2(2.0 * f.cost, dof))]

    closed = closed_form_starts(problem.obs, ys)  # TDOA: Chan & Ho, Ho & Xu
    solve(closed)
    for r in closed:  # a closed form's start that ran off (high noise) is left to the grid
        if (fit := best[r]) is not None and not fit.converged:
            best[r] = None
    todo = unsettled() if closed else list(range(b))
    if not todo:
        _prefer_above(problem, best)
        return best
    by_set = dict(zip(todo, grid_starts(problem, ys if len(todo) == b else ys[todo], g,
                                        subset), strict=True))
    first = 1 if has_bearings else g.starts
    solve(dict(zip(todo, first_of_many([by_set[r] for r in todo], first), strict=True)))
    more = first_of_many([by_set[r] for r in unsettled()], max(24, g.starts))
    solve({r: th[first:] for r, th in zip(unsettled(), more, strict=True)})
    if again := unsettled():
        dense = grid_starts(problem, ys[again], DENSE_GRID, subset)
        solve({r: d.first(DENSE_GRID.starts) for r, d in zip(again, dense, strict=True)})
    _prefer_above(problem, best)
    return best


def _better(problem: VarProProblem, best: Best | None, sol: SolveResult,
            rows: NDArray[np.int64]) -> Best:
    """Give the best of ``best`` and the solves ``rows`` of one data set; others kept as ends."""
    cost = np.where(np.isfinite(sol.cost[rows]), sol.cost[rows], np.inf)
    i = rows[int(np.argmin(cost))]
    used = rows.size + (best.starts if best is not None else 0)
    ends = [(sol.theta[j].copy(), sol.nuisance[j].copy(), float(sol.cost[j]))
            for j in rows if j != i and sol.converged[j] and np.isfinite(sol.cost[j])]
    if best is None or sol.cost[i] < best.cost:
        seen = [] if best is None else [*best.others, *([best.end()] if best.converged else [])]
        return Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]), int(sol.iterations[i]),
                    bool(sol.converged[i]), used,
                    information=information_of(problem, sol.evaluation, i, sol.information),
                    others=seen + ends)
    best.starts = used
    best.others += ends
    if sol.converged[i]:
        best.others.append((sol.theta[i].copy(), sol.nuisance[i].copy(), float(sol.cost[i])))
    return best


def _prefer_above(problem: VarProProblem, best: list[Best | None]) -> None:
    """Report each fit above the sensors' mirror plane, if there is one (in place)."""
    motion = problem.obs.motion
    plane = problem.obs.meas.mirror_plane(1e-9) if "z" in motion.param_names else None
    if plane is None:
        return
    for fit in best:
        if fit is not None:
            fit.others = [(prefer_above(motion, t, plane)[0], nu, c)
                          for t, nu, c in fit.others]  # a mirror image is no other solution
            theta, fit.note = prefer_above(motion, fit.theta, plane)
            if not np.array_equal(theta, fit.theta):  # mirrored: the information is not
                fit.information = fit.decomposition = None  # the one at the new point
            fit.theta = theta


def plausible_chi2(chi2: float, dof: int) -> bool:
    """Tell whether a weighted sum of squares is consistent with its degrees of freedom."""
    dof = max(dof, 1)
    return bool(np.isfinite(chi2) and chi2 <= dof + 5.0 * np.sqrt(2.0 * dof) + 5.0)


SUBSET_FIRST_ROWS = 20_000
"""Rows above which a problem with correlated noise is solved on a subset first."""
SUBSET_ROWS = 5_000
"""Evenly spread rows of that subset (every start is solved there)."""


def subset_first(problem: VarProProblem) -> bool:
    """Tell whether ``problem`` chooses its start on a subset (correlated noise, many rows)."""
    rows = len(problem.obs.meas)
    return bool(problem.noise.correlated) and rows > max(SUBSET_FIRST_ROWS, 2 * SUBSET_ROWS)


def solve_on_subset_first(problem: VarProProblem, ys: NDArray[np.float64],
                          solve_all: Callable[[VarProProblem, NDArray[np.float64]],
                                              Sequence[Any]],
                          max_iter: int) -> list[Any]:
    """Fit each data set on a subset with every start, then its best fit on every row."""
    small, rows = subsample(problem, SUBSET_ROWS)
    found = list(solve_all(small, ys[:, rows]))
    runs = [r for r, fit in enumerate(found) if fit is not None]
    if not runs or small is problem:
        return found
    theta = np.stack([found[r].theta for r in runs])
    # The subset's optimum is within a few standard deviations of the whole set's: one or
    # two lightly damped steps.
    sol = levenberg_marquardt(problem, ys[runs], theta, max_iter=max_iter, damping0=1e-8)
    for i, r in enumerate(runs):
        fit = found[r]
        fit.theta, fit.nuisance = sol.theta[i], sol.nuisance[i]
        fit.cost, fit.iterations = float(sol.cost[i]), int(sol.iterations[i])
        fit.converged = bool(sol.converged[i])
        fit.information = information_of(problem, sol.evaluation, i, sol.information)
    return found


def prefer_above(motion: MotionModel, theta: NDArray[np.float64], plane: float
                 ) -> tuple[NDArray[np.float64], str]:
    """Choose, of a track and its mirror image through the sensors' plane, the one above."""
    names = motion.param_names
    theta = np.array(theta, dtype=float)
    iz = names.index("z")
    note = (f"z is ambiguous: the mirror image through the sensors' plane z = {plane:g} m fits "
            "exactly as well (no elevation is measured); the solution above it is reported")
    if theta[iz] < plane:
        theta[iz] = 2.0 * plane - theta[iz]
        if "vz" in names:
            theta[names.index("vz")] *= -1.0
    return theta, note


REFITS = 2  # refits with the effective noise relinearised


def estimate_with_sensor_errors(meas: MeasurementSet, motion: MotionModel,
                                position_sigma: float, velocity_sigma: float = 0.0,
                                options: Options = None
                                ) -> tuple[EstimateResult, EstimateResult]:
    """Fit by maximum likelihood with the sensors' positions known to ``position_sigma`` (m)."""
    opts = {k: dict(v) for k, v in dict(options or {}).items()}
    ignoring = MaximumLikelihood(options=opts).fit(meas, motion)
    obs = ObservationModel(meas, motion, opts)
    theta = np.asarray(ignoring.estimate, dtype=float)
    nu = np.array([ignoring.nuisance[n][0] for n in obs.nuisance_names])
    converged, iterations, cost = ignoring.status == "converged", 0, np.nan
    for _ in range(REFITS):
        noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)
        sol = levenberg_marquardt(VarProProblem(obs, noise), obs.values, theta[None, :])
        theta, nu = sol.theta[0], sol.nuisance[0]
        converged, cost = bool(sol.converged[0]), float(sol.cost[0])
        iterations += int(sol.iterations[0])
    noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)
    note = (f"sensor positions known to {position_sigma:g} m per axis"
            + (f", velocities to {velocity_sigma:g} m/s" if velocity_sigma else ""))
    accounting = assemble_result(obs, noise, theta, nu, cost, iterations, converged,
                                 "ml-sensor-errors", ignoring.starts, None, note)
    loss = ", ".join(f"{n} {a / b:.3g}x" for n, a, b in zip(
        motion.param_names, accounting.std, ignoring.std, strict=True))
    accounting.message += f"; std against perfectly known positions: {loss}"
    return accounting, ignoring


PRESOLVE_ROWS = 20_000
"""Rows above which the no-guess fit first converges its starts on a subset."""
PRESOLVE_SUBSET = 2_000
"""Evenly spread rows of that subset."""
PRESOLVE_DTOL = 0.5
"""Decrement (half chi2 of the subset) at which the presolve stops."""


def presolve_subset(problem: VarProProblem
                    ) -> tuple[VarProProblem, NDArray[np.int64]] | None:
    """Give the subset :func:`presolve` fits on and its rows, or None for few rows."""
    if len(problem.obs.meas) <= PRESOLVE_ROWS:
        return None
    small, rows = subsample(problem, PRESOLVE_SUBSET)
    return None if small is problem else (small, rows)


def grid_starts(problem: VarProProblem, ys: NDArray[np.float64], settings: GridSettings,
                subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> list[Starts]:
    """Rank the grid's starting points, on the presolve's subset when there is one."""
    if subset is None:
        return best_starts_many(problem, ys, settings)
    return best_starts_many(subset[0], ys[:, subset[1]], settings)


def presolve(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
             max_iter: int, subset: tuple[VarProProblem, NDArray[np.int64]] | None
             ) -> tuple[NDArray[np.float64], bool, NDArray[np.float64] | None]:
    """Move starts to their optimum on a subset of rows; the subset's ``J'J`` scaled to all."""
    subset = subset or presolve_subset(problem)
    if subset is None:
        return theta, False, None
    small, rows = subset
    pre = levenberg_marquardt(small, ys[:, rows], theta, max_iter=max_iter, dtol=PRESOLVE_DTOL)
    ok = pre.converged & np.isfinite(pre.cost)
    if pre.information is not None:
        # A subset that cannot see every parameter has no optimum near the whole set's
        # (bearings from a barely turning observer fit at 10^7 m): such a start stays.
        sound = ok & np.isfinite(pre.information).all(axis=(1, 2))
        ok[sound] = full_rank(pre.information[sound])
    information = None
    if pre.information is not None and not problem.eliminates:
        # each evenly spread row of the subset stands for n / m rows of the whole set
        whole, part = problem.noise.inv_sigma, small.noise.inv_sigma
        information = np.where(ok[:, None, None], pre.information, np.nan) * (
            np.einsum("n,n->", whole, whole) / np.einsum("n,n->", part, part))
    return np.where(ok[:, None], pre.theta, theta), bool(ok.all()), information


def gradient_at(problem: VarProProblem, theta: NDArray[np.float64], u: NDArray[np.float64]
                ) -> tuple[float, NDArray[np.float64]] | None:
    """Give half chi2 and ``J'r`` at one point without forming the Jacobian, or None."""
    theta = np.asarray(theta, dtype=float)
    weights = problem._weights
    if (problem.k or weights is None or not problem.all_angle or u.shape[0] != 1
            or theta.shape[0] != 1):
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        found = planar_gradient_rows(problem.obs, theta, weights)
        if found is None:
            return None
        h0, rows = found
        e = wrap_angle_own(np.subtract(u[0], h0, out=h0), in_place=True)  # (h0 is ours)
        r = problem.noise.whiten(e, overwrite=True)
        return 0.5 * float(np.einsum("n,n->", r, r)), gradient_of_rows(problem.obs, rows, r)


def subset_step(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
                information: NDArray[np.float64] | None
                ) -> tuple[NDArray[np.float64], float] | None:
    """Take the first Gauss–Newton step on every row with the subset's ``J'J``, or None."""
    if (theta.shape[0] != 1 or information is None
            or not np.all(np.isfinite(information))):
        return None
    y = problem.group(ys)
    found = gradient_at(problem, theta, problem.data_part(y, problem.reference_nuisance(y)))
    if found is None or not np.isfinite(found[0]):
        return None
    try:
        step = np.linalg.solve(information[0], found[1])
    except np.linalg.LinAlgError:
        return None
    return (theta + step[None], found[0]) if np.all(np.isfinite(step)) else None


def _fallback(theta: NDArray[np.float64], stepped: tuple[NDArray[np.float64], float] | None,
              information: NDArray[np.float64] | None) -> Fallback | None:
    """Give the presolve's point and cost (and information) to fall back on, if stepped."""
    if stepped is None:
        return None
    cost = np.array([stepped[1]], dtype=np.float64)
    return (theta, cost) if information is None else (theta, cost, information)


POLISH_DECREMENT = 0.5
"""Decrement (half chi2) below which the full solve after a presolve ends with a polish."""


def solve_all_rows(problem: VarProProblem, ys: NDArray[np.float64], theta: NDArray[np.float64],
                   max_iter: int, groups: NDArray[np.int64], ceiling: NDArray[np.float64],
                   subset: tuple[VarProProblem, NDArray[np.int64]] | None) -> SolveResult:
    """Solve every row from starts first converged on the subset (:func:`presolve`)."""
    theta, near, information = presolve(problem, ys, theta, max_iter, subset)
    stepped = subset_step(problem, ys, theta, information) if near else None
    sol = levenberg_marquardt(problem, ys, theta if stepped is None else stepped[0],
                              max_iter=max_iter, groups=groups, ceiling=ceiling,
                              damping0=1e-8 if near else 1e-3,
                              polish=POLISH_DECREMENT if near else 0.0,
                              fallback=_fallback(theta, stepped, information))
    if stepped is not None:
        sol.iterations += 1  # the step taken with the subset's J'J
    return sol
