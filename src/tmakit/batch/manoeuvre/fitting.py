"""The Levenberg–Marquardt fits of the manoeuvre search, with its damping and stopping rules.

One function, :func:`lm_fit`: :func:`tmakit.batch.solver.levenberg_marquardt` with the
search's settings, the held parameters' derivatives not formed.
"""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np
from numpy.typing import NDArray

from ...core import blas
from ...core.arrays import Array
from ...motion.curvilinear_batch import ForwardPiecewise
from ..solver import SolveResult, VarProProblem, levenberg_marquardt

__all__ = ["lm_fit"]


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
