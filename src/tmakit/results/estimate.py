"""A batch estimate as a result: named parameters with standard deviations and covariance,
nuisance values, chi2, and a status that is never hidden (``converged``, ``did not converge``,
``unobservable``, ``diverged``).  Every batch estimator returns an :class:`EstimateResult`;
:func:`assemble_result` builds one from a weighted least-squares fit.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from .bound import Bound, bound_from_information

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


def assemble_result(obs: ObservationModel, noise: NoiseModel, theta: NDArray, nu: NDArray,
                    cost: float, iterations: int, converged: bool, method: str, starts: int,
                    known_nuisance: bool, note: str = "") -> EstimateResult:
    """The result of a weighted least-squares fit at ``theta`` (motion parameters) and ``nu``
    (nuisance): covariance from the Fisher information at the fit, chi2 from ``cost`` (half
    the weighted sum of squares), and the status ``converged``, ``did not converge``,
    ``unobservable`` or ``diverged``."""
    motion = obs.motion
    n = len(obs.meas)
    names_nu = obs.nuisance_names
    if not np.all(np.isfinite(theta)) or not np.isfinite(cost):
        nan = np.full(motion.n_params, np.nan)
        return EstimateResult(motion.param_names, nan, nan, np.full((motion.n_params,) * 2,
                              np.nan), {k: (np.nan, np.nan) for k in names_nu}, DIVERGED,
                              iterations, np.inf, n - motion.n_params, method, motion,
                              None, starts, "the solve left the region where the model is "
                              "defined (non-finite predictions)")
    j_theta, j_nu = obs.jacobian_grouped(theta, nu)  # the noise model is grouped too
    jac = j_theta if known_nuisance else np.concatenate([j_theta, j_nu], axis=-1)
    w = noise.whiten(jac, axis=-2)
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
    dof = noise.rank - len(names)
    status = CONVERGED if converged else NOT_CONVERGED
    message = ""
    if not bound.observability.full_rank:
        status = UNOBSERVABLE
        message = (f"the data determine only {bound.rank} of the {len(names)} unknowns; "
                   "parameters marked unobservable are not estimates")
    elif not converged:
        message = "the iteration limit was reached before the convergence tests were met"
    if note:
        message = f"{message}; {note}" if message else note
    return EstimateResult(motion.param_names, theta.copy(), std, cov, nuis, status,
                          int(iterations), float(2.0 * cost), dof, method, motion, bound,
                          starts, message)
