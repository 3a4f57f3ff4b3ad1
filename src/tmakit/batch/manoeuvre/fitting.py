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
    """Fit by Levenberg–Marquardt with the search's damping and stopping rules.

    Only the columns ``free`` are fitted, from the starts ``theta0``; the damping is divided
    by 3 after an accepted step and multiplied by 4 after a rejected one.

    Parameters
    ----------
    problem : VarProProblem
        The order's least-squares problem (:meth:`ManoeuvreSearch.problem`).
    theta0 : ndarray
        ``(B, p)`` starting points (internal parameters, SI).
    free : ndarray of bool
        ``(p,)`` the parameters fitted.
    max_iter : int
        Most steps per fit.
    rtol, atol : float
        Converged: the Gauss–Newton decrement below ``rtol * cost + atol`` (half chi2).  The
        default (within ~0.05 of the held minimum in chi2) suffices to rank grid points;
        refinements ask for ``rtol=1e-10, atol=1e-7``.
    prune : float, optional
        A cost (half chi2): a fit stops early once even twice its Gauss–Newton decrement could
        not bring it within ``prune`` of the best cost of the batch (or ``best``); its current
        cost (an upper bound) is kept.
    best : float
        A cost reached elsewhere, for ``prune``.
    max_reject : int
        A fit stops unconverged after this many rejected steps in a row (on a corner of the
        likelihood, :meth:`ManoeuvreSearch.settle`, no damping helps).
    stall : float
        With ``stall > 0`` a fit also stops once six iterations in a row lowered its cost by
        less than ``stall`` in all (creeping along corners or a flat valley).

    Returns
    -------
    SolveResult
        Every fit's final point, cost (half chi2), convergence and iterations.
    """
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
