"""Monte Carlo over closed-loop runs: planner choices, bound along the path and errors per step.

Each case is a policy, a sensor plan and a :class:`~tmakit.planning.closed_loop.LoopSetup`.  Run
``r`` of every case uses child ``r`` of ``np.random.SeedSequence(seed)``, so the table does not
depend on chunking or executor and every case meets the same draws (common random numbers).
:meth:`ClosedLoopStudy.pcrb` is the posterior CRB the RMSE is held to;
:meth:`ClosedLoopStudy.criterion` is what the planner believed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ..bounds.pcrb_runs import MIN_RUNS, pcrb_over_runs, ratio_interval
from ..core.arrays import Array
from ..motion.dynamics import NearlyConstantVelocity
from ..planning.closed_loop import LoopRecord, LoopSetup, Policy, run_closed_loop
from ..planning.measurement_plan import SensorPlan
from .execution import dask_client, progress_bar, run_dask, run_local, whole_number

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = ["ClosedLoopStudy", "LoopCase", "LoopChunk", "LoopTask", "closed_loop_study",
           "run_loop_chunk"]

#: Runs per chunk in this process (a chunk's records are kept until the study ends).
LOOP_RUNS_PER_CHUNK = 5
#: Fewest runs for an interval (:data:`tmakit.bounds.pcrb_runs.MIN_RUNS`).
MIN_RUNS_INTERVAL = MIN_RUNS


@dataclass(frozen=True, eq=False)
class LoopCase:
    """One case of a closed-loop study."""

    name: str  # The case's name (a column of the table)
    policy: Policy  # What chooses the steps
    plan: SensorPlan  # What the sensor measures
    setup: LoopSetup  # Truth, sensor start, tracker, decisions


@dataclass(frozen=True, eq=False)
class LoopTask:
    """Runs ``first_run .. first_run + len(seeds) - 1`` of one case."""

    case: LoopCase  # The case
    first_run: int  # Index of the first run
    seeds: tuple[np.random.SeedSequence, ...]  # One per run


@dataclass
class LoopChunk:
    """The records of one task's runs, in run order."""

    case: str  # The case's name
    first_run: int  # Index of the first run
    records: list[LoopRecord] = field(default_factory=list)  # One per run

    def __len__(self) -> int:
        """Return the number of runs."""
        return len(self.records)

    def table(self) -> pd.DataFrame:
        """Return the chunk's rows of the per-step table."""
        frames = []
        for i, rec in enumerate(self.records):
            cols = rec.columns()
            d = len(rec)
            frames.append(pd.DataFrame({"case": np.full(d, self.case, dtype=object),
                                        "run": np.full(d, self.first_run + i, dtype=np.int64),
                                        **cols}))
        return pd.concat(frames, ignore_index=True)


def run_loop_chunk(task: LoopTask) -> LoopChunk:
    """Run a task's closed loops (in this process or on a Dask worker)."""
    c = task.case
    return LoopChunk(c.name, task.first_run,
                     [run_closed_loop(c.policy, c.plan, c.setup, s) for s in task.seeds])


