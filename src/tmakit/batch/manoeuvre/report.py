"""The manoeuvre estimator's result.

The chosen fit in the user's parameterisation, its covariance (the inverse Fisher information
of the fitted parameters, Hörst & Oispuu (2010), eq. 9), the order selection and the state at
the last measurement time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...core.arrays import Array
from ...motion import FixedParameters, PiecewiseCurvilinear
from ...motion.curvilinear import ForwardPiecewise
from ...observation import ObservationModel
from ...results.answers import finite
from ...results.estimate import EstimateResult, assemble_result
from ...results.status import CONVERGED, DIVERGED, NOT_CONVERGED
from .search import ManoeuvreSearch, OrderFit
from .selection import OrderSelection, fit_criterion


@dataclass
class ManoeuvreEstimate(EstimateResult):
    """An :class:`~tmakit.results.estimate.EstimateResult` for the chosen manoeuvres.

    Parameters
    ----------
    selection : OrderSelection, optional
        The model-order selection (None when one order was fitted).
    fits : list of OrderFit
        Every order's fit.
    held : list of str
        The accelerations held at zero (value and std 0).
    final_time : float
        The last measurement time (s).
    final : dict
        The state at ``final_time``: ``{name: (value, std)}`` (SI).

    References
    ----------
    Hörst & Oispuu (2010), eq. 9 (the covariance).
    """

    selection: OrderSelection | None = None
    fits: list[OrderFit] = field(default_factory=list)
    held: list[str] = field(default_factory=list)
    final_time: float = float("nan")
    final: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def manoeuvres(self) -> int:
        """The number of manoeuvres of the chosen model."""
        return int(getattr(self.motion, "manoeuvres", 0))

    def change_over_times(self) -> list[tuple[float, float]]:
        """List the change-over times.

        Returns
        -------
        list of tuple of float
            ``(value, std)`` of every change-over time (s).
        """
        return [(float(self.estimate[i]), float(self.std[i]))
                for i, n in enumerate(self.parameters) if n.startswith("t_")]

    def _fields(self) -> dict[str, object]:
        """Add the manoeuvres, held accelerations, order selection and final state."""
        data = super()._fields()
        data["manoeuvres"] = self.manoeuvres
        data["held_at_zero"] = list(self.held)
        data["model_order"] = self.selection.as_dict() if self.selection else None
        data["change_over_times"] = [{"value": finite(v), "std": finite(s)}
                                     for v, s in self.change_over_times()]
        data["final_state"] = {"time": finite(self.final_time),
                               **{k: {"value": finite(v) if np.isfinite(s) else None,
                                      "std": finite(s)}
                                  for k, (v, s) in self.final.items()}}
        return data

    def summary(self, units: str = "si") -> str:
        """Describe the estimate, the order selection and the final position (m), as text."""
        parts = [super().summary(units)]
        if self.selection is not None:
            parts.append(self.selection.summary())
        if self.final and self.status in ("converged", "unobservable"):
            x, sx = self.final["x"]
            y, sy = self.final["y"]
            if np.isfinite(sx) and np.isfinite(sy):  # no number for what is unobservable
                parts.append(f"position at t = {self.final_time:g} s: x = {x:.1f} m (std "
                             f"{sx:.3g}), y = {y:.1f} m (std {sy:.3g})")
            else:
                parts.append(f"position at t = {self.final_time:g} s: unobservable")
        return "\n".join(parts)


def reference(model: ForwardPiecewise, theta: Array, ref_time: float) -> Array:
    """Give the same trajectory in :class:`PiecewiseCurvilinear` parameters at ``ref_time``."""
    state = model.segment_states(theta, np.array([ref_time]))[0]
    out = np.array(theta, dtype=float)
    out[:4] = state
    out[3] = (state[3] + math.pi) % (2 * math.pi) - math.pi
    if out[3] == -math.pi:
        out[3] = math.pi
    return out


def report(search: ManoeuvreSearch, fit: OrderFit, ref_time: float,
           selection: OrderSelection | None, fits: list[OrderFit]) -> ManoeuvreEstimate:
    """Report the chosen fit in the user's parameterisation, with its covariance.

    References
    ----------
    Hörst & Oispuu (2010), eq. 9.
    """
    m = fit.manoeuvres
    motion = PiecewiseCurvilinear(m, ref_time)
    pr = search.problem(m)
    assert isinstance(pr.obs.motion, ForwardPiecewise)  # the search fits in that form
    theta = reference(pr.obs.motion, fit.theta, ref_time)
    if not np.all(np.isfinite(theta)) or not np.isfinite(fit.chi2):
        nan = np.full(motion.n_params, np.nan)
        return ManoeuvreEstimate(motion.param_names, nan, nan,
                                 np.full((motion.n_params,) * 2, np.nan),
                                 {k: (np.nan, np.nan) for k in pr.obs.nuisance_names},
                                 DIVERGED, chi2=np.inf, dof=pr.noise.rank - fit.unknowns,
                                 message="the solve left the region where the model is "
                                         "defined (non-finite predictions)", method="ml",
                                 motion=motion, selection=selection, fits=fits,
                                 final_time=search.t_end, iterations=fit.iterations,
                                 starts=fit.starts)
    free = fit.free_mask()
    held = [n for n, f in zip(motion.param_names, free, strict=True) if not f]
    # the information of the fitted parameters only: a held acceleration is no unknown
    fitted = FixedParameters(motion, dict.fromkeys(held, 0.0)) if held else motion
    # a fit settled on a corner of the likelihood says so in its note, not as "iteration limit"
    res = assemble_result(ObservationModel(search.meas, fitted, search.options), pr.noise,
                          theta[free], fit.nuisance, fit.chi2 / 2.0, fit.iterations,
                          fit.converged or bool(fit.note), "ml", fit.starts,
                          search.known, fit.note)
    status = res.status if fit.converged or res.status != CONVERGED else NOT_CONVERGED
    p = motion.n_params
    std = np.zeros(p)
    std[free] = res.std
    cov = np.zeros((p, p))
    cov[np.ix_(free, free)] = res.covariance
    message = res.message
    if held:
        note = (f"held at zero as the data do not need them ({fit_criterion(search.s)}): "
                f"{', '.join(held)}")
        message = f"{message}; {note}" if message else note
    assert res.bound is not None
    return ManoeuvreEstimate(motion.param_names, theta, std, cov, res.nuisance, status,
                             chi2=fit.chi2, dof=res.dof, bound=res.bound, message=message,
                             final=res.bound.derived(search.t_end), held=held, method="ml",
                             motion=motion, selection=selection, fits=fits,
                             final_time=search.t_end, iterations=fit.iterations,
                             starts=fit.starts)
