"""One chunk of Monte Carlo runs: simulate, estimate, record (here or on a Dask worker).

The estimators are the method registry :data:`tmakit.batch.methods.METHODS`, called run by run
through :func:`tmakit.batch.methods.estimate_with`; ``"ml"`` is solved and summarised as one
batch of the chunk's runs (:func:`solve_runs`, :func:`summarise_runs`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..batch.methods import METHODS, EstimatorSettings, estimate_with, is_manoeuvring
from ..batch.ml import FIT_ERRORS, Best, MaximumLikelihood, solve_without_guess
from ..batch.solver import VarProProblem, levenberg_marquardt
from ..batch.varpro import compiled_batches
from ..core.blas import one_thread
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..results.estimate import assemble_result
from ..results.nuisance import KnownNuisance, as_known_nuisance
from ..results.observability import full_rank
from ..results.status import CONVERGED, DIVERGED, NOT_CONVERGED, UNOBSERVABLE
from ..scenario.model import Scenario

__all__ = ["FAILED", "RUN_ERRORS", "ChunkOutput", "ChunkTask", "available_estimators",
           "check_estimator", "run_chunk", "solve_runs", "summarise_runs"]

#: Status of a run whose estimator raised an error (the message is in ``result.failures``).
FAILED = "failed"
#: Errors an estimator may raise on one unlucky data set; they mark the run as failed.
RUN_ERRORS = FIT_ERRORS
#: Runs times rows of one block of the Fisher information (bounds its temporaries).
BLOCK_ROWS = 200_000


def available_estimators() -> tuple[str, ...]:
    """Names accepted as ``estimator`` by :func:`tmakit.montecarlo.monte_carlo`.

    Returns
    -------
    tuple of str
        The keys of :data:`tmakit.batch.methods.METHODS`.
    """
    return tuple(METHODS)


def check_estimator(estimator: str, known_nuisance: bool) -> None:
    """Refuse an estimator the study cannot run."""
    names = available_estimators()
    if not isinstance(estimator, str) or estimator not in names:
        raise ValueError(f"unknown estimator {estimator!r}; expected one of {', '.join(names)}")
    if known_nuisance and not METHODS[estimator].takes_known_nuisance:
        raise ValueError(f"estimator {estimator!r} cannot be given known nuisance "
                         "parameters; use known_nuisance=False or estimator 'ml'")


@dataclass(frozen=True)
class ChunkTask:
    """What a worker needs to compute runs ``first_run .. first_run + len(seeds) - 1``."""

    scenario: Scenario  # The scenario simulated
    estimator: str  # ``"ml"`` or a name of the registry (:func:`available_estimators`)
    options: dict[str, dict[str, object]]  # Per-kind measurement-model options
    #: The nuisance values given to the estimator (None: estimated)
    known_nuisance: KnownNuisance | None
    init: Any  # The starting point given to every run (``None``: the estimator's own)
    first_run: int  # Index of the chunk's first run
    seeds: tuple[np.random.SeedSequence, ...]  # One seed sequence per run
    #: Whether the batched fits evaluate by the compiled kernel where it applies
    #: (:func:`tmakit.batch.varpro.compiled_batches`): decided once per study, so that every
    #: executor evaluates the same way
    compiled: bool = False


@dataclass
class ChunkOutput:
    """Per-run results of one chunk, in run order."""

    first_run: int  # Index of the chunk's first run
    status: list[str]  # Estimator status per run (:data:`FAILED` when it raised)
    #: iterations, chi2, starts: Iterations, chi-square and starting points solved from, per run
    iterations: NDArray[np.int64]
    chi2: NDArray[np.float64]
    starts: NDArray[np.int64]
    estimates: NDArray[np.float64]  # The estimates (NaN for failed runs); shape (runs, p)
    #: Run index to the error message, for failed runs
    failures: dict[int, str] = field(default_factory=dict)

    def __len__(self) -> int:
        """Return the number of runs in the chunk."""
        return len(self.status)

    @classmethod
    def empty(cls, first_run: int, m: int, p: int) -> ChunkOutput:
        """Make ``m`` failed runs of ``p`` parameters, to be filled in."""
        return cls(first_run, [FAILED] * m, np.zeros(m, dtype=np.int64), np.full(m, np.nan),
                   np.zeros(m, dtype=np.int64), np.full((m, p), np.nan))

    def fail(self, i: int, error: Exception) -> None:
        """Record the error of run ``i`` of the chunk (its status stays :data:`FAILED`)."""
        self.failures[self.first_run + i] = f"{type(error).__name__}: {error}"

    def record(self, i: int, res: Any) -> None:
        """Store estimate result ``res`` as run ``i`` of the chunk."""
        self.status[i] = str(res.status)
        self.iterations[i] = int(res.iterations)
        self.chi2[i] = float(res.chi2)
        self.starts[i] = int(getattr(res, "starts", 1))
        self.estimates[i] = np.asarray(res.estimate, dtype=float)


def run_chunk(task: ChunkTask) -> ChunkOutput:
    """Simulate and estimate the runs of one chunk."""
    # One BLAS thread: a chunk's products are many and mid-sized, and the cores are shared
    # with the other chunks (workers or processes), where BLAS threads spin against them.
    with one_thread(), compiled_batches(task.compiled):
        scn = task.scenario
        rngs = [np.random.default_rng(s) for s in task.seeds]
        if task.estimator == "ml" and not is_manoeuvring(scn.motion):
            return _ml_batched(task, *scn.simulate_values(rngs))
        return _per_run(task, scn.simulate_many(rngs))


def _per_run(task: ChunkTask, meas: Sequence[MeasurementSet]) -> ChunkOutput:
    """Each run through the estimator's public function."""
    scn = task.scenario
    out = ChunkOutput.empty(task.first_run, len(meas), scn.motion.n_params)
    settings: EstimatorSettings = {"init": task.init, "options": task.options}
    if task.known_nuisance is not None:
        settings["known_nuisance"] = task.known_nuisance
    for i, m in enumerate(meas):
        try:
            res = estimate_with(task.estimator, m, scn.motion, **settings)
        except RUN_ERRORS as e:
            out.fail(i, e)
            continue
        out.record(i, res)
    return out


