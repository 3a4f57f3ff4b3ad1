"""Monte Carlo evaluation of an estimator on a scenario, against the Cramér-Rao bound.

:func:`monte_carlo` (run ``r`` uses child ``r`` of ``np.random.SeedSequence(seed)`` whatever the
chunking), :func:`closed_loop_study` (planners in the closed loop), :class:`MonteCarloResult`.
"""

from __future__ import annotations

from .closed_loop import ClosedLoopStudy, LoopCase, closed_loop_study
from .execution import COMPILED_CHUNK, LOCAL_CHUNK, LOOP_CHUNK, keep_freed_memory
from .runs import FAILED, RUN_ERRORS, available_estimators
from .study import MonteCarloResult, finished_runs_table, monte_carlo, ratio_interval

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
