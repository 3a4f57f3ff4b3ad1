"""The analyst's options of ``tma estimate``: own-ship legs, ``--leg N``, turn cuts, ambiguity."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from .answers_out import SPEED_UNITS, parse_time
from .common import err, fail, out

LegOption = Annotated[int | None, typer.Option(
    "--leg", help="solve the own ship's leg N (1 = the first; the legs are printed with every "
                  "estimate)")]
SnapOption = Annotated[bool, typer.Option(
    "--snap", help="move --from to the start and --to to the end of the own-ship leg each "
                   "falls in")]
KeepTurnCutsOption = Annotated[bool, typer.Option(
    "--keep-turn-cuts", help="towed-array cuts taken in an own-ship turn or while the array "
                             "settles: fit them (default: left out, each named)")]
TurnRateOption = Annotated[float | None, typer.Option(
    "--turn-rate", help="own-ship turns: a heading rate above this (deg/s, default 0.1)")]
SettleOption = Annotated[float | None, typer.Option(
    "--settle", help="the towed array's settling time after a turn (s, default 180)")]


def legs_of(meas: Any, turn_rate: float | None) -> Any:
    """Return the own ship's legs (None when the set has several sensors or one that is still)."""
    import numpy as np

    from ..results.own_legs import TURN_RATE_DEG_S, own_ship_legs

    rate = TURN_RATE_DEG_S if turn_rate is None else turn_rate
    if not rate > 0:
        raise fail(f"--turn-rate {turn_rate!r}: expected a heading rate > 0 (deg/s)")
    if len(meas.sensors) != 1 or not np.any(np.hypot(meas.sensor_state[:, 3],
                                                     meas.sensor_state[:, 4]) > 0.05):
        return None
    return own_ship_legs(meas, turn_rate_deg_s=rate)


def leg_window(meas: Any, leg: int | None, start: str | None, stop: str | None, snap: bool,
               turn_rate: float | None) -> tuple[str | None, str | None, Any]:
    """Return ``--from``/``--to`` (seconds as text) for ``--leg N`` or ``--snap``."""
    legs = legs_of(meas, turn_rate)
    if legs is None:
        raise fail("--leg/--snap: own-ship legs need one moving sensor (the own ship); the "
                   f"set has {len(meas.sensors)} sensor(s): {', '.join(meas.sensors)}")
    if leg is not None:
        if start is not None or stop is not None:
            raise fail("--leg N sets the window: give it without --from/--to (or --from/--to "
                       "with --snap)")
        if not 1 <= leg <= len(legs.legs):
            raise fail(f"--leg {leg}: the own ship has {len(legs.legs)} leg(s) "
                       f"({legs.thresholds()})")
        chosen = legs.legs[leg - 1]
        return repr(chosen.start), repr(chosen.stop), legs
    ends_start = [g.start for g in legs.legs]
    ends_stop = [g.stop for g in legs.legs]

    def snapped(text: str | None, option: str, ends: list[float], other: list[float]
                ) -> str | None:
        t = parse_time(text, meas, option)
        if t is None:
            return None
        inside = [k for k, g in enumerate(legs.legs) if g.start <= t <= g.stop]
        if inside:
            return repr(ends[inside[0]])
        return repr(min(ends + other, key=lambda e: abs(e - t)))

    return (snapped(start, "--from", ends_start, ends_stop),
            snapped(stop, "--to", ends_stop, ends_start), legs)


def _span(meas: Any, part: dict[str, Any]) -> str:
    """Give a leg's or turn's ``start to stop``: UTC clock times (HH:MM:SS), else seconds."""
    from ..results.context import clock_time

    clocks = [(t, clock_time(meas, t)) for t in (part["start"], part["stop"])]
    return " to ".join(f"{t:g} s" if c is None else c[11:19] for t, c in clocks)


