"""Sanity checks that speak: an improbable fit, angles that look like radians, far positions.

Each check returns :class:`SanityWarning` objects: a code and a sentence with the rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import chi2 as chi2_dist
from ..data import KIND_CODES, MeasurementSet
from ..measurements import model_for
from ..observation import ObservationModel
from .answers import Answer, bearing_interval, estimate_answer
from .solutions import range_spread

CHI2_P_LIMIT = 0.001
"""A fit whose chi-square has a smaller upper-tail probability is flagged improbable."""

RADIAN_MIN_ROWS = 3
"""Fewest rows of an angle kind for the radians check."""

FAR_FROM_ORIGIN = 100_000.0
"""Distance from the ENU origin (m) beyond which positions are warned about."""

FAR_FACTOR = 10.0
"""An estimate this many times farther than the farthest sensor is warned about."""


FAST_SPEED = 1e4
"""An estimated speed (m/s) above this is warned about (faster than an orbiting satellite)."""


@dataclass(frozen=True)
class SanityWarning:
    """A warning about the data or a fit.

    Parameters
    ----------
    code, message : str
        E.g. ``improbable-chi2``; what was seen, the rule, and what to do.
    """

    code: str
    message: str

    def as_dict(self) -> dict[str, str]:
        """Return ``{"code": ..., "message": ...}``.

        Returns
        -------
        dict
        """
        return {"code": self.code, "message": self.message}


def chi2_probability(chi2: float, dof: int) -> float | None:
    """Return the upper-tail probability of a chi-square value, ``P(chi2_dof >= chi2)``."""
    if dof <= 0 or not np.isfinite(chi2):
        return None
    return float(chi2_dist.sf(chi2, dof))


def chi2_warning(chi2: float, dof: int, limit: float = CHI2_P_LIMIT) -> SanityWarning | None:
    """Flag a fit whose chi-square is improbable (``p < limit``) and name the likely causes."""
    p = chi2_probability(chi2, dof)
    if p is None or p >= limit:
        return None
    return SanityWarning(
        "improbable-chi2",
        f"the fit is improbable under the stated noise: chi2 = {chi2:.4g} on {dof} degrees of "
        f"freedom (chi2/dof = {chi2 / dof:.3g}, p = {p:.2g} < {limit:g}). Likely causes: the "
        "target manoeuvred (try a manoeuvring motion, curvilinear[:M], or a shorter leg), the "
        "sigma are too small (rescale them from the residuals: scale_sigma, --scale-sigma), "
        "or outliers (look at the residuals in units of sigma: --plot)")


def chi2_low_warning(chi2: float, dof: int, limit: float = CHI2_P_LIMIT
                     ) -> SanityWarning | None:
    """Flag a fit whose chi-square is improbably small (``P(chi2_dof <= chi2) < limit``)."""
    if dof <= 0 or not np.isfinite(chi2):
        return None
    p = float(chi2_dist.cdf(chi2, dof))
    if p >= limit:
        return None
    ratio = chi2 / dof
    factor = (f"about {1.0 / np.sqrt(ratio):.3g} times too large" if ratio > 0 else
              "larger than any residual (the residuals are zero: noise-free data?)")
    return SanityWarning(
        "chi2-too-small",
        f"the fit is too good to be true: chi2 = {chi2:.4g} on {dof} degrees of freedom "
        f"(chi2/dof = {ratio:.3g}, P(chi2 <= {chi2:.4g}) "
        f"{f'= {p:.2g}' if p > 0 else '< 1e-300'} < {limit:g}). The stated "
        f"sigma look {factor}, so the std and ellipses printed are too large by that factor "
        "(or the data are synthetic, without noise); --scale-sigma (scale_sigma in Python) "
        "rescales them from the residuals")


def radian_warnings(meas: MeasurementSet) -> list[SanityWarning]:
    """Warn about angle kinds in degrees whose values all look like radians."""
    found = []
    for kind in meas.kinds:
        if model_for(kind).file_unit != "deg":
            continue
        rows, largest = _kind_extent(meas, kind)
        if rows < RADIAN_MIN_ROWS or largest > 2 * np.pi:
            continue
        values = meas.value[meas.kind_mask(kind)]
        found.append(SanityWarning(
            "radians",
            f"every {kind} value lies within ±2π ({np.min(values):.3g} .. {np.max(values):.3g}) "
            f"although the file's unit is degrees: were they written in radians? Multiply by "
            f"180/π ({values.size} rows; rule: all |{kind}| <= 2π with at least "
            f"{RADIAN_MIN_ROWS} rows)"))
    return found


_BLOCK = 1 << 14  # rows read at a time by the checks of a whole set (temporaries kept in cache)


def _kind_extent(meas: MeasurementSet, kind: str) -> tuple[int, float]:
    """Give the number of rows of ``kind`` and their largest magnitude in file units."""
    one = len(meas.kinds) == 1
    code = KIND_CODES[kind]
    rows, largest = (len(meas), 0.0) if one else (0, 0.0)
    value = meas.value
    for lo in range(0, len(meas), _BLOCK):
        block = np.abs(value[lo:lo + _BLOCK])
        if not one:
            mine = meas.kind_code[lo:lo + _BLOCK] == code
            rows += int(np.count_nonzero(mine))
            block = block[mine]
        if block.size:
            largest = max(largest, float(np.max(block)))
    return rows, largest


def _farthest_sensor(meas: MeasurementSet) -> tuple[int, float]:
    """Give the row whose sensor is farthest from the ENU origin horizontally, and how far (m)."""
    k, far2 = 0, -1.0
    for lo in range(0, len(meas), _BLOCK):
        east, north = meas.sensor_state[lo:lo + _BLOCK, 0], meas.sensor_state[lo:lo + _BLOCK, 1]
        d2 = east * east
        d2 += north * north
        i = int(np.argmax(d2))
        if d2[i] > far2:
            k, far2 = lo + i, float(d2[i])
    return k, float(np.sqrt(far2)) if far2 >= 0 else -1.0


def sensor_distance_warnings(meas: MeasurementSet, farthest: tuple[int, float] | None = None
                             ) -> list[SanityWarning]:
    """Warn about sensors far from the ENU origin."""
    if not len(meas):
        return []
    k, far = _farthest_sensor(meas) if farthest is None else farthest
    if far <= FAR_FROM_ORIGIN:
        return []
    return [SanityWarning(
        "far-sensor",
        f"sensor {meas.sensor_names[meas.sensor_code[k]]} is {far / 1000:.4g} km from the ENU "
        f"origin (time {meas.time[k]:g} s); beyond {FAR_FROM_ORIGIN / 1000:g} km the flat local "
        "frame departs from the Earth (curvature, the turn of North): take an origin near the "
        "sensors, or check the positions' unit")]


def measurement_warnings(meas: MeasurementSet, farthest: tuple[int, float] | None = None
                         ) -> list[SanityWarning]:
    """Return the warnings about a measurement set (radians, sensors far from the origin).

    Parameters
    ----------
    meas : MeasurementSet
    farthest : (int, float), optional
        The row of the sensor farthest from the origin and its distance, m, if known.

    Returns
    -------
    list of SanityWarning
    """
    return [*radian_warnings(meas), *sensor_distance_warnings(meas, farthest)]


def estimate_distance_warning(position: NDArray[np.float64], meas: MeasurementSet,
                              reach: float | None = None) -> SanityWarning | None:
    """Warn about an estimated position far from the origin and from every sensor."""
    position = np.asarray(position, dtype=float)
    if not np.all(np.isfinite(position[:2])) or not len(meas):
        return None
    d = float(np.linalg.norm(position[:2]))
    reach = _farthest_sensor(meas)[1] if reach is None else reach
    if d <= max(FAR_FROM_ORIGIN, FAR_FACTOR * reach):
        return None
    return SanityWarning(
        "far-estimate",
        f"the estimated position is {d / 1000:.4g} km from the ENU origin, more than "
        f"{FAR_FACTOR:g} times the farthest sensor ({reach / 1000:.3g} km): the data may not "
        "determine it (bearings in the wrong unit, too little geometry)")


def solutions_warning(solutions: list[Any]) -> SanityWarning | None:
    """Warn that separated solutions fit the data about as well as the reported one."""
    if len(solutions) < 2:
        return None
    best = solutions[0].result
    others = "; ".join(f"#{s.rank}: chi2 = {s.result.chi2:.4g}, LR = {s.lr_statistic:.3g}, "
                       f"p = {s.p_value:.2g}" for s in solutions[1:])
    return SanityWarning(
        "several-solutions",
        f"{len(solutions)} separated solutions fit the data about equally well (the reported "
        f"one: chi2 = {best.chi2:.4g}; {others}; kept when the likelihood-ratio test against "
        "the reported fit gives p >= 0.05): the reported std describe one of them, not the "
        "whole uncertainty. All are listed (table 'solutions', JSON 'solutions') and drawn "
        "(--plot); what tells them apart: data from another geometry (an own-ship manoeuvre), a "
        "motion model that can follow the contact, or sigma from the residuals (--scale-sigma)")


def range_spread_warning(solutions: list[Any], meas: MeasurementSet) -> SanityWarning | None:
    """Warn that the solutions' ranges disagree: the range is not determined, only the bearing."""
    spread = range_spread(solutions, meas) if len(meas) else None
    if spread is None:
        return None
    a = solutions[0].answer(meas)
    span = bearing_interval(a, meas)
    return SanityWarning("position-undetermined", (
        f"the separated solutions' ranges from {a.sensor} at t = {a.time:g} s, "
        f"{spread[0] / 1000:.4g} km to {spread[1] / 1000:.4g} km, lie outside one another's 95 "
        "% intervals: the minima lie along the line of sight and the data do not determine the "
        "range. The "
        "reported 95 % region is the bearing interval"
        + ("" if span is None else f", {span[0]:.1f} deg ± {span[1]:.2g} deg")
        + ". An own-ship manoeuvre across the line of sight would pin the range down"))


