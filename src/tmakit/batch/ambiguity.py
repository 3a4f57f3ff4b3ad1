"""A towed array's port/starboard ambiguity, resolved leg by leg inside the batch fit.

Debrief's workflow: turn cuts left out, each leg's cuts on one side, every assignment of sides
fitted and the least chi-square chosen; docs/analyst.md describes the rules.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..results.context import clock_time
from ..results.estimate import EstimateResult
from ..results.own_legs import (
    MIN_TURN_DEG,
    RATE_WINDOW_S,
    TURN_RATE_DEG_S,
    LegsAndTurns,
    heading_rate,
    own_ship_legs,
    own_ship_sensors,
)
from ..results.solutions import separated_solutions

__all__ = ["MAX_EXHAUSTIVE_LEGS", "RESOLVED_RATIO", "SETTLE_S", "AmbiguityResult", "LegSide",
           "TurnCut", "resolve_ambiguity"]

SETTLE_S = 180.0
"""The array's settling time after a turn (s): cuts this soon after a turn ends are turn cuts."""

RESOLVED_RATIO = 100.0
"""The likelihood ratio (the chosen side against the other) at which a leg is resolved."""

MAX_EXHAUSTIVE_LEGS = 8
"""Up to this many legs (and parts) every assignment of sides is fitted; above, a search."""

ENDFIRE_DEG = 15.0
"""A leg's cuts are split into parts where the contact passes within this (deg) of the axis."""

ENDFIRE_RISE_DEG = 5.0
"""A pass near the axis ends when the angle from it has risen this much (deg) above its least."""

IMPROBABLE_P = 0.001
"""A best fit whose chi-square has a smaller p-value resolves no leg."""

PORT, STARBOARD = "port", "starboard"
_PARTS = 1000  # group id = leg * _PARTS + part


@dataclass(frozen=True)
class TurnCut:
    """A cut taken while the own ship turned, or while its array settled after a turn."""

    time: float  # s
    reason: str  # why it is a turn cut, in words
    kept: bool  # fitted anyway (keep_turn_cuts)