def legs_lines(meas: Any, legs: dict[str, Any], units: str) -> list[str]:
    """Return the own-ship legs and turns in words, with the thresholds."""
    unit, scale = SPEED_UNITS[units]
    lines = [f"own-ship legs of {legs['sensor']} ({legs['thresholds']}):"]
    for k, leg in enumerate(legs["legs"]):
        lines.append(f"  leg {k + 1}: {_span(meas, leg)}, heading "
                     f"{leg['course_deg']:.1f} deg at {leg['speed'] / scale:.3g} {unit}")
        if k < len(legs["turns"]):
            u = legs["turns"][k]
            lines.append(f"  turn: {_span(meas, u)}, {u['change_deg']:+.0f} deg")
    return lines


def print_legs(meas: Any, result: Any, units: str) -> None:
    """Print the own-ship legs and the contact's legs a fit carries (``extra``)."""
    legs, target = result.extra.get("legs"), result.extra.get("contact_legs")
    lines = (legs_lines(meas, legs, units) if legs else []) + (
        contact_legs_lines(meas, target, units) if target else [])
    for line in lines:
        out.print(line, highlight=False, soft_wrap=True)


def contact_legs_lines(meas: Any, legs: list[dict[str, Any]], units: str) -> list[str]:
    """Return the contact's legs of a manoeuvre fit in words."""
    unit, scale = SPEED_UNITS[units]
    lines = ["contact legs (the manoeuvre fit's segments):"]
    for k, leg in enumerate(legs):
        course = (f"course {leg['course_deg']:.1f} deg" if leg["turn_deg"] is None
                  or abs(leg["turn_deg"]) < 1.0 else
                  f"turning {leg['course_start_deg']:.1f} to {leg['course_deg']:.1f} deg")
        lines.append(f"  leg {k + 1}: {_span(meas, leg)}, {course}, speed "
                     f"{leg['speed'] / scale:.3g} {unit}")
    return lines


def fit_with_ambiguity(meas: Any, fit: Any,
                       turns: tuple[bool, float | None, float | None], as_json: bool,
                       legs: Any = None) -> tuple[Any, Any]:
    """Fit, resolving a towed array's ambiguity when the bearings carry twins."""
    import numpy as np

    keep_turn_cuts, settle, turn_rate = turns
    if meas.ambiguous_si is None or not np.any(~np.isnan(meas.ambiguous_si)):
        if keep_turn_cuts or settle is not None:
            err.print("note: --keep-turn-cuts/--settle apply to towed-array cuts with a second, "
                      "ambiguous bearing; these data have none", highlight=False)
        return fit(meas), meas
    from ..batch.ambiguity import SETTLE_S, resolve_ambiguity
    from ..results.own_legs import TURN_RATE_DEG_S

    try:
        amb = resolve_ambiguity(meas, fit=fit, keep_turn_cuts=keep_turn_cuts,
                                settle_s=SETTLE_S if settle is None else settle,
                                turn_rate_deg_s=TURN_RATE_DEG_S if turn_rate is None
                                else turn_rate, legs=legs)
    except ValueError as e:
        raise fail(str(e)) from None
    say = err if as_json else out
    for line in amb.lines(meas):
        say.print(line, highlight=False, soft_wrap=True)
    return amb.result, amb.measurements


def sides_for_filter(meas: Any, dim: int) -> Any:
    """``tma track``: each ambiguous cut on the side the batch fit chooses, decisions printed.

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements.
    dim : int
        The filter's dimension (the batch fit is cv2d or cv3d).

    Returns
    -------
    tmakit.data.MeasurementSet
        ``meas`` without twins as it is; else the cuts on their legs' sides, turn cuts out.

    Raises
    ------
    typer.Exit
        Status 2 when nothing is left to track.
    """
    import numpy as np

    if meas.ambiguous_si is None or not np.any(~np.isnan(meas.ambiguous_si)):
        return meas
    from ..batch.ambiguity import resolve_ambiguity

    try:
        amb = resolve_ambiguity(meas, f"cv{dim}d")
    except ValueError as e:
        raise fail(str(e)) from None
    for line in amb.lines(meas):
        err.print(line, highlight=False, soft_wrap=True)
    if not amb.resolved:
        err.print("note: a filter follows one bearing per cut: the track takes the best fit's "
                  "side of each unresolved leg, and the mirror track fits about as well (tma "
                  "estimate reports both)", highlight=False, soft_wrap=True)
    return amb.measurements

