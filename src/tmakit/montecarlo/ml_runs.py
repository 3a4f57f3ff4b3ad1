"""The maximum-likelihood runs of a Monte Carlo chunk, solved and summarised as one batch."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..batch.ml import FIT_ERRORS, Best, MaximumLikelihood, solve_without_guess
from ..batch.solver import VarProProblem, levenberg_marquardt
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..results.estimate import assemble_result
from ..results.nuisance import KnownNuisance, as_known_nuisance
from ..results.observability import full_rank
from ..results.status import CONVERGED, DIVERGED, NOT_CONVERGED, UNOBSERVABLE

__all__ = ["RunSummaries", "solve_runs", "summarise_runs"]

#: Runs times rows of one block of the Fisher information (bounds its temporaries).
BLOCK_ROWS = 200_000


@dataclass
class RunSummaries:
    """What a study keeps of each run, in run order."""

    #: ``converged``, ``did not converge``, ``unobservable`` or ``diverged``; ``None`` for a run
    #: whose fit raised (its message in ``failures``)
    status: list[str | None]
    #: iterations, starts: Iterations of the solve that found the estimate; starting points solved
    iterations: NDArray[np.int64]
    chi2: NDArray[np.float64]  # Twice the final cost (inf for a diverged run, NaN for a failed one)
    starts: NDArray[np.int64]
    #: The motion parameters (SI; NaN for a diverged or failed run); shape (runs, p)
    estimates: NDArray[np.float64]
    #: Index of the run (in the batch) to its error
    failures: dict[int, Exception] = field(default_factory=dict)


def solve_runs(ml: MaximumLikelihood, meas: MeasurementSet, values: NDArray[np.float64],
               motion: MotionModel) -> tuple[VarProProblem, list[Best | Exception]]:
    """Solve every run's values on the shared rows, as :meth:`MaximumLikelihood.fit_many`."""
    known = as_known_nuisance(ml.known_nuisance)  # (one already: as it is)
    obs = ObservationModel(meas, motion, ml.options)
    fixed = None if known is None else obs.nuisance_vector(known.values)
    problem = VarProProblem(obs, None, fixed)
    if ml.init is not None:
        init = ml.init
        theta0 = (motion.theta(init) if isinstance(init, Mapping)
                  else np.asarray(init, dtype=float)).reshape(1, -1)
        sol = levenberg_marquardt(problem, values, np.repeat(theta0, values.shape[0], 0),
                                  max_iter=ml.max_iter)
        return problem, [Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]),
                              int(sol.iterations[i]), bool(sol.converged[i]), 1)
                         for i in range(values.shape[0])]
    return problem, _without_guess(ml, problem, values)


def _without_guess(ml: MaximumLikelihood, problem: VarProProblem,
                   values: NDArray[np.float64]) -> list[Best | Exception]:
    """No-guess solves of all runs; should the batch raise, each run alone."""
    try:
        found = solve_without_guess(problem, values, ml.grid, ml.max_iter)
    except FIT_ERRORS as e:
        if values.shape[0] == 1:
            return [e]
        return [r for i in range(values.shape[0])
                for r in _without_guess(ml, problem, values[i:i + 1])]
    return [ValueError("no starting point gives finite predictions; check the data")
            if b is None else b for b in found]


def summarise_runs(problem: VarProProblem, bests: list[Best | Exception],
                   known: KnownNuisance | None) -> RunSummaries:
    """Summarise each run's fit as :func:`~tmakit.results.estimate.assemble_result` would."""
    obs = problem.obs
    m, p = len(bests), obs.motion.n_params
    out = RunSummaries([None] * m, np.zeros(m, np.int64), np.full(m, np.nan),
                       np.zeros(m, np.int64), np.full((m, p), np.nan))
    fitted: list[tuple[int, Best]] = []
    for i, best in enumerate(bests):
        if isinstance(best, Exception):
            out.failures[i] = best
            continue
        out.iterations[i], out.starts[i] = best.iterations, best.starts
        if np.all(np.isfinite(best.theta)) and np.isfinite(best.cost):
            fitted.append((i, best))
        else:
            out.status[i], out.chi2[i] = DIVERGED, np.inf
    block = max(1, BLOCK_ROWS // max(1, len(obs.meas)))
    for lo in range(0, len(fitted), block):
        _full_rank_block(problem, fitted[lo:lo + block], known, out)
    return out


def _full_rank_block(problem: VarProProblem, fits: list[tuple[int, Best]],
                     known: KnownNuisance | None, out: RunSummaries) -> None:
    """Status, chi2 and estimate of finite fits (run, fit), their information in a batch."""
    theta = np.stack([b.theta for _, b in fits])
    nu = np.stack([b.nuisance for _, b in fits])
    j_theta, j_nu = problem.obs.jacobian_grouped(theta, nu)
    jac = j_theta if known is not None else np.concatenate(
        [j_theta, np.broadcast_to(j_nu, (*j_theta.shape[:-1], j_nu.shape[-1]))], axis=-1)
    w = problem.noise.whiten(jac, axis=-2)
    info = w.swapaxes(-1, -2) @ w
    sound = np.asarray(np.isfinite(info).all(axis=(-2, -1)))
    full = np.zeros(len(fits), dtype=bool)
    if sound.any():
        full[sound] = full_rank(info[sound])
    for k, (i, best) in enumerate(fits):
        if not sound[k]:  # what a single fit's result does with it, exactly
            _one_by_one(problem, best, known, i, out)
            continue
        out.status[i] = (UNOBSERVABLE if not full[k] else
                         CONVERGED if best.converged else NOT_CONVERGED)
        out.chi2[i] = 2.0 * best.cost
        out.estimates[i] = best.theta


def _one_by_one(problem: VarProProblem, best: Best, known: KnownNuisance | None, i: int,
                out: RunSummaries) -> None:
    """Summarise one run through the full result (a fit whose information is not finite)."""
    try:
        res = assemble_result(problem.obs, problem.noise, best.theta, best.nuisance,
                              best.cost, best.iterations, best.converged, "ml", best.starts,
                              known, best.note)
    except FIT_ERRORS as e:
        out.failures[i] = e
        out.iterations[i] = out.starts[i] = 0
        return
    out.status[i] = str(res.status)
    out.chi2[i] = float(res.chi2)
    out.estimates[i] = np.asarray(res.estimate, dtype=float)