@dataclass
class ClosedLoopStudy:
    """The runs of every case of a closed-loop study.

    Attributes
    ----------
    records : dict of str to list of LoopRecord
        Per case, the runs in order.
    seed : int or None
        The study's seed.
    wall_s : float
        Wall time of the study (s).
    setups : dict of str to LoopSetup
        Per case, its loop setup (the prior and the process noise of the bound).

    Every method takes a ``case`` of :attr:`cases` (ValueError for another) and gives its
    figures per decision, (D,) in metres, unless it says otherwise.
    """

    records: dict[str, list[LoopRecord]]
    seed: int | None
    wall_s: float = 0.0
    setups: dict[str, LoopSetup] = field(default_factory=dict)
    _efficiency: dict[tuple[str, float], dict[str, float | None]] = field(
        default_factory=dict, init=False, repr=False, compare=False)

    @property
    def cases(self) -> list[str]:
        """The case names, in order."""
        return list(self.records)

    def runs(self, case: str) -> int:
        """Return the number of runs of ``case``."""
        return len(self._of(case))

    def _of(self, case: str) -> list[LoopRecord]:
        if case not in self.records:
            raise ValueError(f"no case {case!r}; the study has {', '.join(self.records)}")
        return self.records[case]

    def times(self, case: str) -> Array:
        """Return the decision times of ``case`` (D,), s."""
        return self._of(case)[0].times

    def stack(self, case: str, name: str) -> Array:
        """Return the :class:`LoopRecord` field ``name`` of every run stacked, (runs, D, ...)."""
        return np.stack([getattr(r, name) for r in self._of(case)])

    def rmse(self, case: str) -> Array:
        """Return the position RMSE over runs at each step."""
        return np.sqrt(np.mean(self.stack(case, "error_m") ** 2, axis=0))

    def criterion(self, case: str) -> Array:
        """Return the RMS over runs of the planning criterion (what the planner believed)."""
        return np.sqrt(np.mean(self.stack(case, "criterion_m") ** 2, axis=0))

    def pcrb_covariance(self, case: str) -> Array:
        """Return the posterior CRB of the state at each step (D, n, n), SI (needs the setup)."""
        if case not in self.setups:
            raise ValueError(f"the study holds no setup of case {case!r}: no bound")
        s = self.setups[case]
        return pcrb_over_runs(self.stack(case, "information"), self.times(case),
                              s.prior_covariance, NearlyConstantVelocity(s.dim, s.q),
                              s.platform.time)

    def pcrb(self, case: str) -> Array:
        """Return the posterior CRB of the position at each step (``sqrt`` of its trace)."""
        cov = self.pcrb_covariance(case)
        d = cov.shape[-1] // 2
        return np.sqrt(np.clip(np.einsum("kii->k", cov[:, :d, :d]), 0.0, None))

    def efficiency(self, case: str, level: float = 0.95) -> dict[str, float | None]:
        """Return ``final_pcrb_m``, ``rmse_over_pcrb`` and its interval (``_low``, ``_high``).

        The interval is :func:`tmakit.bounds.pcrb_runs.ratio_interval` (None under ``MIN_RUNS``
        runs).
        """
        if (case, level) not in self._efficiency:
            cov = self.pcrb_covariance(case)[-1]
            p = cov[:cov.shape[-1] // 2, :cov.shape[-1] // 2]
            ratio, low, high = ratio_interval(self.stack(case, "error_m")[:, -1], p, level,
                                              0 if self.seed is None else self.seed)
            self._efficiency[case, level] = {
                "final_pcrb_m": float(np.sqrt(np.trace(p))), "rmse_over_pcrb": ratio,
                "rmse_over_pcrb_low": low, "rmse_over_pcrb_high": high}
        return dict(self._efficiency[case, level])

    def summary(self, case: str) -> dict[str, float | int | None]:
        """Return the case's key figures.

        ``final_rmse_m``, the :meth:`efficiency` figures (with the case's setup),
        ``final_criterion_m``, ``min_range_m`` (true range over every run and step),
        ``mean_decision_ms`` (ms) and ``runs``.
        """
        bound = self.efficiency(case) if case in self.setups else {}
        return {"final_rmse_m": float(self.rmse(case)[-1]), **bound,
                "final_criterion_m": float(self.criterion(case)[-1]),
                "min_range_m": float(self.stack(case, "range_m").min()),
                "mean_decision_ms": float(self.stack(case, "decision_ms").mean()),
                "runs": self.runs(case)}

    def table(self) -> pd.DataFrame:
        """Return the per-step table: one row per case, run and decision (:class:`LoopRecord`).

        Columns ``case``, ``run`` and :meth:`LoopRecord.columns` (violations 0 where a case
        lacks the constraint).
        """
        frames = [LoopChunk(case, 0, recs).table() for case, recs in self.records.items()]
        out = pd.concat(frames, ignore_index=True)
        viol = [c for c in out.columns if c.startswith("violation_")]
        out[viol] = out[viol].fillna(0.0)
        return out


def closed_loop_study(cases: Sequence[LoopCase], runs: int = 100, seed: int | None = 0,
                      chunk: int | None = None, dask: str | Client | None = None,
                      progress: bool = True,
                      on_chunk: Callable[[LoopChunk], None] | None = None
                      ) -> ClosedLoopStudy:
    """Run every case ``runs`` times.

    Parameters
    ----------
    cases : sequence of LoopCase
        The cases (distinct names).
    runs : int, optional
        Runs per case.
    seed : int or None, optional
        The study's seed (>= 0).
    chunk : int, optional
        Runs per task (default :data:`LOOP_RUNS_PER_CHUNK`); the results do not depend on it.
    dask : str or distributed.Client, optional
        Run the tasks on a Dask cluster (its workers must import tmakit).
    progress : bool, optional
        Show a progress bar.
    on_chunk : callable, optional
        Called with each finished :class:`LoopChunk`.

    Returns
    -------
    ClosedLoopStudy

    Raises
    ------
    ValueError
        On no cases, repeated names, or ``runs``, ``chunk`` or ``seed`` out of range.
    """
    cases = list(cases)
    if not cases:
        raise ValueError("a closed-loop study needs at least one case")
    names = [c.name for c in cases]
    if len(set(names)) != len(names):
        raise ValueError(f"case names must differ, got {names}")
    runs = whole_number(runs, "runs")
    size = LOOP_RUNS_PER_CHUNK if chunk is None else whole_number(chunk, "chunk")
    if seed is not None:
        whole_number(seed, "seed", 0)
    seeds = np.random.SeedSequence(seed).spawn(runs)
    # chunk by chunk, every case for each (finished chunks then cover every case evenly)
    tasks = [LoopTask(c, lo, tuple(seeds[lo:lo + size]))
             for lo in range(0, runs, size) for c in cases]
    client, opened = (None, False) if dask is None else dask_client(dask)
    bar: Any = progress_bar(runs * len(cases), progress, "closed loop")
    start = time.perf_counter()
    try:
        outputs = (run_local(tasks, bar, run_loop_chunk, on_chunk) if client is None
                   else run_dask(tasks, client, bar, run_loop_chunk, on_chunk))
    finally:
        bar.close()
        if opened and client is not None:
            client.close()
    records: dict[str, list[LoopRecord]] = {n: [] for n in names}
    for out in sorted(outputs, key=lambda o: (names.index(o.case), o.first_run)):
        records[out.case].extend(out.records)
    return ClosedLoopStudy(records, seed, time.perf_counter() - start,
                           {c.name: c.setup for c in cases})
