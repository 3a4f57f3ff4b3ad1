"""One chunk of Monte Carlo runs: simulate, estimate, record.

In this process or on a Dask worker.

The maximum-likelihood estimator without an initial guess is vectorised across the runs of a
chunk when they share times, sensors and noise (their noise-free rows are simulated once,
:meth:`~tmakit.scenario.Scenario.simulate_many`): the grid's predictions are computed once
for all of them (:func:`~tmakit.batch.init.best_starts_many`), one batched
Levenberg–Marquardt call solves every run from its first starting points, and further batched
calls re-solve only the runs whose best fit did not converge or has an implausible chi2 —
exactly what :func:`~tmakit.batch.ml.estimate` does run by run
(:func:`~tmakit.batch.ml.solve_without_guess` serves both).  Other estimators (the registry of
:mod:`.estimators`) are called run by run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..batch.methods import estimate_with
from ..batch.ml import Best, solve_without_guess
from ..batch.solver import VarProProblem, levenberg_marquardt
from ..blas import one_thread
from ..data import MeasurementSet
from ..observation import ObservationModel
from ..results.estimate import assemble_result
from ..results.nuisance import KnownNuisance
from ..scenario import Scenario

__all__ = ["FAILED", "RUN_ERRORS", "ChunkOutput", "ChunkTask", "run_chunk"]

#: Status of a run whose estimator raised an error (the message is in ``result.failures``).
FAILED = "failed"
#: Errors an estimator may raise on one unlucky data set; they mark the run as failed.
RUN_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)


@dataclass(frozen=True)
class ChunkTask:
    """What a worker needs to compute runs ``first_run .. first_run + len(seeds) - 1``.

    Parameters
    ----------
    scenario : Scenario
        The scenario simulated.
    estimator : str
        ``"ml"`` or a name of the registry (:mod:`.estimators`).
    options : dict
        Per-kind measurement-model options.
    known_nuisance : bool
        Give the estimator the scenario's true nuisance values.
    init : object
        The starting point given to every run (``None``: the estimator's own).
    init_vector : ndarray or None
        ``init`` as a parameter vector, for the batched ``ml`` solve.
    first_run : int
        Index of the chunk's first run.
    seeds : tuple of numpy.random.SeedSequence
        One seed sequence per run.
    """

    scenario: Scenario
    estimator: str
    options: dict[str, dict[str, object]]
    known_nuisance: bool
    init: Any
    init_vector: NDArray[np.float64] | None
    first_run: int
    seeds: tuple[np.random.SeedSequence, ...]


@dataclass
class ChunkOutput:
    """Per-run results of one chunk, in run order.

    Parameters
    ----------
    first_run : int
        Index of the chunk's first run.
    status : list of str
        Estimator status per run (:data:`FAILED` when it raised).
    iterations, chi2, starts : ndarray
        Iterations, chi-square and starting points solved from, per run.
    estimates : ndarray, shape (runs, p)
        The estimates (NaN for failed runs).
    failures : dict of int to str
        Run index to the error message, for failed runs.
    """

    first_run: int
    status: list[str]
    iterations: NDArray[np.int64]
    chi2: NDArray[np.float64]
    starts: NDArray[np.int64]
    estimates: NDArray[np.float64]
    failures: dict[int, str] = field(default_factory=dict)

    def __len__(self) -> int:
        """Return the number of runs in the chunk."""
        return len(self.status)

    @classmethod
    def empty(cls, first_run: int, m: int, p: int) -> ChunkOutput:
        """Make ``m`` failed runs of ``p`` parameters, to be filled in.

        Parameters
        ----------
        first_run : int
            Index of the chunk's first run in the study.
        m, p : int
            Number of runs and of motion parameters.

        Returns
        -------
        ChunkOutput
            Every run :data:`FAILED`, estimates NaN.
        """
        return cls(first_run, [FAILED] * m, np.zeros(m, dtype=np.int64), np.full(m, np.nan),
                   np.zeros(m, dtype=np.int64), np.full((m, p), np.nan))

    def record(self, i: int, res: Any) -> None:
        """Store estimate result ``res`` as run ``i`` of the chunk.

        Parameters
        ----------
        i : int
            The run's index in the chunk.
        res : tmakit.results.EstimateResult
            Its estimate (SI).
        """
        self.status[i] = str(res.status)
        self.iterations[i] = int(res.iterations)
        self.chi2[i] = float(res.chi2)
        self.starts[i] = int(getattr(res, "starts", 1))
        self.estimates[i] = np.asarray(res.estimate, dtype=float)


def run_chunk(task: ChunkTask) -> ChunkOutput:
    """Simulate and estimate the runs of one chunk.

    Parameters
    ----------
    task : ChunkTask
        The chunk.

    Returns
    -------
    ChunkOutput
        Its runs' results.
    """
    # One BLAS thread: a chunk's products are many and mid-sized, and the cores are shared
    # with the other chunks (workers or processes), where BLAS threads spin against them.
    with one_thread():
        scn = task.scenario
        meas = scn.simulate_many([np.random.default_rng(s) for s in task.seeds])
        if task.estimator == "ml" and _shared_layout(meas):
            return _ml_batched(task, meas)
        return _per_run(task, meas)


def _shared_layout(meas: Sequence[MeasurementSet]) -> bool:
    """Tell whether every set has the rows of the first.

    Rows means times, sensors, kinds, sigmas, sensor states; then they differ only in their values
    and one problem serves them all.
    """
    a = meas[0]
    for b in meas[1:]:
        if len(b) != len(a) or not (
                np.array_equal(a.time, b.time) and np.array_equal(a.sensor, b.sensor)
                and np.array_equal(a.kind, b.kind) and np.array_equal(a.sigma, b.sigma)
                and np.array_equal(a.sensor_state, b.sensor_state)
                and np.array_equal(a.time_ref, b.time_ref, equal_nan=True)
                and np.array_equal(a.ref_sensor_state, b.ref_sensor_state, equal_nan=True)):
            return False
    return True


def _per_run(task: ChunkTask, meas: Sequence[MeasurementSet]) -> ChunkOutput:
    """Each run through the estimator's public function."""
    scn = task.scenario
    out = ChunkOutput.empty(task.first_run, len(meas), scn.motion.n_params)
    known = {"known_nuisance": dict(scn.nuisance)} if task.known_nuisance else {}
    for i, m in enumerate(meas):
        try:
            res = estimate_with(task.estimator, m, scn.motion, init=task.init,
                                options=task.options, **known)
        except RUN_ERRORS as e:
            out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
            continue
        out.record(i, res)
    return out


def _ml_batched(task: ChunkTask, meas: Sequence[MeasurementSet]) -> ChunkOutput:
    """:func:`tmakit.batch.ml.estimate` for every run of the chunk, the solves batched.

    Step for step what ``estimate`` does per run: best grid starts (or ``init``), a solve from
    the first start, a solve from the other starts if that fit did not converge or has an
    implausible chi2, the lowest cost wins, and ``_result`` gives the status.  Each row of a
    batched Levenberg–Marquardt solve is independent of the others, so the results are those
    of ``estimate``.
    """
    scn = task.scenario
    motion = scn.motion
    m, p = len(meas), motion.n_params
    out = ChunkOutput.empty(task.first_run, m, p)
    obs0 = ObservationModel(meas[0], motion, task.options)
    known = KnownNuisance(scn.nuisance) if task.known_nuisance else None
    fixed = None if known is None else obs0.nuisance_vector(known.values)
    # As estimate() builds it (the problem makes its own noise model, in its row order); the
    # noise model is then shared by every run of the chunk: they have the same rows.
    problem = VarProProblem(obs0, None, fixed)
    ys = np.stack([x.value_si for x in meas])

    if task.init_vector is not None:
        sol = levenberg_marquardt(problem, ys, np.repeat(task.init_vector.reshape(1, p), m, 0))
        bests: list[Best | None] = [
            Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]), int(sol.iterations[i]),
                 bool(sol.converged[i]), 1) for i in range(m)]
    else:
        try:  # the very code estimate() runs, for the whole chunk at once
            bests = solve_without_guess(problem, ys)
        except RUN_ERRORS:  # find the run at fault one by one
            bests = []
            for i in range(m):
                try:
                    bests.extend(solve_without_guess(problem, ys[i:i + 1]))
                except RUN_ERRORS as e:
                    out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
                    bests.append(None)
    for i, best in enumerate(bests):
        if best is None:
            out.failures.setdefault(task.first_run + i, "ValueError: no starting point gives "
                                    "finite predictions; check the data")
            continue
        try:
            res = assemble_result(problem.obs, problem.noise, best.theta, best.nuisance,
                                  best.cost, best.iterations, best.converged, "ml",
                                  best.starts, known, best.note)
        except RUN_ERRORS as e:  # pragma: no cover - the bound of a finite fit
            out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
            continue
        out.record(i, res)
    return out