@dataclass(frozen=True)
class LegSide:
    """The side chosen for one own-ship leg's ambiguous cuts."""

    leg: int  # the leg's index (0-based)
    start: float  # its first cut, s
    stop: float  # and its last
    course_deg: float  # the own ship's course on the leg
    cuts: int  # its ambiguous cuts fitted
    side: str  # port or starboard: the best fit's
    delta_chi2: float  # chi-square with the leg on the other side minus the best's
    resolved: bool  # after a turn, likelihood ratio at least RESOLVED_RATIO
    reason: str  # why, in words
    part: int = 0  # 0, or the number of earlier crossings of the array's axis on this leg

    @property
    def likelihood_ratio(self) -> float:
        """``exp(delta_chi2 / 2)``: how much likelier the chosen side is (inf past 1e300)."""
        return float(np.exp(self.delta_chi2 / 2.0)) if self.delta_chi2 < 1381.0 else np.inf

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form."""
        lr = self.likelihood_ratio
        return {"leg": self.leg + 1, "part": self.part + 1, "start": self.start, "stop": self.stop,
                "course_deg": self.course_deg, "cuts": self.cuts, "side": self.side,
                "delta_chi2": self.delta_chi2,
                "likelihood_ratio": lr if np.isfinite(lr) else None,
                "status": "resolved" if self.resolved else "unresolved", "reason": self.reason}


@dataclass
class AmbiguityResult:
    """The ambiguity resolved (or not) leg by leg, and the fit of the sides chosen.

    Parameters
    ----------
    result : EstimateResult
        The fit of the chosen sides (unresolved alternatives among its solutions).
    measurements : MeasurementSet
        The cuts fitted, each on its leg's side.
    legs, sides, turn_cuts : LegsAndTurns, list of LegSide, list of TurnCut
    alternatives : list of (tuple of str, EstimateResult)
        Per unresolved leg, the best fit with it on the other side.
    settle_s : float
        The array's settling time, s.
    """

    result: EstimateResult
    measurements: MeasurementSet
    legs: LegsAndTurns
    sides: list[LegSide]
    turn_cuts: list[TurnCut]
    alternatives: list[tuple[tuple[str, ...], EstimateResult]] = field(default_factory=list)
    settle_s: float = SETTLE_S

    @property
    def resolved(self) -> bool:
        """True when every leg's side is resolved."""
        return all(s.resolved for s in self.sides)

    def lines(self, meas: MeasurementSet | None = None) -> list[str]:
        """Return the decisions in words, one line each.

        Parameters
        ----------
        meas : MeasurementSet, optional
            For clock times; default :attr:`measurements`.

        Returns
        -------
        list of str
        """
        meas = self.measurements if meas is None else meas
        out = [f"towed-array ambiguity: {sum(s.cuts for s in self.sides)} cuts with two "
               f"bearings on {len(self.sides)} own-ship leg(s); {self.legs.thresholds()}; turn "
               f"cuts: in a turn or within {self.settle_s:g} s after one"]
        for c in self.turn_cuts:
            out.append(f"  turn cut at {_when(meas, c.time)}: {c.reason}: "
                       + ("kept (--keep-turn-cuts)" if c.kept else "left out"))
        for s in self.sides:
            lr = _ratio_words(s.delta_chi2)
            part = f", part {s.part + 1} (the contact crossed the axis)" if s.part else ""
            out.append(f"  leg {s.leg + 1}{part} ({_when(meas, s.start)} to "
                       f"{_when(meas, s.stop)}, own course {s.course_deg:.1f} deg, {s.cuts} cuts): "
                       + (f"{s.side}, likelihood ratio {lr} against {_other(s.side)}: "
                          "resolved" if s.resolved else
                          f"unresolved ({s.reason}); best fit {s.side}, likelihood ratio "
                          f"{lr}: both sides are reported"))
        for sides, alt in self.alternatives:
            a = alt.answer(meas)
            out.append(f"  the other solution (sides {', '.join(sides)}): chi2 {alt.chi2:.4g} "
                       f"against {self.result.chi2:.4g}; "
                       + (f"course {a.course_deg:.1f} deg, speed {a.speed:.3g} m/s"
                          if a.course_deg is not None and a.speed is not None
                          else f"status {alt.status}"))
        return out

    def as_dict(self, meas: MeasurementSet | None = None) -> dict[str, object]:
        """Return the JSON form: legs' sides, turn cuts, the other solutions.

        Parameters
        ----------
        meas : MeasurementSet, optional
            For the other solutions' answers; default :attr:`measurements`.

        Returns
        -------
        dict
        """
        meas = self.measurements if meas is None else meas
        return {"resolved": self.resolved, "settle_s": self.settle_s,
                "resolved_ratio": RESOLVED_RATIO,
                "sides": [s.as_dict() for s in self.sides],
                "turn_cuts": [{"time": c.time, "reason": c.reason, "kept": c.kept}
                              for c in self.turn_cuts],
                "other_solutions": [{"sides": list(sides), "chi2": float(alt.chi2),
                                     "status": alt.status,
                                     "answer": alt.answer(meas).as_dict()}
                                    for sides, alt in self.alternatives]}


def _ratio_words(delta_chi2: float) -> str:
    """``3.2e+05``, or ``exp(Δχ²/2), Δχ² = 2468`` past what a float holds."""
    if not np.isfinite(delta_chi2):
        return "infinite (the other side's fit failed)"
    if delta_chi2 / 2.0 > 690.0:
        return f"exp({delta_chi2:.6g}/2)"
    return f"{np.exp(delta_chi2 / 2.0):.3g}"


def _other(side: str) -> str:
    return PORT if side == STARBOARD else STARBOARD


def _when(meas: MeasurementSet, t: float) -> str:
    clock = clock_time(meas, t)
    return f"t = {t:g} s" if clock is None else f"{clock[11:19]} (t = {t:g} s)"


