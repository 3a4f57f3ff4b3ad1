"""A batch estimate as a result: :class:`EstimateResult` and the functions that build it."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import blas
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from .answers import (
    ELLIPSE_LEVEL,
    KNOT,
    Answer,
    estimate_answer,
    finite,
    in_bearing_interval,
    parameter_display,
)
from .bound import Bound, bound_from_information
from .checks import SanityWarning, chi2_probability, fit_warnings, wider_undetermined
from .context import geodetic_fix, origin_of
from .nuisance import KnownNuisance, as_known_nuisance
from .observability import Decomposition
from .solutions import Solution, fit_fields, range_spread
from .status import CONVERGED, DIVERGED, NOT_CONVERGED, UNOBSERVABLE, Status, fit_status
from .trust import Trust, trust_of


@dataclass
class EstimateResult:
    """A batch estimate: named parameters, std, nuisance values, and how the solve went.

    Parameters
    ----------
    parameters : tuple of str
        The motion parameters' names.
    estimate, std : ndarray, shape (p,)
        Their values and std, SI (m, m/s, rad, s); std inf where unobservable, 0 where held.
    covariance : ndarray, shape (p, p)
    nuisance : dict
        ``{name: (value, std)}`` (std 0 when known).
    status, message : Status, str
    iterations, dof, starts : int
        Iterations, degrees of freedom, starting points solved.
    chi2 : float
        The weighted sum of squares at the estimate.
    method : str
        A key of :data:`tmakit.batch.METHODS`.
    motion : MotionModel
    bound : Bound, optional
        The information at the estimate (None for the papers' own covariances).
    extra : dict, optional
        Method-specific diagnostics.
    solutions : list of Solution, optional
        Separated fits about as good, this one first.
    covers : list of EstimateResult, optional
        Close fits whose ellipses this one's covariance is widened to contain.
    wider : EstimateResult, optional
        The widest model's fit when it leaves the position undetermined and this one does not.
    """

    parameters: tuple[str, ...]
    estimate: NDArray[np.float64]
    std: NDArray[np.float64]
    covariance: NDArray[np.float64]
    nuisance: dict[str, tuple[float, float]]
    status: Status
    iterations: int
    chi2: float
    dof: int
    method: str
    motion: MotionModel
    bound: Bound | None = None
    starts: int = 1
    message: str = ""
    extra: dict[str, object] = field(default_factory=dict)
    solutions: list[Solution] = field(default_factory=list, repr=False, compare=False)
    covers: list[EstimateResult] = field(default_factory=list, repr=False, compare=False)
    wider: EstimateResult | None = field(default=None, repr=False, compare=False)

    @property
    def converged(self) -> bool:
        """Whether the status is ``converged``."""
        return self.status == CONVERGED

    def ranked_solutions(self) -> list[Solution]:
        """Return the solutions reported, this fit first.

        Returns
        -------
        list of Solution
        """
        return self.solutions or [Solution(self, 1, 0.0, 1.0)]

    def region_contains(self, position: ArrayLike, meas: MeasurementSet | None = None,
                        time: float | None = None, level: float = ELLIPSE_LEVEL) -> bool:
        """Tell whether a horizontal position lies in the reported region at ``time``.

        Parameters
        ----------
        position : array_like
            East, North, m.
        meas, time, level : optional
            As for :meth:`answer`.

        Returns
        -------
        bool
        """
        sols = self.ranked_solutions()
        if any(s.region_contains(position, meas, time, level) for s in sols):
            return True
        if range_spread(sols, meas, time, level) is not None and in_bearing_interval(
                position, self.answer(meas, time, level=level), meas, level):
            return True
        if self.wider is None:
            return False
        return (wider_undetermined(self.wider, meas, time)
                and in_bearing_interval(position, self.wider.answer(meas, time, level=level),
                                        meas, level))

    @property
    def chi2_p_value(self) -> float | None:
        """The upper-tail probability of :attr:`chi2` on :attr:`dof` degrees of freedom, or None."""
        return chi2_probability(self.chi2, self.dof)

    def as_dict(self, meas: MeasurementSet | None = None, *, answer: Answer | None = None,
                warnings: Sequence[SanityWarning] | None = None,
                sigma_scale: Mapping[str, float] | None = None) -> dict[str, object]:
        """Return the JSON form: the keys of ``tma estimate --json`` (SI; non-finite as None).

        Parameters
        ----------
        meas : MeasurementSet, optional
            The measurements fitted: with them ``answer``, ``warnings`` and ``geodetic`` are filled.
        answer, warnings : Answer, sequence of SanityWarning, optional
        sigma_scale : mapping of str to float, optional
            Each kind's sigma factor (``--scale-sigma``).

        Returns
        -------
        dict of str to object
        """
        if meas is not None:
            answer = self.answer(meas) if answer is None else answer
            warnings = self.warnings(meas) if warnings is None else warnings
        trust = trust_of(self, warnings or [])
        # what the data determine of an unobservable fit (a bearing) is shown; a solve that
        # stopped short shows nothing as an answer
        shown = answer if self.status in (CONVERGED, UNOBSERVABLE) else None
        return {**self._fields(), **trust.as_dict(),
                "geodetic": None if meas is None else self._geodetic(meas),
                "answer": None if shown is None else shown.as_dict(),
                "covariance": [[finite(c) if trust.answer else None for c in row]
                               for row in np.asarray(self.covariance)],
                "chi2_p_value": self.chi2_p_value,
                "warnings": None if warnings is None else [w.as_dict() for w in warnings],
                "sigma_scale": None if sigma_scale is None else dict(sigma_scale),
                "height": self.extra.get("height"),
                "legs": self.extra.get("legs"),
                "contact_legs": self.extra.get("contact_legs"),
                "ambiguity": self.extra.get("ambiguity"),
                "solutions": [sol.as_dict(meas) for sol in self.ranked_solutions()]}

    def _geodetic(self, meas: MeasurementSet) -> dict[str, object] | None:
        """Give the position at the reference time in lat/lon/alt."""
        if self.status in (UNOBSERVABLE, DIVERGED) or origin_of(meas) is None \
                or not self.estimate.size:
            return None  # no number for an unobservable position (an altitude of 2.5e9 m)
        t = float(getattr(self.motion, "ref_time", meas.time.min()))
        return geodetic_fix(meas, t, self.motion.states(self.estimate, np.array([t]))[0])

    def _fields(self) -> dict[str, object]:
        """Give the result's own fields in JSON form."""
        answer = self.status in (CONVERGED, UNOBSERVABLE)  # (unobservable: what is determined)
        data: dict[str, object] = {
            # no number for what the data do not determine ("unobservable" says why) nor for
            # a solve that stopped short ("last_iterate" keeps where it stopped)
            **fit_fields(self, [finite(v) if answer and np.isfinite(s) else None
                                for v, s in zip(self.estimate, self.std, strict=True)]),
            "nuisance": {k: {"value": finite(v), "std": finite(s)}
                         for k, (v, s) in self.nuisance.items()},
            "iterations": self.iterations,
            "method": self.method,
            "ref_time": _reference_time(self.motion),
            "starts": self.starts,
            "message": self.message,
            "unobservable": ([d.as_dict() for d in self.bound.observability.directions]
                             if self.bound is not None else []),
        }
        if not answer:
            data["last_iterate"] = [finite(v) for v in self.estimate]
        return data

    def answer(self, meas: MeasurementSet | None = None, time: float | None = None,
               sensor: str | None = None, level: float = ELLIPSE_LEVEL) -> Answer:
        """Return the estimate in the user's terms at one time.

        Parameters
        ----------
        meas : MeasurementSet, optional
            Origins and the sensor's track.
        time : float, optional
            s; default the last measurement time.
        sensor : str, optional
            For range and bearing; default the last measurement's.
        level : float, optional
            Probability inside the ellipse.

        Returns
        -------
        Answer

        Raises
        ------
        ValueError
            If ``time`` is not finite or far from the measurements.
        """
        return estimate_answer(self, meas, time, sensor, level)

    def warnings(self, meas: MeasurementSet) -> list[SanityWarning]:
        """Return the sanity warnings of the fit and of the measurements it fitted.

        Parameters
        ----------
        meas : MeasurementSet

        Returns
        -------
        list of SanityWarning
        """
        return fit_warnings(self, meas)

    def trust(self, meas: MeasurementSet) -> Trust:
        """Return how far to trust the estimate (:func:`tmakit.results.trust_of`).

        Parameters
        ----------
        meas : MeasurementSet

        Returns
        -------
        Trust
        """
        return trust_of(self, self.warnings(meas))

    def to_json(self, meas: MeasurementSet | None = None, indent: int | None = 2, *,
                answer: Answer | None = None, warnings: Sequence[SanityWarning] | None = None,
                sigma_scale: Mapping[str, float] | None = None) -> str:
        """Return :meth:`as_dict` as JSON text (that of ``tma estimate --json``).

        Parameters
        ----------
        meas, answer, warnings, sigma_scale, indent : optional
            As for :meth:`as_dict`; the JSON indent.

        Returns
        -------
        str
        """
        return json.dumps(self.as_dict(meas, answer=answer, warnings=warnings,
                                       sigma_scale=sigma_scale), indent=indent)

    def summary(self, units: str = "si") -> str:
        """Return a readable table: status, chi2, each parameter with its std and unit.

        Parameters
        ----------
        units : str, optional
            ``si`` or ``nautical`` (speeds in knots).

        Returns
        -------
        str
        """
        lines = [f"{self.method} estimate, motion {self.motion.name}: {self.status}"
                 f" after {self.iterations} iterations"
                 + (f" from {self.starts} starting points" if self.starts > 1 else ""),
                 f"chi2 = {self.chi2:.2f} on {self.dof} degrees of freedom"
                 + (f" (chi2/dof = {self.chi2 / self.dof:.3f})" if self.dof > 0 else "")]
        if self.message:
            lines.append(self.message)
        if len(self.solutions) > 1:
            lines.append(f"{len(self.solutions)} separated solutions fit the data about "
                         "equally well; this is the first: its std are not the whole "
                         "uncertainty (see the solutions)")
        ref = _reference_time(self.motion)
        if ref is not None:  # (what x, y, ... are at: the time origin the fit chose or was given)
            lines.append(f"parameters at the motion's reference time t = {ref:.15g} s")
        if self.status in (NOT_CONVERGED, DIVERGED):
            lines.append("no answer: the solve stopped short of an estimate, so no parameter "
                         "is printed (the JSON keeps its last iterate)")
            return "\n".join(lines)
        width = max(len(n) for n in (*self.parameters, *self.nuisance))
        lines.append(f"  {'parameter':<{width}}  {'estimate':>16}  {'std':>12}  unit")
        for n, v, s in (*zip(self.parameters, self.estimate, self.std, strict=True),
                        *((n, v, s) for n, (v, s) in self.nuisance.items())):
            v, s, unit = parameter_display(n, v, s)
            if units == "nautical" and unit == "m/s":
                v, s, unit = v / KNOT, s / KNOT, "kn"
            value = f"{v:16.13g}" if n in self.nuisance else f"{v:16.8g}"
            if not np.isfinite(s):
                value = f"{'-':>16}"  # not an estimate: no number for what is unobservable
            lines.append(f"  {n:<{width}}  {value}  "
                         + (f"{s:12.4g}" if np.isfinite(s) else f"{'unobservable':>12}")
                         + f"  {unit}")
        if self.bound is not None:
            for d in self.bound.observability.directions:
                lines.append(f"  unobservable: {d.sentence}")
        return "\n".join(lines)


def _reference_time(motion: MotionModel) -> float | None:
    """Give the time (s) of a motion's parameters; None for a fixed emitter."""
    ref = getattr(motion, "ref_time", None)
    return float(ref) if ref is not None and np.isfinite(ref) else None


def diverged_result(motion: MotionModel, nuisance_names: Sequence[str], iterations: int,
                    dof: int, method: str, message: str, starts: int = 1,
                    extra: dict[str, object] | None = None) -> EstimateResult:
    """Return the result of a diverged solve: values and std NaN, chi2 infinite."""
    p = motion.n_params
    nan = np.full(p, np.nan)
    return EstimateResult(motion.param_names, nan, nan, np.full((p, p), np.nan),
                          {k: (np.nan, np.nan) for k in nuisance_names}, DIVERGED, iterations,
                          np.inf, dof, method, motion, None, starts, message,
                          {} if extra is None else extra)


def result_from_covariance(motion: MotionModel, theta: NDArray[np.float64],
                           covariance: NDArray[np.float64],
                           nuisance: dict[str, tuple[float, float]], status: Status,
                           iterations: int, chi2: float, dof: int, method: str,
                           message: str = "", extra: dict[str, object] | None = None
                           ) -> EstimateResult:
    """Return the result of a fit whose method computed its own covariance (no bound)."""
    p = motion.n_params
    std = np.sqrt(np.clip(np.diag(covariance), 0.0, None))[:p]
    return EstimateResult(motion.param_names, theta.copy(), std, covariance[:p, :p], nuisance,
                          status, iterations, chi2, dof, method, motion, None, 1, message,
                          {} if extra is None else extra)


def assemble_result(obs: ObservationModel, noise: NoiseModel, theta: NDArray[np.float64],
                    nu: NDArray[np.float64],
                    cost: float, iterations: int, converged: bool, method: str, starts: int,
                    known_nuisance: KnownNuisance | None, note: str = "", *,
                    jacobian: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
                    information: NDArray[np.float64] | None = None,
                    decomposition: Decomposition | None = None) -> EstimateResult:
    """Return the result of a weighted least-squares fit: covariance from the information.

    Parameters
    ----------
    obs : ObservationModel
    noise : NoiseModel
        In the grouped row order of ``obs``.
    theta, nu : ndarray
        Motion parameters and nuisance at the fit, SI.
    cost : float
        Half the weighted sum of squares.
    converged : bool
    iterations, method, starts, known_nuisance
        As the fields of :class:`EstimateResult`; nuisance known (None: estimated).
    note : str, optional
        Appended to the message.
    jacobian, information, decomposition : optional
        ``obs.jacobian_grouped(theta, nu)``, the Fisher information and its decomposition
        (:func:`~tmakit.results.observability.analyse`'s), if the caller has them.

    Returns
    -------
    EstimateResult
    """
    known = as_known_nuisance(known_nuisance) is not None
    motion = obs.motion
    n = len(obs.meas)
    names_nu = obs.nuisance_names
    if not (math.isfinite(cost) and all(map(math.isfinite, theta.tolist()))):
        return diverged_result(motion, names_nu, iterations, n - motion.n_params, method,
                               "the solve left the region where the model is defined "
                               "(non-finite predictions)", starts)
    n_info = motion.n_params + (0 if known else len(names_nu))
    if information is not None and information.shape == (n_info, n_info):
        info = np.asarray(information, dtype=float)
    else:
        info, decomposition = _information(obs, noise, theta, nu, known, jacobian), None
    names = motion.param_names + (() if known else names_nu)
    values = theta if known else np.concatenate([theta, nu]) if len(nu) else theta.copy()
    nu_values = dict(zip(names_nu, nu, strict=True)) if names_nu else {}
    bound = bound_from_information(info, names, values, obs.meas, motion,
                                   KnownNuisance(nu_values) if known else None, nu_values,
                                   decomposition)
    p = motion.n_params
    nuis = {name: (float(nu[i]), 0.0 if known else float(bound.std[p + i]))
            for i, name in enumerate(names_nu)}
    dof = noise.rank - len(names)
    status, message = fit_status(converged, bound, len(names))
    if note:
        message = f"{message}; {note}" if message else note
    return EstimateResult(motion.param_names, theta.copy(), bound.std[:p],
                          bound.covariance[:p, :p], nuis, status,
                          int(iterations), float(2.0 * cost), dof, method, motion, bound,
                          starts, message)


def _information(obs: ObservationModel, noise: NoiseModel, theta: NDArray[np.float64],
                 nu: NDArray[np.float64], known: bool,
                 jacobian: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
                 ) -> NDArray[np.float64]:
    """Fisher information ``J'WJ`` at the fit; chunk by chunk for many rows."""
    n = len(obs.meas)
    chunks = n > blas.CHUNKED_ROWS and obs.n_nuisance == 0
    if jacobian is not None and not chunks:
        j_theta, j_nu = jacobian
        jac = j_theta if known else np.concatenate([j_theta, j_nu], axis=-1)
        w = noise.whiten(jac, axis=-2)
        return np.asarray(w.T @ w, dtype=float)
    info: float | NDArray[np.float64] = 0.0
    for lo, hi in noise.chunk_bounds(blas.CHUNK_ROWS) if chunks else [(0, n)]:
        part = obs.take(obs.order[lo:hi]) if chunks else obs
        j_theta, j_nu = part.jacobian_grouped(theta, nu)  # the noise model is grouped too
        jac = j_theta if known or j_nu.shape[-1] == 0 else np.concatenate([j_theta, j_nu], -1)
        if chunks and noise.correlated:  # whole blocks only: whitened by the chunk's own
            jac = NoiseModel(part.grouped, part.models).whiten(jac, axis=-2, overwrite=True)
        elif chunks:  # jac is this loop's own array: scaled in place
            jac *= noise.inv_sigma[lo:hi, None]
        w = jac if chunks else noise.whiten(jac, axis=-2, overwrite=True)
        info = info + w.T @ w
    return np.asarray(info, dtype=float)
