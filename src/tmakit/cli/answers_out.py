"""The answers table, the warnings and the time options of ``tma estimate`` and ``tma track``.

What is printed is computed by :mod:`tmakit.results.answers` and :mod:`tmakit.results.checks`;
this module only lays it out.  No numpy at import time (``tma --help`` stays light).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

import typer

from .common import err, fail, out, print_wide

UnitsOption = Annotated[str, typer.Option(
    "--units", help="si (speed m/s, range m) or nautical (speed kn, range nmi)")]
AtOption = Annotated[str | None, typer.Option(
    "--at", help="time of the answers: seconds, or a UTC clock time (ISO-8601) when the "
                 "file records its time origin (default: the last measurement)")]
SensorOption = Annotated[str | None, typer.Option(
    "--sensor", help="sensor that range and bearing are given from (default: the sensor of "
                     "the last measurement)")]

SPEED_UNITS = {"si": ("m/s", 1.0), "nautical": ("kn", 1852.0 / 3600.0)}
RANGE_UNITS = {"si": ("m", 1.0), "nautical": ("nmi", 1852.0)}

if TYPE_CHECKING:
    from rich.table import Table


def check_units(units: str) -> None:
    """Refuse an unknown ``--units``."""
    if units not in SPEED_UNITS:
        raise fail(f"--units {units!r}: expected si or nautical")


def parse_time(text: str | None, meas: Any, option: str) -> float | None:
    """Return a time option in seconds: seconds, an ISO-8601 clock time, or ``HH:MM[:SS]``."""
    if text is None:
        return None
    from ..io.logs import seconds_of_time_text
    from ..results.context import TIME_ORIGIN_KEY

    origin_ns = span = None
    if (origin := meas.metadata.get(TIME_ORIGIN_KEY)) is not None:
        import numpy as np

        from ..io.logs import parse_clock_times

        stamps, bad = parse_clock_times([origin])
        if not bad[0]:
            origin_ns = int(stamps[0])
            if len(meas):
                span = tuple(origin_ns + round(float(f(meas.time)) * 1e9)
                             for f in (np.min, np.max))
    try:
        return seconds_of_time_text(text, option, origin_ns, span)  # type: ignore[arg-type]
    except ValueError as e:
        raise fail(str(e)) from None


def select_window(meas: Any, start: str | None, stop: str | None) -> Any:
    """Return the rows with ``--from <= time <= --to`` (one leg), refusing an empty window."""
    t_from, t_to = parse_time(start, meas, "--from"), parse_time(stop, meas, "--to")
    if t_from is None and t_to is None:
        return meas
    keep = ((meas.time >= (t_from if t_from is not None else -float("inf")))
            & (meas.time <= (t_to if t_to is not None else float("inf"))))
    if int(keep.sum()) == 0:
        raise fail(f"--from/--to: no measurement between {t_from} and {t_to} s (the file "
                   f"covers {meas.time.min():g} .. {meas.time.max():g} s)")
    return meas.take(keep)


def _num(v: float | None, fmt: str, scale: float = 1.0) -> str:
    """Format a number, or ``unobservable`` for None."""
    return "unobservable" if v is None else format(v / scale, fmt)


def answers_table(a: Any, units: str, title: str) -> Table:
    """Lay out an :class:`~tmakit.results.answers.Answer` as a table with units in its header."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    sp_unit, sp = SPEED_UNITS[units]
    rg_unit, rg = RANGE_UNITS[units]
    table = Table(title=title, title_justify="left")
    for col, justify in (("quantity", "left"), ("value", "right"), ("std (1σ)", "right"),
                         ("unit", "left")):
        table.add_column(col, justify=justify)  # type: ignore[arg-type]

    def row(name: str, v: float | None, s: float | None, fmt: str, unit: str,
            scale: float = 1.0, std_unit: str = "") -> None:
        table.add_row(name, _num(v, fmt, scale),
                      "" if v is None else _num(s, ".3g", scale) + std_unit, unit)

    if a.geodetic is not None:
        lat, lon, alt = a.geodetic
        row("latitude", lat, a.enu_std[1], ".6f", "deg", std_unit=" m")
        row("longitude", lon, a.enu_std[0], ".6f", "deg", std_unit=" m")
        if a.dim == 3:
            row(f"altitude ({a.altitude_reference})", alt, a.enu_std[2], ".1f", "m")
    for i, name in enumerate(("east", "north", "up")[: a.dim]):
        row(name, a.enu[i], a.enu_std[i], ".1f", "m")
    if not a.stationary:
        row("course (true)", a.course_deg, a.course_std_deg, ".1f", "deg")
        row("speed", a.speed, a.speed_std, ".3g", sp_unit, sp)
    if a.sensor is not None:
        row(f"range from {a.sensor}", a.range_m, a.range_std, ".4g", rg_unit, rg)
        row(f"bearing from {a.sensor} (true)", a.bearing_deg, a.bearing_std_deg, ".2f", "deg")
    e = a.ellipse
    if e is None:
        table.add_row("position ellipse", "unobservable", "", "")
    else:
        table.add_row(f"{e.level:.0%} ellipse semi-axes", f"{e.semi_major:.4g} x "
                      f"{e.semi_minor:.4g}", "", "m")
        table.add_row(f"{e.level:.0%} ellipse major axis (true)", f"{e.orientation_deg:.1f}",
                      "", "deg")
    return table