def side_bearings(meas: MeasurementSet) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return each row's starboard and port bearing (rad; NaN for rows without a twin)."""
    twin = (np.full(len(meas), np.nan) if meas.ambiguous_si is None
            else np.asarray(meas.ambiguous_si))
    b = np.where(np.isnan(twin), np.nan, meas.value_si)
    heading = np.arctan2(meas.sensor_state[:, 3], meas.sensor_state[:, 4])
    axis = np.angle(np.exp(1j * b) + np.exp(1j * twin))
    axis = np.where(np.cos(axis - heading) < 0, axis + np.pi, axis)
    first_starboard = np.sin(b - axis) >= 0
    return np.where(first_starboard, b, twin), np.where(first_starboard, twin, b)


def resolve_ambiguity(meas: MeasurementSet, motion: MotionModel | str = "cv2d", *,
                      fit: Callable[[MeasurementSet], EstimateResult] | None = None,
                      keep_turn_cuts: bool = False, settle_s: float = SETTLE_S,
                      turn_rate_deg_s: float = TURN_RATE_DEG_S,
                      window_s: float = RATE_WINDOW_S,
                      min_turn_deg: float = MIN_TURN_DEG,
                      legs: LegsAndTurns | None = None) -> AmbiguityResult:
    """Choose each own-ship leg's side of a towed array by likelihood.

    Parameters
    ----------
    meas : MeasurementSet
        With ambiguous bearings (:meth:`~tmakit.data.MeasurementSet.with_ambiguous`), one own ship.
    motion : MotionModel or str
    fit : callable, optional
        ``fit(meas) -> EstimateResult`` instead of ``tk.estimate(meas, motion)``.
    keep_turn_cuts : bool
        Fit the cuts taken in a turn or while the array settles.
    settle_s : float
        The array's settling time after a turn, s.
    turn_rate_deg_s, window_s, min_turn_deg : float
        The own ship's turns (:func:`tmakit.results.own_legs.detect_legs`).
    legs : LegsAndTurns, optional
        Legs found over a longer record than ``meas``.

    Returns
    -------
    AmbiguityResult

    Raises
    ------
    ValueError
        No ambiguous bearing, several own ships carry them, or every cut is a turn cut.
    """
    if meas.ambiguous_si is None or not np.any(~np.isnan(meas.ambiguous_si)):
        raise ValueError("no cut carries a second, ambiguous bearing: nothing to resolve")
    if not settle_s >= 0:
        raise ValueError(f"settle_s {settle_s!r}: expected a time >= 0 (s)")
    twin = ~np.isnan(meas.ambiguous_si)
    hosts = sorted(set(meas.sensor[twin].tolist()))
    if len(hosts) > 1 and not set(hosts) <= set(own_ship_sensors(meas, hosts[0])):
        raise ValueError(f"ambiguous bearings from several sensors ({', '.join(hosts)}) not on "
                         "one own ship: resolve one own ship's at a time")
    if fit is None:
        from .methods import estimate

        def fit(m: MeasurementSet) -> EstimateResult:
            return estimate(m, motion)

    if legs is None:
        legs = own_ship_legs(meas, hosts[0], turn_rate_deg_s=turn_rate_deg_s,
                             window_s=window_s, min_turn_deg=min_turn_deg)
    keep, group, turn_cuts = _turn_cuts(meas, twin, legs, settle_s, keep_turn_cuts)
    if not np.any(keep & twin):
        raise ValueError("every ambiguous cut was taken in an own-ship turn or while the array "
                         "settled: keep them (keep_turn_cuts, --keep-turn-cuts) or give more data")
    kept = meas.take(keep)
    leg_of_row = group[keep]
    starboard, port = side_bearings(kept)
    group = _split_at_axis(leg_of_row, starboard, port)
    groups = np.unique(group[group >= 0]).tolist()
    fits = _fit_assignments(kept, group, groups, starboard, port, fit)
    best_sides = min(fits, key=lambda s: fits[s][0])
    _, best, best_meas = fits[best_sides]
    sides, alternatives = _judge_sides(kept, twin[keep], legs, group, groups, fits,
                                       np.unique(leg_of_row[leg_of_row >= 0]).size > 1)
    if alternatives:
        _report_both(best, [a for _, a in alternatives], best_meas)
    out = AmbiguityResult(best, best_meas, legs, sides, turn_cuts, alternatives, settle_s)
    best.extra["ambiguity"] = out.as_dict()
    return out