def fit_warnings(result: object, meas: MeasurementSet, answer: Answer | None = None
                 ) -> list[SanityWarning]:
    """Return every warning about a batch estimate and the measurements it fitted.

    ``answer``, if given, is ``estimate_answer(result, meas)`` (at the last time), computed once.
    """
    farthest = _farthest_sensor(meas) if len(meas) else None
    found = measurement_warnings(meas, farthest)
    chi2, dof = float(result.chi2), int(result.dof)  # type: ignore[attr-defined]
    solutions = getattr(result, "solutions", [])
    found += [w for w in (chi2_warning(chi2, dof), chi2_low_warning(chi2, dof),
                          solutions_warning(solutions), range_spread_warning(solutions, meas))
              if w is not None]
    theta = np.asarray(result.estimate, dtype=np.float64)  # type: ignore[attr-defined]
    if np.all(np.isfinite(theta)) and len(meas):
        motion = result.motion  # type: ignore[attr-defined]
        state = motion.states(theta, np.array([float(np.max(meas.time))]))[0]
        far = estimate_distance_warning(state[:3], meas, None if farthest is None
                                        else farthest[1])
        if far is not None:
            found.append(far)
        speed = float(np.linalg.norm(state[3:6]))
        if not speed <= FAST_SPEED:
            span = float(np.max(meas.time) - np.min(meas.time))
            found.append(SanityWarning("implausible-speed", (
                f"the estimated speed, {speed:.3g} m/s, is faster than any craft near the "
                f"Earth (more than {FAST_SPEED:g} m/s): the answer is not to be trusted. Are "
                f"the times in seconds (the data span {span:.3g} s)? Otherwise the data do "
                "not determine the motion (try a simpler --motion, or more data)")))
        found.extend(undetermined_warnings(result, meas, answer))
    wider = wider_model_warning(result, meas)
    if wider is not None:
        found.append(wider)
    return found


