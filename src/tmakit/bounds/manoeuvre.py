"""Cramér–Rao bounds for a piecewise curvilinearly moving target at a sequence of times.

Hörst & Oispuu (2010), §3, eqs. 7-9, and Fig. 2: at each ``t_ref`` the unknowns are the state
at ``t_ref``, every segment's accelerations and the change-over times of the manoeuvres started
(``t_m < t_ref``), from all measurements up to ``t_ref``.  ``known_manoeuvres=True`` holds the
manoeuvres at their truth (Ristic & Arulampalam (2003)).  Unobservable directions give infinite
std, named in :attr:`CrbPoint.bound`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import FixedParameters, MotionModel, PiecewiseCurvilinear
from ..results.answers import finite
from ..results.bound import Bound
from .fim import bound_source, crlb, truth_vector

if TYPE_CHECKING:  # pragma: no cover
    from ..scenario.model import Scenario

_ALIASES = {"azimuth": "bearing"}


@dataclass
class CrbPoint:
    """The bound at one reference time.

    Parameters
    ----------
    ref_time : float
        s.
    manoeuvres : int
        Manoeuvres started by ``ref_time``.
    n_measurements : int
        Measurements up to ``ref_time``.
    position : ndarray
        ``(2,)`` true ENU position, m.
    covariance : ndarray
        ``(2, 2)`` its bound, m^2.
    std : ndarray
        ``(2,)`` std bounds of x and y, m.
    rms : float
        ``sqrt(var x + var y)``, m.
    ellipse : dict of str to float
        As :meth:`tmakit.bounds.Bound.ellipse`.
    bound : Bound
        The full bound.

    References
    ----------
    Hörst & Oispuu (2010), eqs. 7-9.
    """

    ref_time: float
    manoeuvres: int
    n_measurements: int
    position: NDArray[np.float64]
    covariance: NDArray[np.float64]
    std: NDArray[np.float64]
    rms: float
    ellipse: dict[str, float]
    bound: Bound

    @property
    def parameters(self) -> tuple[str, ...]:
        """The unknowns of the bound, by name."""
        return self.bound.parameters

    @property
    def observable(self) -> bool:
        """True when the position at ``ref_time`` has a finite bound."""
        return bool(np.isfinite(self.rms))

    @property
    def extent(self) -> float:
        """Largest diameter of the confidence ellipse (m): twice the major semi-axis."""
        return 2.0 * float(self.ellipse["major"])


@dataclass
class CrbSequence:
    """Bounds at a sequence of reference times (one :class:`CrbPoint` each).

    Parameters
    ----------
    kinds : tuple of str
    known_manoeuvres : bool
    level : float
        The ellipses' probability.
    points : list of CrbPoint
    """

    kinds: tuple[str, ...]
    known_manoeuvres: bool
    level: float
    points: list[CrbPoint]

    @property
    def ref_times(self) -> NDArray[np.float64]:
        """The reference times (s)."""
        return np.array([p.ref_time for p in self.points])

    @property
    def rms(self) -> NDArray[np.float64]:
        """Position RMS bound ``sqrt(var x + var y)`` (m) at each reference time."""
        return np.array([p.rms for p in self.points])

    @property
    def std(self) -> NDArray[np.float64]:
        """Bounds on the standard deviations of x and y ``(T, 2)`` (m)."""
        return np.array([p.std for p in self.points])

    def at(self, ref_time: float) -> CrbPoint:
        """Give the point at a reference time (one of :attr:`ref_times`, s).

        Parameters
        ----------
        ref_time : float

        Returns
        -------
        CrbPoint

        Raises
        ------
        KeyError
            For a time that is not one of :attr:`ref_times`.
        """
        hits = np.flatnonzero(self.ref_times == float(ref_time))
        if hits.size == 0:
            raise KeyError(f"no bound at reference time {ref_time:g} s; reference times are "
                           f"{self.ref_times[0]:g} .. {self.ref_times[-1]:g} s "
                           f"({len(self.points)} of them)")
        return self.points[int(hits[0])]

    def label(self) -> str:
        """Name the kinds used (and known manoeuvres), for titles and legends.

        Returns
        -------
        str
        """
        kinds = " + ".join("azimuth" if k == "bearing" else k.replace("_", " ")
                           for k in self.kinds)
        return kinds + (", manoeuvres known" if self.known_manoeuvres else "")

    def summary(self) -> str:
        """Tabulate the bounds, one line per reference time (m).

        Returns
        -------
        str
            The table.
        """
        lines = [f"Cramér–Rao bound, {self.label()}: position at t_ref from the data up to "
                 f"t_ref ({self.level:.0%} ellipses)",
                 f"  {'t_ref (s)':>9} {'manoeuvres':>10} {'unknowns':>8} {'samples':>7} "
                 f"{'std x (m)':>11} {'std y (m)':>11} {'RMS (m)':>11} {'major (m)':>11} "
                 f"{'minor (m)':>11}"]

        def fmt(v: float) -> str:
            return f"{v:11.4g}" if np.isfinite(v) else f"{'unobs.':>11}"

        for p in self.points:
            lines.append(f"  {p.ref_time:9.6g} {p.manoeuvres:10d} {len(p.parameters):8d} "
                         f"{p.n_measurements:7d} {fmt(p.std[0])} {fmt(p.std[1])} "
                         f"{fmt(p.rms)} {fmt(p.ellipse['major'])} {fmt(p.ellipse['minor'])}")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, object]:
        """Give the bounds as JSON-ready data (SI units; non-finite numbers as None).

        Returns
        -------
        dict of str to object
            ``kinds``, ``known_manoeuvres``, ``level`` and ``points``.
        """
        return {
            "kinds": list(self.kinds), "known_manoeuvres": self.known_manoeuvres,
            "level": self.level,
            "points": [{"ref_time": p.ref_time, "manoeuvres": p.manoeuvres,
                        "parameters": list(p.parameters), "n_measurements": p.n_measurements,
                        "position": [float(v) for v in p.position],
                        "std": [finite(v) for v in p.std], "rms": finite(p.rms),
                        "ellipse": {k: (finite(v) if isinstance(v, float) else v)
                                    for k, v in p.ellipse.items()}}
                       for p in self.points],
        }


def _check_change_over_times(motion: PiecewiseCurvilinear, theta: NDArray[np.float64]
                             ) -> NDArray[np.float64]:
    """Check the truth is finite with increasing change-over times; give those times (s)."""
    cot = theta[6 + 2 * motion.manoeuvres:]
    if not np.all(np.isfinite(theta)):
        bad = [n for n, v in zip(motion.param_names, theta, strict=True) if not np.isfinite(v)]
        raise ValueError(f"truth: {', '.join(bad)} must be finite numbers")
    if np.any(np.diff(cot) <= 0):
        listing = ", ".join(f"t_{m + 1} = {v:g} s" for m, v in enumerate(cot))
        raise ValueError(f"truth: change-over times must be strictly increasing "
                         f"(t_1 < t_2 < ...); got {listing}")
    return cot


def curvilinear_crb_sequence(
    source: Scenario | MeasurementSet,
    ref_times: ArrayLike,
    kinds: Sequence[str] | None = None,
    known_manoeuvres: bool = False,
    *,
    motion: MotionModel | None = None,
    truth: Mapping[str, float] | ArrayLike | None = None,
    level: float = 0.9,
    nuisance: Mapping[str, float] | None = None,
    known_nuisance: bool = False,
    options: Mapping[str, Mapping[str, object]] | None = None,
) -> CrbSequence:
    """Bound the target position at each reference time, from the data up to that time.

    Manoeuvre ``m`` is unknown at ``t_ref`` only once started (``t_m < t_ref``); a sample at a
    change-over time belongs to the earlier segment.

    Parameters
    ----------
    source : Scenario or MeasurementSet
        A scenario with a piecewise curvilinear target, or a set with ``motion`` and ``truth``.
    ref_times : array_like
        s, inside the data's span.
    kinds : sequence of str, optional
        Kinds used (``"azimuth"`` means ``"bearing"``); default all.
    known_manoeuvres : bool
        Only the state at ``t_ref`` is unknown.
    motion : MotionModel, optional
        A :class:`~tmakit.motion.PiecewiseCurvilinear`, with a set.
    truth : mapping or array_like, optional
        Its parameters, SI, with a set.
    level : float
        The ellipses' probability.
    nuisance, known_nuisance, options
        As for :func:`tmakit.bounds.crlb`.

    Returns
    -------
    CrbSequence

    Raises
    ------
    ValueError
        For a target that is not piecewise curvilinear, change-over times out of order, a time
        outside the data, a kind the data lack, or ``level`` outside (0, 1).

    References
    ----------
    Hörst & Oispuu (2010), eqs. 7-9 and Fig. 2.
    """
    meas, motion, truth, nuisance, options = bound_source(
        source, motion, truth, nuisance, options, "curvilinear_crb_sequence()")
    if not isinstance(motion, PiecewiseCurvilinear):
        raise ValueError("curvilinear_crb_sequence() needs a piecewise curvilinear target "
                         f"(motion curvilinear:M); got {getattr(motion, 'name', motion)!r}")
    theta = truth_vector(motion, truth)
    cot = _check_change_over_times(motion, theta)
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be a probability between 0 and 1; got {level}")
    chosen = _chosen_kinds(meas, kinds)
    meas = meas.take(np.isin(meas.kind, chosen))
    refs = _checked_ref_times(meas, ref_times)
    points = [_point(meas, motion, theta, float(t_ref), int(np.sum(cot < t_ref)),
                     known_manoeuvres, level, dict(nuisance=nuisance,
                                                   known_nuisance=known_nuisance,
                                                   options=options))
              for t_ref in refs]
    return CrbSequence(chosen, bool(known_manoeuvres), float(level), points)


def _chosen_kinds(meas: MeasurementSet, kinds: Sequence[str] | None) -> tuple[str, ...]:
    """Resolve the kinds asked for (aliases too), all of them in the data."""
    if kinds is None:
        return tuple(meas.kinds)
    chosen = tuple(dict.fromkeys(_ALIASES.get(k, k) for k in kinds))
    missing = [k for k in chosen if k not in meas.kinds]
    if missing or not chosen:
        raise ValueError(f"kinds: {', '.join(missing) or 'none given'} not in the data "
                         f"(it has {', '.join(meas.kinds)})")
    return chosen


def _checked_ref_times(meas: MeasurementSet, ref_times: ArrayLike) -> NDArray[np.float64]:
    """Check the reference times (s): a vector, each inside the span of the data."""
    refs = np.atleast_1d(np.asarray(ref_times, dtype=float))
    if refs.ndim != 1 or refs.size == 0 or not np.all(np.isfinite(refs)):
        raise ValueError("ref_times must be a non-empty list of finite times (s)")
    first, last = float(meas.time.min()), float(meas.time.max())
    outside = refs[(refs < first) | (refs > last)]
    if outside.size:
        raise ValueError(f"reference time {outside[0]:g} s is outside the data (samples from "
                         f"{first:g} to {last:g} s); the bound at t_ref uses the data up to "
                         "t_ref and the state at t_ref")
    return refs


def _point(meas: MeasurementSet, motion: PiecewiseCurvilinear, theta: NDArray[np.float64],
           t_ref: float, started: int, known_manoeuvres: bool, level: float,
           crlb_options: dict[str, object]) -> CrbPoint:
    """Compute the bound at ``t_ref`` (s) from the data up to it."""
    model, theta_ref = motion.rereferenced(theta, t_ref, started)
    used: MotionModel = model
    values = theta_ref
    if known_manoeuvres:
        known = {n: float(v) for n, v in zip(model.param_names[4:], theta_ref[4:], strict=True)}
        used = FixedParameters(model, known)
        values = theta_ref[:4]
    rows = meas.take(meas.time <= t_ref)
    bound = crlb(rows, used, values, **crlb_options)  # type: ignore[arg-type]
    state, cov = bound.state_covariance(t_ref)
    c2 = cov[:2, :2]
    std = np.sqrt(np.diag(c2))
    rms = float(np.sqrt(c2[0, 0] + c2[1, 1]))
    return CrbPoint(t_ref, started, len(rows), state[:2].copy(), c2, std, rms,
                    bound.ellipse(t_ref, level), bound)