def _split_at_axis(leg: NDArray[np.intp], starboard: NDArray[np.float64],
                   port: NDArray[np.float64]) -> NDArray[np.intp]:
    """Give each ambiguous cut its group (leg, part): a new part after each pass near endfire."""
    group = np.where(leg >= 0, leg * _PARTS, -1)
    twin = ~np.isnan(starboard)
    half = np.abs(np.angle(np.exp(1j * (starboard - port)))) / 2.0  # from the nearer end
    limit, rise = np.deg2rad(ENDFIRE_DEG), np.deg2rad(ENDFIRE_RISE_DEG)
    for g in np.unique(leg[leg >= 0]).tolist():
        rows = np.flatnonzero((leg == g) & twin)
        part, low, low_at = 0, np.inf, -1
        for i, r in enumerate(rows):
            e = half[r]
            if e < low:
                low, low_at = e, i
            elif low < limit and e > low + rise:  # passed near the axis and left it
                group[rows[low_at + 1:i]] = g * _PARTS + part + 1
                part, low, low_at = part + 1, e, i
            group[r] = g * _PARTS + part
    return group


def _judge_sides(kept: MeasurementSet, twin: NDArray[np.bool_], legs: LegsAndTurns,
                 group: NDArray[np.intp], groups: list[int],
                 fits: dict[tuple[str, ...], tuple[float, EstimateResult, MeasurementSet]],
                 turned: bool
                 ) -> tuple[list[LegSide], list[tuple[tuple[str, ...], EstimateResult]]]:
    """Each group's side, ratio and status; the other-side fits of the unresolved ones."""
    best_sides = min(fits, key=lambda s: fits[s][0])
    best_chi2, best, _ = fits[best_sides]
    improbable = best.chi2_p_value is not None and best.chi2_p_value < IMPROBABLE_P
    sides: list[LegSide] = []
    alternatives: list[tuple[tuple[str, ...], EstimateResult]] = []
    for k, g in enumerate(groups):
        flipped = [(c, s) for s, (c, _, _) in fits.items() if s[k] != best_sides[k]]
        other_chi2, other_sides = min(flipped) if flipped else (np.inf, best_sides)
        delta = float(other_chi2 - best_chi2)
        rows = group == g
        if not turned:
            ok, why = False, "no own-ship turn within these cuts: the mirror track fits as well"
        elif improbable:
            ok, why = False, (f"the best fit is improbable (chi2 {best_chi2:.4g} on {best.dof} "
                              "dof): the contact may manoeuvre or change sides in a way the "
                              "motion model does not follow")
        elif delta >= 2.0 * np.log(RESOLVED_RATIO):
            ok, why = True, "after a turn"
        else:
            ok, why = False, (f"likelihood ratio below {RESOLVED_RATIO:g}: the other side "
                              "fits about as well")
        sides.append(LegSide(g // _PARTS, float(kept.time[rows].min()),
                             float(kept.time[rows].max()), legs.legs[g // _PARTS].course_deg,
                             int(np.count_nonzero(rows & twin)), best_sides[k], delta, ok, why,
                             g % _PARTS))
        if not ok and np.isfinite(other_chi2) and all(other_sides != a for a, _ in alternatives):
            alternatives.append((other_sides, fits[other_sides][1]))
    return sides, alternatives


def _report_both(best: EstimateResult, others: list[EstimateResult],
                 meas: MeasurementSet) -> None:
    """Rank the unresolved legs' other-side fits among the best fit's separated solutions."""
    earlier = [s.result for s in best.solutions[1:]]
    best.solutions = separated_solutions(best, [*others, *earlier], meas)


def _turn_cuts(meas: MeasurementSet, twin: NDArray[np.bool_], legs: LegsAndTurns,
               settle_s: float, keep_all: bool
               ) -> tuple[NDArray[np.bool_], NDArray[np.intp], list[TurnCut]]:
    """Flag the ambiguous cuts in turns or settling; return kept rows, leg of each, decisions."""
    group = legs.leg_of(meas.time)
    settling = np.zeros(len(meas), bool)
    after: dict[int, float] = {}
    for turn in legs.turns:
        near = (meas.time >= turn.stop) & (meas.time <= turn.stop + settle_s)
        settling |= near
        for k in np.flatnonzero(near):
            after.setdefault(int(k), turn.stop)
    t_fix, first = np.unique(meas.time, return_index=True)
    v = meas.sensor_state[first, 3:5]
    rate = np.degrees(heading_rate(t_fix, np.arctan2(v[:, 0], v[:, 1]), legs.window_s))
    flagged = twin & ((group < 0) | settling)
    cuts = []
    seen: set[float] = set()
    for k in np.flatnonzero(flagged):
        t = float(meas.time[k])
        if t in seen:
            continue
        seen.add(t)
        r = float(rate[np.searchsorted(t_fix, t)])
        why = (f"within {settle_s:g} s after the turn ending at t = {after[int(k)]:g} s "
               f"(heading rate {abs(r):.2g} deg/s)" if group[k] >= 0 else
               f"in a turn (heading rate {abs(r):.2g} deg/s, threshold "
               f"{legs.turn_rate_deg_s:g} deg/s)")
        cuts.append(TurnCut(t, why, keep_all))
    if keep_all:  # a kept turn cut goes with the leg after it (the array settles into it)
        nxt = np.searchsorted([leg.start for leg in legs.legs], meas.time)
        group = np.where(group < 0, np.minimum(nxt, len(legs.legs) - 1), group)
        return np.ones(len(meas), bool), group, cuts
    return ~flagged, group, cuts


def _with_sides(meas: MeasurementSet, group: NDArray[np.intp], groups: list[int],
                sides: tuple[str, ...], starboard: NDArray[np.float64],
                port: NDArray[np.float64]) -> MeasurementSet:
    """Give the set with each leg's ambiguous bearings on its side (twins swapped)."""
    value = np.array(meas.value_si)
    twin = np.array(meas.ambiguous_si)
    for g, side in zip(groups, sides, strict=True):
        rows = (group == g) & ~np.isnan(twin)
        chosen, other = (starboard, port) if side == STARBOARD else (port, starboard)
        value[rows], twin[rows] = chosen[rows], other[rows]
    out = MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, value, meas.sigma_si,
                                 meas.sensor_state, meas.time_ref, meas.ref_sensor_state,
                                 meas.metadata, check=False)
    return out.with_ambiguous(twin)