def wider_undetermined(wider: Any, meas: MeasurementSet | None, time: float | None = None) -> bool:
    """Whether the widest model's fit leaves the position at ``time`` undetermined."""
    return not wider.converged or not wider.answer(meas, time).position_determined


def wider_model_warning(result: object, meas: MeasurementSet) -> SanityWarning | None:
    """Warn that the position holds only under the reported fit's model."""
    wider = getattr(result, "wider", None)
    if wider is None or not len(meas):
        return None
    a = estimate_answer(wider, meas)
    why = ("its fit is " + str(wider.status) if str(wider.status) != "converged"
           else "range " + "; ".join(w for w in a.undetermined if w.startswith("range"))
           if a.enu[0] is not None else "the position is unobservable")
    span = bearing_interval(a, meas)
    bearing = ("bearing not determined either" if span is None else
               f"the bearing from {a.sensor} is {span[0]:.1f} deg ± {span[1]:.2g} deg (95 %)")
    return SanityWarning("position-undetermined", (
        f"the position at t = {a.time:g} s holds only if the target made no manoeuvre beyond "
        f"those of the reported fit ({result.motion.name}): with the model asked for "  # type: ignore[attr-defined]
        f"({wider.motion.name}, every acceleration fitted) the data do not determine it "
        f"({why}); {bearing}. A manoeuvre the bearings cannot rule out would move it: the "
        "ellipse assumes none, and the reported 95 % region is the bearing interval. An "
        "own-ship manoeuvre after the target's last one would pin the range down"))


