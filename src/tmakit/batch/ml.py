"""Maximum-likelihood batch estimation: ``tk.estimate(meas, motion)`` with no initial guess.

Gaussian noise makes the ML estimate the weighted least-squares fit.  The nuisance parameters
(carrier and drift, power constant, path-loss exponent) are eliminated exactly at every step
(:mod:`tmakit.batch.solver`); the starting points come from a coarse likelihood grid
(:mod:`tmakit.batch.init`) unless ``init`` is given.  The covariance is the inverse Fisher
information at the estimate, over the motion and nuisance parameters together.  The status is
never hidden: ``converged``, ``did not converge``, ``unobservable`` or ``diverged``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..bounds.fim import Bound, bound_from_information
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from .init import GridSettings, best_starts
from .solver import SolveResult, VarProProblem, levenberg_marquardt

CONVERGED = "converged"
NOT_CONVERGED = "did not converge"
UNOBSERVABLE = "unobservable"
DIVERGED = "diverged"


@dataclass
class EstimateResult:
    """A batch estimate: named parameters, their standard deviations, nuisance values, and
    how the solve went."""

    parameters: tuple[str, ...]
    estimate: NDArray[np.float64]
    std: NDArray[np.float64]
    covariance: NDArray[np.float64]
    nuisance: dict[str, tuple[float, float]]
    status: str
    iterations: int
    chi2: float
    dof: int
    method: str
    motion: MotionModel
    bound: Bound | None = None
    starts: int = 1
    message: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return self.status == CONVERGED

    def as_dict(self) -> dict[str, object]:
        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {
            "parameters": list(self.parameters),
            "estimate": [num(v) for v in self.estimate],
            "std": [num(s) for s in self.std],
            "nuisance": {k: {"value": num(v), "std": num(s)}
                         for k, (v, s) in self.nuisance.items()},
            "status": self.status,
            "iterations": self.iterations,
            "chi2": num(self.chi2),
            "dof": self.dof,
            "method": self.method,
            "motion": self.motion.name,
            "starts": self.starts,
            "message": self.message,
            "unobservable": ([d.as_dict() for d in self.bound.observability.directions]
                             if self.bound is not None else []),
        }

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.as_dict(), indent=indent)

    def summary(self) -> str:
        lines = [f"{self.method} estimate, motion {self.motion.name}: {self.status}"
                 f" after {self.iterations} iterations"
                 + (f" from {self.starts} starting points" if self.starts > 1 else ""),
                 f"chi2 = {self.chi2:.2f} on {self.dof} degrees of freedom"
                 + (f" (chi2/dof = {self.chi2 / self.dof:.3f})" if self.dof > 0 else "")]
        if self.message:
            lines.append(self.message)
        width = max(len(n) for n in (*self.parameters, *self.nuisance))
        lines.append(f"  {'parameter':<{width}}  {'estimate':>16}  {'std':>12}")
        for n, v, s in zip(self.parameters, self.estimate, self.std, strict=True):
            lines.append(f"  {n:<{width}}  {v:16.8g}  "
                         + (f"{s:12.4g}" if np.isfinite(s) else f"{'unobservable':>12}"))
        for n, (v, s) in self.nuisance.items():
            lines.append(f"  {n:<{width}}  {v:16.13g}  "
                         + (f"{s:12.4g}" if np.isfinite(s) else f"{'unobservable':>12}"))
        if self.bound is not None:
            for d in self.bound.observability.directions:
                lines.append(f"  unobservable: {d.sentence}")
        return "\n".join(lines)


def _result(problem: VarProProblem, theta: NDArray, nu: NDArray, cost: float, iterations: int,
            converged: bool, method: str, starts: int, known_nuisance: bool) -> EstimateResult:
    obs, motion = problem.obs, problem.obs.motion
    n = len(obs.meas)
    names_nu = obs.nuisance_names
    if not np.all(np.isfinite(theta)) or not np.isfinite(cost):
        nan = np.full(motion.n_params, np.nan)
        return EstimateResult(motion.param_names, nan, nan, np.full((motion.n_params,) * 2,
                              np.nan), {k: (np.nan, np.nan) for k in names_nu}, DIVERGED,
                              iterations, np.inf, n - motion.n_params, method, motion,
                              None, starts, "the solve left the region where the model is "
                              "defined (non-finite predictions)")
    j_theta, j_nu = obs.jacobian_grouped(theta, nu)  # the problem's noise is grouped too
    jac = j_theta if known_nuisance else np.concatenate([j_theta, j_nu], axis=-1)
    w = problem.noise.whiten(jac, axis=-2)
    info = w.T @ w
    names = motion.param_names + (() if known_nuisance else names_nu)
    values = theta if known_nuisance else np.concatenate([theta, nu])
    bound = bound_from_information(info, names, values, obs.meas, motion, known_nuisance,
                                   dict(zip(names_nu, nu, strict=True)))
    p = motion.n_params
    std = bound.std[:p]
    cov = bound.covariance[:p, :p]
    nuis = {}
    for i, name in enumerate(names_nu):
        s = np.nan if known_nuisance else bound.std[p + i]
        nuis[name] = (float(nu[i]), float(s) if not known_nuisance else 0.0)
    dof = problem.noise.rank - len(names)
    status = CONVERGED if converged else NOT_CONVERGED
    message = ""
    if not bound.observability.full_rank:
        status = UNOBSERVABLE
        message = (f"the data determine only {bound.rank} of the {len(names)} unknowns; "
                   "parameters marked unobservable are not estimates")
    elif not converged:
        message = "the iteration limit was reached before the convergence tests were met"
    return EstimateResult(motion.param_names, theta.copy(), std, cov, nuis, status,
                          int(iterations), float(2.0 * cost), dof, method, motion, bound,
                          starts, message)


def estimate(meas: MeasurementSet, motion: MotionModel,
             init: Mapping[str, float] | ArrayLike | None = None,
             options: Mapping[str, Mapping[str, object]] | None = None,
             known_nuisance: Mapping[str, float] | None = None,
             grid: GridSettings | None = None, max_iter: int = 100) -> EstimateResult:
    """Maximum-likelihood estimate of the motion parameters from a measurement set.

    ``init`` (optional) is a starting point by name or as a vector; without it the grid of
    :mod:`tmakit.batch.init` finds the starting points.  ``options`` selects the nuisance
    model per kind (``{"frequency": {"drift": True}, "power": {"exponent": None}}``).
    ``known_nuisance`` fixes the nuisance parameters at the given values instead of
    estimating them.
    """
    obs = ObservationModel(meas, motion, options)
    fixed = None if known_nuisance is None else obs.nuisance_vector(known_nuisance)
    problem = VarProProblem(obs, None, fixed)
    y = obs.values
    if init is not None:
        theta0 = (motion.theta(init) if isinstance(init, Mapping)
                  else np.asarray(init, dtype=float)).reshape(1, -1)
        if theta0.shape[1] != motion.n_params:
            raise ValueError(f"init must give {motion.n_params} values "
                             f"({', '.join(motion.param_names)})")
    else:
        theta0 = best_starts(problem, y, grid)
        if theta0.shape[0] == 0:
            raise ValueError("no starting point gives finite predictions; check the data")
    # The best grid point first; the others only if its fit is implausible (chi2 far above
    # its degrees of freedom), so that a local minimum is not taken for the answer.
    sol = levenberg_marquardt(problem, y, theta0[:1], max_iter=max_iter)
    dof = problem.noise.rank - motion.n_params - (0 if fixed is not None else obs.n_nuisance)
    used = 1
    if theta0.shape[0] > 1 and not (sol.converged[0] and plausible_chi2(2 * sol.cost[0], dof)):
        more = levenberg_marquardt(problem, y, theta0[1:], max_iter=max_iter)
        sol = _stack(sol, more)
        used = theta0.shape[0]
    best = int(np.argmin(np.where(np.isfinite(sol.cost), sol.cost, np.inf)))
    return _result(problem, sol.theta[best], sol.nuisance[best], float(sol.cost[best]),
                   int(sol.iterations[best]), bool(sol.converged[best]), "ml",
                   used, known_nuisance is not None)


def plausible_chi2(chi2: float, dof: int) -> bool:
    """Whether a weighted sum of squares is consistent with its degrees of freedom (within
    about five standard deviations of the chi-square distribution)."""
    dof = max(dof, 1)
    return bool(np.isfinite(chi2) and chi2 <= dof + 5.0 * np.sqrt(2.0 * dof) + 5.0)


def _stack(a: SolveResult, b: SolveResult) -> SolveResult:
    return SolveResult(np.concatenate([a.theta, b.theta]),
                       np.concatenate([a.nuisance, b.nuisance]),
                       np.concatenate([a.cost, b.cost]),
                       np.concatenate([a.iterations, b.iterations]),
                       np.concatenate([a.converged, b.converged]), b.evaluation)