def _fit_assignments(meas: MeasurementSet, group: NDArray[np.intp], groups: list[int],
                     starboard: NDArray[np.float64], port: NDArray[np.float64],
                     fit: Callable[[MeasurementSet], EstimateResult]
                     ) -> dict[tuple[str, ...], tuple[float, EstimateResult, MeasurementSet]]:
    """Fit assignments of sides: all of them, or a coordinate search for many legs."""
    done: dict[tuple[str, ...], tuple[float, Any, MeasurementSet]] = {}

    def run(sides: tuple[str, ...]) -> float:
        if sides not in done:
            m = _with_sides(meas, group, groups, sides, starboard, port)
            r = fit(m)
            chi2 = float(r.chi2) if r.status in ("converged", "unobservable") and np.isfinite(
                r.chi2) else np.inf
            done[sides] = (chi2, r, m)
        return done[sides][0]

    if len(groups) <= MAX_EXHAUSTIVE_LEGS:
        for sides in itertools.product((PORT, STARBOARD), repeat=len(groups)):
            run(sides)
        return done
    n = len(groups)
    alternate = tuple(PORT if k % 2 else STARBOARD for k in range(n))  # a crossing flips sides
    current = min(((PORT,) * n, (STARBOARD,) * n, alternate,
                   tuple(_other(s) for s in alternate)), key=run)
    improved = True
    while improved:
        improved = False
        for k in range(len(groups)):
            trial = (*current[:k], _other(current[k]), *current[k + 1:])
            if run(trial) < run(current):
                current, improved = trial, True
    for k in range(len(groups)):  # each leg's flip of the end point, for its ratio
        run((*current[:k], _other(current[k]), *current[k + 1:]))
    return done
