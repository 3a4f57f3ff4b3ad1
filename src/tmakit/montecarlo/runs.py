"""One chunk of Monte Carlo runs: simulate, estimate, record.

In this process or on a Dask worker.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..batch.dispatch import is_manoeuvring
from ..batch.methods import estimate_with
from ..batch.ml import FIT_ERRORS, MaximumLikelihood
from ..batch.varpro import compiled_batches
from ..core.blas import one_thread
from ..data import MeasurementSet
from ..results.nuisance import KnownNuisance
from ..scenario.model import Scenario
from .ml_runs import solve_runs, summarise_runs

__all__ = ["FAILED", "RUN_ERRORS", "ChunkOutput", "ChunkTask", "run_chunk"]

#: Status of a run whose estimator raised an error (the message is in ``result.failures``).
FAILED = "failed"
#: Errors an estimator may raise on one unlucky data set; they mark the run as failed.
RUN_ERRORS = FIT_ERRORS


@dataclass(frozen=True)
class ChunkTask:
    """What a worker needs to compute runs ``first_run .. first_run + len(seeds) - 1``."""

    scenario: Scenario  # The scenario simulated
    estimator: str  # ``"ml"`` or a name of the registry (:mod:`.estimators`)
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
    known = {} if task.known_nuisance is None else {"known_nuisance": task.known_nuisance}
    for i, m in enumerate(meas):
        try:
            res = estimate_with(task.estimator, m, scn.motion, init=task.init,
                                options=task.options, **known)
        except RUN_ERRORS as e:
            out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
            continue
        out.record(i, res)
    return out


def _ml_batched(task: ChunkTask, meas: MeasurementSet, values: NDArray[np.float64]
                ) -> ChunkOutput:
    """:func:`tmakit.batch.ml.estimate` for every run of the chunk, the solves batched."""
    motion = task.scenario.motion
    ml = MaximumLikelihood(task.init, task.options, task.known_nuisance)
    problem, bests = solve_runs(ml, meas, values, motion)
    got = summarise_runs(problem, bests, task.known_nuisance)
    out = ChunkOutput.empty(task.first_run, values.shape[0], motion.n_params)
    for i, e in got.failures.items():
        out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
    out.status = [FAILED if st is None else st for st in got.status]
    out.iterations, out.chi2, out.starts, out.estimates = (got.iterations, got.chi2,
                                                           got.starts, got.estimates)
    return out
