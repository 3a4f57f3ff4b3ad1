"""Monte Carlo evaluation of an estimator on a scenario, against the Cramér–Rao bound.

>>> from tmakit.montecarlo import monte_carlo
>>> res = monte_carlo(tk.load_scenario("gu2007"), "ml", runs=200, rng=1)
>>> print(res.summary())            # bias, RMSE, CRLB, RMSE/CRLB with 95 % interval
>>> from tmakit.io.study_files import write_study_table
>>> write_study_table(res, "gu2007-mc.parquet")   # the per-run table

One job per module:

* :mod:`.study` — :func:`monte_carlo`: arguments, seeds (run ``r`` uses child ``r`` of
  ``np.random.SeedSequence(seed)``, whatever the chunking), chunks, the CRLB.
* :mod:`.runs` — one chunk of runs: simulate, estimate (the ``ml`` solves batched across
  runs, equal to :func:`tmakit.batch.estimate` run by run), record.
* :mod:`.ml_runs` — the ``ml`` runs of a chunk: one batch of solves on the rows they share,
  their status, chi-square and estimate summarised in one batch.
* :mod:`.memory` — :func:`keep_freed_memory`: the allocator keeps the temporaries a chunk
  frees (glibc thresholds); a process-wide setting, opt-in (``tma`` and the pool workers
  make it).
* :mod:`.execution` — where the chunks run: this process, ``workers`` processes of this
  machine, or a Dask cluster; progress bar.
* :mod:`.estimators` — the estimator names a study accepts (the registry
  :mod:`tmakit.batch.methods`).
* :mod:`.closed_loop` — :func:`closed_loop_study`: closed-loop runs of sensor planners
  (:mod:`tmakit.planning`), per-step table of choices, bounds and errors.
* :mod:`.result` — :class:`MonteCarloResult`: the per-run table, summary against the CRLB
  (:func:`ratio_interval`), JSON and saving.

Dask, distributed and tqdm are imported only when used.
"""

from __future__ import annotations

from .closed_loop import ClosedLoopStudy, LoopCase, closed_loop_study
from .estimators import available_estimators
from .execution import COMPILED_CHUNK, LOCAL_CHUNK, LOOP_CHUNK
from .memory import keep_freed_memory
from .result import MonteCarloResult, ratio_interval
from .runs import FAILED, RUN_ERRORS
from .study import finished_runs_table, monte_carlo

__all__ = [
           "COMPILED_CHUNK",
           "FAILED",
           "LOCAL_CHUNK",
           "LOOP_CHUNK",
           "RUN_ERRORS",
           "ClosedLoopStudy",
           "LoopCase",
           "MonteCarloResult",
           "available_estimators",
           "closed_loop_study",
           "finished_runs_table",
           "keep_freed_memory",
           "monte_carlo",
           "ratio_interval",
]