def answer_title(a: Any, what: str) -> str:
    """Return the answers table's title: what, at which time (seconds and UTC when known)."""
    when = f"t = {a.time:g} s" + (f" ({a.clock})" if a.clock else "")
    if not a.stationary:
        return f"{what} at {when}"
    return f"{what} (stationary)" + (f"; range and bearing at {when}" if a.sensor else "")


def frame_note(meas: Any) -> str | None:
    """Say where lat/lon and clock times come from: the ENU origin and the time origin."""
    from ..results.answers import altitude_reference

    meta = {} if meas is None else meas.metadata
    parts = []
    if "origin_lat" in meta and "origin_lon" in meta:
        source = meta.get("origin_source")
        parts.append(f"ENU origin lat {float(meta['origin_lat']):.6f} deg, lon "
                     f"{float(meta['origin_lon']):.6f} deg, alt "
                     f"{float(meta.get('origin_alt', 0.0)):.1f} m"
                     + (f" ({source})" if source else "")
                     + f", altitudes above {altitude_reference(meas)}")
    if "time_origin" in meta:
        parts.append(f"t = 0 s is {meta['time_origin']} (UTC)")
    return "frame: " + "; ".join(parts) if parts else None


def print_answers(a: Any, units: str, meas: Any = None, title: str | None = None) -> None:
    """Print the answers table, how its std were computed and the frame of lat/lon and clock."""
    what = title or ("emitter position" if a.stationary else "emitter")
    print_wide(answers_table(a, units, answer_title(a, what)))
    note = ("std: linearised (delta method) from the covariance; position ellipse: "
            f"{a.ellipse.level if a.ellipse else 0.95:.0%} probability (chi-square, 2 dof)")
    if a.dim == 2:
        note += "; range is horizontal (2-D motion)"
    out.print(note, highlight=False)
    frame = frame_note(meas)
    if frame is not None:
        out.print(frame, highlight=False)


def print_solutions(result: Any, meas: Any, units: str) -> None:
    """Print the separated solutions, ranked, each with its chi2, test and answers."""
    if len(result.solutions) < 2:
        return
    from rich.table import Table

    sp_unit, sp = SPEED_UNITS[units]
    rg_unit, rg = RANGE_UNITS[units]
    first = result.solutions[0].answer(meas)
    table = Table(title=f"{len(result.solutions)} separated solutions at t = {first.time:g} s"
                  + (f" ({first.clock})" if first.clock else "")
                  + ": each fits the data about as well as the first", title_justify="left")
    for col in ("#", "motion", "chi2", "LR", "p", "east m", "north m", "course deg",
                f"speed {sp_unit}", f"range {rg_unit}", "bearing deg", "95% ellipse m"):
        table.add_column(col, justify="left" if col in ("#", "motion") else "right")
    for sol in result.solutions:
        a = sol.answer(meas)

        def pm(v: float | None, s: float | None, fmt: str, scale: float = 1.0,
               std_fmt: str = ".2g") -> str:
            return ("unobservable" if v is None
                    else f"{v / scale:{fmt}} ± {_num(s, std_fmt, scale)}")

        e = a.ellipse
        table.add_row(str(sol.rank), sol.result.motion.name, f"{sol.result.chi2:.4g}",
                      f"{sol.lr_statistic:.3g}", f"{sol.p_value:.2g}",
                      pm(a.enu[0], a.enu_std[0], ".0f", std_fmt=".0f"),
                      pm(a.enu[1], a.enu_std[1], ".0f", std_fmt=".0f"),
                      pm(a.course_deg, a.course_std_deg, ".1f") if not a.stationary else "-",
                      pm(a.speed, a.speed_std, ".3g", sp) if not a.stationary else "-",
                      pm(a.range_m, a.range_std, ".4g", rg),
                      _num(a.bearing_deg, ".1f"),
                      "unobservable" if e is None
                      else f"{e.semi_major:.4g} x {e.semi_minor:.4g}")
    print_wide(table)
    out.print("solutions: LR = chi2 - chi2 of the first (0 when lower); p = P(chi2 with the "
              "first fit's unknowns as degrees of freedom >= LR); the truth may lie in any "
              "of their ellipses", highlight=False)


def print_warnings(warnings: list[Any]) -> None:
    """Print each sanity warning on standard error as ``warning: ...``."""
    for w in warnings:
        err.print(f"[bold yellow]warning:[/] {w.message}", highlight=False, soft_wrap=True)


def answer_or_fail(source: Any, meas: Any, sensor: str | None, **where: Any) -> Any:
    """Return an estimate's or a track's answers (``--sensor``), errors as ``error: ...``."""
    if sensor is not None and sensor not in meas.sensors:
        raise fail(f"--sensor {sensor!r}: no such sensor in the file (sensors: "
                   f"{', '.join(meas.sensors)})")
    try:
        return source.answer(meas, sensor=sensor, **where)
    except ValueError as e:  # a time the data cannot answer for (tmakit.rules.time_problem)
        raise fail(str(e).replace("time ", "--at ", 1) if "time" in where else str(e)) from None