def undetermined_warnings(result: object, meas: MeasurementSet, answer: Answer | None = None
                          ) -> list[SanityWarning]:
    """Return a warning when the answer leaves out quantities the data do not determine.

    With the range undetermined, a second (``ellipse-not-a-bound``) says that the position's
    ellipse, however small, is no bound on the truth.
    """
    answer = estimate_answer(result, meas) if answer is None else answer
    weak = answer.undetermined
    if not weak:
        return []
    ranged = any(w.startswith("range") for w in weak)
    found = [SanityWarning("undetermined", (
        "the data do not determine " + ", ".join(weak) + " although the fit converged: these "
        "are left out of the answer (shown as unobservable)"
        + ("" if ranged else ", and the position's ellipse is wide")
        + ". More data, or an own-ship manoeuvre across the line of sight, would pin them "
        "down"))]
    e = answer.ellipse
    if ranged and e is not None:
        found.append(SanityWarning("ellipse-not-a-bound", (
            f"the position's {e.level:.0%} ellipse ({e.semi_major:.3g} x {e.semi_minor:.3g} m) "
            "cannot be trusted to hold the truth: it is the fit's covariance linearised at the "
            f"estimate, and with the range from {answer.sensor} undetermined (its 1-sigma above "
            "3 times the range) the likelihood does not close around the estimate, so the "
            "truth may lie far outside the ellipse, at another range, however small the "
            "ellipse is")))
    return found


def normalised_residuals(result: object, meas: MeasurementSet,
                         options: Mapping[str, Mapping[str, object]] | None = None
                         ) -> NDArray[np.float64]:
    """Return each row's residual at the fit in units of its sigma (NaN for a diverged fit).

    Parameters
    ----------
    result, meas : EstimateResult, MeasurementSet
        A fit and the measurements fitted.
    options : mapping, optional
        The fit's measurement-model options.

    Returns
    -------
    ndarray, shape (n,)
    """
    theta = np.asarray(result.estimate, dtype=np.float64)  # type: ignore[attr-defined]
    if not np.all(np.isfinite(theta)):
        return np.full(len(meas), np.nan)
    obs = ObservationModel(meas, result.motion, options)  # type: ignore[attr-defined]
    nu = obs.nuisance_vector({k: v for k, (v, _) in
                              result.nuisance.items()})  # type: ignore[attr-defined]
    return obs.residuals(theta, nu) / meas.sigma_si


def scale_sigma(meas: MeasurementSet, residuals: NDArray[np.float64], dof: int
                ) -> tuple[MeasurementSet, dict[str, float]]:
    """Rescale each kind's sigma by ``sqrt(sum z_k^2 / (n_k dof / n))``: chi2/dof becomes 1.

    Parameters
    ----------
    meas : MeasurementSet
    residuals : ndarray, shape (n,)
        In units of sigma (:func:`normalised_residuals`).
    dof : int

    Returns
    -------
    scaled : MeasurementSet
    factors : dict of str to float

    Raises
    ------
    ValueError
        Without degrees of freedom or finite residuals.
    """
    residuals = np.asarray(residuals, dtype=float)
    if dof <= 0 or not np.all(np.isfinite(residuals)):
        raise ValueError("the noise can be rescaled only from a fit with finite residuals and "
                         "degrees of freedom left")
    share = dof / len(meas)
    factors = {}
    sigma = meas.sigma_si.copy()
    for kind in meas.kinds:
        rows = meas.kind_mask(kind)
        factors[kind] = float(np.sqrt(np.sum(residuals[rows] ** 2) / (rows.sum() * share)))
        if not factors[kind] > 0:
            raise ValueError(f"every {kind} residual is zero (noise-free data): the sigma "
                             "cannot be rescaled from them")
        sigma[rows] *= factors[kind]
    scaled = MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si, sigma,
                                    meas.sensor_state, meas.time_ref, meas.ref_sensor_state,
                                    dict(meas.metadata,
                                         sigma_scaled=",".join(f"{k}={v:.6g}"
                                                               for k, v in factors.items())))
    return scaled, factors