def _ml_batched(task: ChunkTask, meas: MeasurementSet, values: NDArray[np.float64]
                ) -> ChunkOutput:
    """:func:`tmakit.batch.ml.estimate` for every run of the chunk, the solves batched."""
    ml = MaximumLikelihood(task.init, task.options, task.known_nuisance)
    problem, bests = solve_runs(ml, meas, values, task.scenario.motion)
    return summarise_runs(problem, bests, task.known_nuisance, task.first_run)


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
                   known: KnownNuisance | None, first_run: int = 0) -> ChunkOutput:
    """Summarise each run's fit as :func:`~tmakit.results.estimate.assemble_result` would."""
    obs = problem.obs
    out = ChunkOutput.empty(first_run, len(bests), obs.motion.n_params)
    fitted: list[tuple[int, Best]] = []
    for i, best in enumerate(bests):
        if isinstance(best, Exception):
            out.fail(i, best)
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
                     known: KnownNuisance | None, out: ChunkOutput) -> None:
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
                out: ChunkOutput) -> None:
    """Summarise one run through the full result (a fit whose information is not finite)."""
    try:
        res = assemble_result(problem.obs, problem.noise, best.theta, best.nuisance,
                              best.cost, best.iterations, best.converged, "ml", best.starts,
                              known, best.note)
    except FIT_ERRORS as e:
        out.fail(i, e)
        out.iterations[i] = out.starts[i] = 0
        return
    out.status[i] = str(res.status)
    out.chi2[i] = float(res.chi2)
    out.estimates[i] = np.asarray(res.estimate, dtype=float)
