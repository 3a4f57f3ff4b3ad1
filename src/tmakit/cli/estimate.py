"""``tma estimate`` and ``tma report``; the answers, legs and exports that ``tma track`` shares."""

from __future__ import annotations

import gc
import inspect
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from .common import (
    DriftOption,
    FilesArgument,
    ForceOption,
    FreeExponentOption,
    JsonOption,
    MotionOption,
    OriginOption,
    PropagationSpeedOption,
    RefTimeOption,
    SensorPositionSigmaOption,
    check_dim,
    check_output,
    check_outputs,
    check_ref_time,
    err,
    fail,
    failing,
    file_ref_time,
    measured,
    model_options,
    motion_or_fail,
    note_unused_model_options,
    out,
    parse_assignments,
    parse_origin,
    parse_time,
    print_wide,
    read_or_fail,
    read_window,
    reads_logs,
    select_window,
    window_help,
    write_picture,
)

ExactOption = Annotated[bool, typer.Option(
    "--exact", help="curvilinear with M manoeuvres: fit exactly M (default: 0 to M)")]
ScaleSigmaOption = Annotated[bool, typer.Option(
    "--scale-sigma", help="rescale each kind's sigma from the residuals of a first fit "
                          "(chi2/dof becomes 1) and fit again; the covariance follows")]
DimOption = Annotated[int | None, typer.Option(
    help="2 or 3: fit in 2-D, or in 3-D (the emitter off the sensors' plane); default: 3-D "
         "where the sensors fly or the data need the height (docs/estimation.md)")]

CriterionOption = Annotated[str | None, typer.Option(
    help="curvilinear: how the number of manoeuvres is chosen, bic (default) or lrt")]
AlphaOption = Annotated[float | None, typer.Option(
    help="curvilinear, --criterion lrt: level of the likelihood-ratio tests (default 0.01)")]
AccelerationsOption = Annotated[str | None, typer.Option(
    help="curvilinear: select (default: hold at zero the accelerations the data do not need, "
         "by the same criterion) or all")]
FromOption = Annotated[str | None, typer.Option(
    "--from", help=window_help("solve one leg", "first"))]
ToOption = Annotated[str | None, typer.Option("--to", help=window_help("solve one leg", "last"))]
PlotOption = Annotated[Path | None, typer.Option(
    help="draw the solution: geometry, bearing lines, ellipses, residuals (PNG, PDF, SVG)")]


UnitsOption = Annotated[str, typer.Option(
    "--units", help="si (speed m/s, range m) or nautical (speed kn, range nmi)")]
AtOption = Annotated[str | None, typer.Option(
    "--at", help="time of the answers: seconds, or a UTC clock time (ISO-8601) when the "
                 "file records its time origin (default: the last measurement)")]
SensorOption = Annotated[str | None, typer.Option(
    "--sensor", help="sensor that range and bearing are given from (default: the sensor of "
                     "the last measurement)")]
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
HtmlOption = Annotated[Path | None, typer.Option(
    "--html", metavar="FILE",
    help="write the interactive solution page (one self-contained .html file): map, bearing "
         "fan, ellipses and stacked dots; drag the solution in the page")]
ExportOption = Annotated[list[Path] | None, typer.Option(
    "--export", metavar="FILE",
    help="write the solution as Debrief ;TMA_POS: lines (.rep), GeoJSON (.geojson) or KML "
         "(.kml); may be given several times")]
ExportEveryOption = Annotated[float, typer.Option(
    "--export-every", metavar="SECONDS", help="seconds between the exported solution points")]
ExportRbOption = Annotated[bool, typer.Option(
    "--export-rb", help=".rep export: add ;TMA_RB: lines (range and bearing from the "
                        "sensor)")]
ExportNameOption = Annotated[str | None, typer.Option(
    "--export-name", metavar="NAME", help="the exported solution's name (default TMAKIT)")]


@reads_logs(after="origin")
def estimate(
    files: FilesArgument,
    motion: MotionOption = None,
    ref_time: RefTimeOption = None,
    init: Annotated[str | None, typer.Option(
        help="optional starting point, e.g. x=3000,y=3000,vx=-20,vy=-10")] = None,
    method: Annotated[str, typer.Option(
        help="ml (default), or a paper's method: gu-direct, ratio, ratio-power, "
             "ratio-doppler, lecture-gn, chan-ho (TDOA), ho-xu (TDOA + FDOA)")] = "ml",
    drift: DriftOption = False, free_exponent: FreeExponentOption = False,
    propagation_speed: PropagationSpeedOption = None,
    origin: OriginOption = None,
    exact: ExactOption = False,
    criterion: CriterionOption = None, alpha: AlphaOption = None,
    accelerations: AccelerationsOption = None,
    dim: DimOption = None,
    at: AtOption = None, sensor: SensorOption = None,
    units: UnitsOption = "si",
    scale_sigma: ScaleSigmaOption = False,
    start: FromOption = None, stop: ToOption = None,
    leg: LegOption = None, snap: SnapOption = False,
    keep_turn_cuts: KeepTurnCutsOption = False, turn_rate: TurnRateOption = None,
    settle: SettleOption = None,
    plot: PlotOption = None,
    html: HtmlOption = None, export: ExportOption = None,
    export_every: ExportEveryOption = 60.0, export_rb: ExportRbOption = False,
    export_name: ExportNameOption = None,
    force: ForceOption = False,
    as_json: JsonOption = False, sensor_position_sigma: SensorPositionSigmaOption = None,
    *, logs: dict[str, Any],
) -> None:
    """Estimate the emitter's trajectory from a measurement file (no initial guess needed).

    Gives position (east/north, and lat/lon when the origin is known), course, speed, range
    and bearing from a sensor, each with its std, and the position's 95 % ellipse; warns when
    the fit is improbable, angles look like radians or positions are far from the origin.

    --motion curvilinear[:M] searches 0 to M manoeuvres (default M = 2) and chooses their
    number by BIC or likelihood-ratio tests, and holds at zero the accelerations the data do
    not need (tmakit.batch.curvilinear).

    Exit status 0: an answer (trust ok or warning); 4: no answer (unobservable, not converged,
    diverged), in words, no number as an answer; 2: bad input (docs/reliability.md).
    Own-ship legs, turn cuts and towed-array ambiguity: docs/analyst.md.
    """
    check_units(units)
    check_fit_options(settle, criterion, alpha, accelerations)
    plot = check_output(plot, "--plot", force, "picture")
    model = model_options(drift, free_exponent, propagation_speed)
    more = check_solution_outputs(html, export, force, list(files), export_every, export_rb,
                                  export_name, taken=[plot], options=model)
    meas, record_legs = read_leg_window(files, parse_origin(origin), logs, (start, stop),
                                        leg, snap, turn_rate)
    meas = grouped_by_kind(meas)  # the last reference to the file's order: freed
    check_exports(more.exports, meas, more.every)
    note_unused_model_options(meas, model)
    fit = fitter(meas, motion, ref_time, parse_assignments(init, "--init") or None, method,
                 model, (exact, criterion, alpha, accelerations), dim, sensor_position_sigma)
    result, meas = fit_leg_by_leg(meas, fit, (keep_turn_cuts, settle, turn_rate), as_json,
                                  record_legs)
    factors = None
    if scale_sigma:  # each kind's sigma rescaled from the residuals, and a second fit
        from ..results import normalised_residuals
        from ..results import scale_sigma as rescaled

        with failing("--scale-sigma: "):
            meas, factors = rescaled(meas, normalised_residuals(result, meas, model), result.dof)
        result = fit(meas)
    from ..results.checks import fit_warnings

    answer = answer_or_fail(result, meas, sensor, time=parse_time(at, meas, "--at"))
    warnings = fit_warnings(result, meas, answer if at is None and sensor is None else None)
    warnings += manoeuvre_warnings(meas, result, model)
    print_estimate(meas, result, as_json, answer=answer, units=units, warnings=warnings,
                   factors=factors, plot=(plot, " + ".join(map(str, files)), model), more=more)


def check_fit_options(settle: float | None, criterion: str | None, alpha: float | None,
                      accelerations: str | None) -> None:
    """Refuse --settle, --criterion, --alpha and --accelerations out of their range, by name."""
    from ..batch.manoeuvre import ACCELERATIONS, CRITERIA

    if settle is not None and not settle >= 0:
        raise fail(f"--settle {settle:g}: expected a time >= 0 (s)")
    if criterion is not None and criterion not in CRITERIA:
        raise fail(f"--criterion {criterion!r}: expected {' or '.join(CRITERIA)}")
    if alpha is not None and not 0 < alpha < 1:
        raise fail(f"--alpha {alpha:g}: expected a significance level in (0, 1)")
    if accelerations is not None and accelerations not in ACCELERATIONS:
        raise fail(f"--accelerations {accelerations!r}: expected {' or '.join(ACCELERATIONS)}")


def manoeuvre_warnings(meas: Any, result: Any, options: dict[str, Any] | None, **words: str
                       ) -> list[Any]:
    """Warn when a cv2d fit hides a target manoeuvre (:mod:`tmakit.batch.leg_change`)."""
    from ..batch.leg_change import leg_change_warning

    # The test's first fit loads numba and its kernels: ~10^5 objects that live to the end of
    # the command, which the garbage collector would go through again and again meanwhile.
    collecting = gc.isenabled()
    gc.disable()
    try:
        with failing():
            found = leg_change_warning(meas, result, options, **words)
    finally:
        if collecting:
            gc.enable()
    return [] if found is None else [found]


def read_leg_window(files: list[Path], origin: Any, options: dict[str, Any],
                    window: tuple[str | None, str | None], leg: int | None, snap: bool,
                    turn_rate: float | None) -> tuple[Any, Any]:
    """Read the files and keep ``--from``/``--to``, ``--leg N`` or the snapped window."""
    start, stop = window
    if leg is None and not snap:  # a replay's window is applied before its reader's checks
        return read_window(files, origin, window, **options), None
    meas = measured(read_or_fail(files, origin, window=(None, None), **options), files)
    start, stop, legs = leg_window(meas, leg, start, stop, snap, turn_rate)
    return select_window(meas, start, stop), legs


def fit_leg_by_leg(meas: Any, fit: Any, turns: tuple[bool, float | None, float | None],
                   as_json: bool, legs: Any) -> tuple[Any, Any]:
    """Fit (ambiguity resolved where bearings have twins); keep own-ship and contact legs."""
    from ..results.own_legs import contact_legs

    result, fitted = fit_with_ambiguity(meas, fit, turns, as_json, legs)
    legs = legs_of(meas, turns[2]) if legs is None else legs
    if legs is not None:
        result.extra["legs"] = {"sensor": ", ".join(meas.sensors), **legs.as_dict()}
    target = contact_legs(result, fitted)
    if target is not None:
        result.extra["contact_legs"] = target
    return result, fitted


def grouped_by_kind(meas: Any) -> Any:
    """Reorder a set of many rows by kind (file order within a kind), the order of the fit."""
    import numpy as np

    from ..core import blas

    # (the solvers hold a grouped copy, ~150 bytes a row, of a set whose kinds alternate)
    if len(meas) <= blas.CHUNKED_ROWS or len(meas.kinds) == 1:
        return meas
    order = np.concatenate([np.flatnonzero(meas.kind_mask(k)) for k in meas.kinds])
    return meas if np.array_equal(order, np.arange(order.size)) else meas.take(order)


def fitter(meas: Any, motion: str | None, ref_time: float | None,
           start: dict[str, float] | None, method: str, options: dict[str, Any],
           manoeuvre: tuple[bool, str | None, float | None, str | None],
           dim: int | None = None, sensor_position_sigma: float | None = None) -> Any:
    """Return the fit the options ask for, as a function of the measurements."""
    if sensor_position_sigma is not None:
        return sensor_error_fitter(meas, motion, ref_time, method, options, sensor_position_sigma)
    exact, criterion, alpha, accelerations = manoeuvre
    check_dim(dim)
    name = motion if motion is not None else meas.metadata.get("motion")
    model = None if name is None else motion_or_fail(motion, ref_time, meas)
    if getattr(model, "manoeuvres", None) is not None:
        if dim is not None:
            raise fail("--dim applies to static2d and cv2d fits, not to --motion "
                       f"{name} (a manoeuvring target moves on the surface)")
        if method != "ml":
            raise fail(f"--method {method}: manoeuvring targets (--motion {name}) are "
                       "estimated by ml only")
        if ref_time is None and motion is None and (ref_time := file_ref_time(meas)) is not None:
            check_ref_time(ref_time, meas.time, "the file's ref_time")
        def fit_manoeuvring(m: Any) -> Any:
            from ..batch.curvilinear import estimate_for

            with failing():
                return estimate_for(m, name, init=start, options=options, ref_time=ref_time,
                                    exact=exact, criterion=criterion or "bic",
                                    alpha=0.01 if alpha is None else alpha,
                                    accelerations=accelerations)

        return fit_manoeuvring
    if exact or criterion is not None or alpha is not None or accelerations is not None:
        raise fail("--exact, --criterion, --alpha and --accelerations apply to --motion "
                   "curvilinear[:M] only")
    model = model if model is not None else motion_or_fail(motion, ref_time, meas)
    if dim is not None and method != "ml":
        raise fail(f"--dim: the height is fitted by ml only, not by --method {method}")

    def fit(m: Any) -> Any:
        with failing():
            if method == "ml":
                from ..batch import estimate as run

                return with_height(m, run(m, model, init=start, options=options), options, dim)
            from ..batch.methods import estimate_with

            return estimate_with(method, m, model, init=start, options=options)

    return fit


def sensor_error_fitter(meas: Any, motion: str | None, ref_time: float | None, method: str,
                        options: dict[str, Any], sigma: float) -> Any:
    """Return the fit that accounts for sensor position errors (``--sensor-position-sigma``)."""
    from ..batch.ml import estimate_with_sensor_errors

    if not sigma >= 0:  # (nan and inf: the guard)
        raise fail(f"--sensor-position-sigma {sigma}: expected a distance >= 0 (m)")
    if method != "ml":
        raise fail(f"--sensor-position-sigma: fitted by ml only, not --method {method}")
    model = motion_or_fail(motion, ref_time, meas)
    if getattr(model, "manoeuvres", None) is not None:
        raise fail("--sensor-position-sigma: for a motion without manoeuvres (cv2d, cv3d, "
                   "static2d, static3d)")

    def fit(m: Any) -> Any:
        with failing("--sensor-position-sigma: "):
            return estimate_with_sensor_errors(m, model, sigma, options=options)[0]

    return fit


def with_height(meas: Any, result: Any, options: dict[str, Any], dim: int | None) -> Any:
    """Return the 2-D fit or its 3-D counterpart, as the data (or ``--dim``) choose."""
    from ..batch.height import choose_height, height_matters

    if dim == 2:
        return result
    if not height_matters(meas, result):
        if dim == 3:
            raise fail("--dim 3: the height is fitted for a static2d or cv2d fit of ranges, "
                       "powers or Doppler from sensors read in one plane; give a 3-D motion "
                       "(--motion static3d, cv3d) for a 3-D file")
        return result
    choice = choose_height(meas, result, options, force=dim == 3)
    choice.result.extra["height"] = choice.as_dict()
    return choice.result


def print_estimate(meas: Any, result: Any, as_json: bool, answer: Any = None,
                   units: str = "si", warnings: list[Any] | None = None,
                   factors: dict[str, float] | None = None,
                   plot: tuple[Path | None, Path | str, Any] | None = None,
                   more: SolutionOutputs | None = None) -> None:
    """Print an estimate (text or JSON) with its trust, draw it; exit status 4 without answer."""
    from ..results.trust import trust_of
    from .guard import EXIT_NO_ANSWER

    answer = answer if answer is not None else result.answer(meas)
    warnings = list(warnings or [])
    trust = trust_of(result, warnings)
    # what the data determine of an unobservable fit (a bearing) is shown; a solve that
    # stopped short shows nothing as an answer
    shown = answer if result.status in ("converged", "unobservable") else None
    if as_json:  # the result's own serialisation: its keys are the JSON's
        out.print_json(result.to_json(meas, None, answer=answer, warnings=warnings,
                                      sigma_scale=factors))
    else:
        out.print(result.summary(units))
        if factors is not None:
            out.print("--scale-sigma: sigma multiplied by " + ", ".join(
                f"{f:.3g} ({k})" for k, f in factors.items()) + " from the first fit's "
                "residuals; the estimate and covariance above are of the refit")
        if shown is not None:
            print_answers(shown, units, meas,
                          None if trust.answer else "what the data determine (no answer: "
                                                    f"the estimate is {result.status})")
        out.print(f"trust: {trust.level}" + ("" if trust.level == "ok" else
                                             f" ({len(trust.reasons)} reason"
                                             f"{'s' if len(trust.reasons) > 1 else ''}: "
                                             + ", ".join(r.code for r in trust.reasons) + ")"))
        print_solutions(result, meas, units)
        print_legs(meas, result, units)
    print_warnings(warnings)
    if plot is not None and plot[0] is not None:
        draw_solution(meas, result, answer, plot, err if as_json else out, units)
    if more:
        write_solution_outputs(meas, result, more, trust.answer, err if as_json else out)
    if not trust.answer:
        raise typer.Exit(EXIT_NO_ANSWER)


def draw_solution(meas: Any, result: Any, answer: Any, plot: tuple[Path | None, Path | str, Any],
                  say: Any, units: str = "si") -> None:
    """Draw the solution picture (``--plot``) and say so."""
    from ..plot.solution import plot_solution
    from ..results import normalised_residuals

    path, file, options = plot
    assert path is not None
    plot_solution(meas, result, path, residuals=normalised_residuals(result, meas, options),
                  answer=answer, title=f"{file}: {result.method} estimate, {result.motion.name}",
                  units=units)
    say.print(f"wrote {path}")


SPEED_UNITS = {"si": ("m/s", 1.0), "nautical": ("kn", 1852.0 / 3600.0)}
RANGE_UNITS = {"si": ("m", 1.0), "nautical": ("nmi", 1852.0)}

if TYPE_CHECKING:
    from rich.table import Table


def check_units(units: str) -> None:
    """Refuse an unknown ``--units``."""
    if units not in SPEED_UNITS:
        raise fail(f"--units {units!r}: expected si or nautical")


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
        whole = a.range_m is not None and a.range_m / rg >= 1e4  # 28720 m, not 2.872e+04
        row(f"range from {a.sensor}", a.range_m, a.range_std, ".0f" if whole else ".4g",
            rg_unit, rg)
        row(f"bearing from {a.sensor} (true)", a.bearing_deg, a.bearing_std_deg, ".2f", "deg")
    e = a.ellipse
    if e is None:
        table.add_row("position ellipse", "unobservable", "", "")
    else:
        table.add_row(f"{e.level:.0%} ellipse semi-axes", f"{e.semi_major:.4g} x "
                      f"{e.semi_minor:.4g}" + ("" if a.position_determined
                                               else " (not a bound: range undetermined)"),
                      "", "m")
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
    from ..results.context import altitude_reference

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
    out.print(note)
    frame = frame_note(meas)
    if frame is not None:
        out.print(frame)


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
              "of their ellipses")


def print_warnings(warnings: list[Any]) -> None:
    """Print each sanity warning on standard error as ``warning: ...``."""
    for w in warnings:
        err.print(f"[bold yellow]warning:[/] {escape(w.message)}", markup=True, soft_wrap=True)


def answer_or_fail(source: Any, meas: Any, sensor: str | None, **where: Any) -> Any:
    """Return an estimate's or a track's answers (``--sensor``), errors as ``error: ...``."""
    if sensor is not None and sensor not in meas.sensors:
        raise fail(f"--sensor {sensor!r}: no such sensor in the file (sensors: "
                   f"{', '.join(meas.sensors)})")
    try:
        return source.answer(meas, sensor=sensor, **where)
    except ValueError as e:  # a time the data cannot answer for (tmakit.rules.time_problem)
        raise fail(str(e).replace("time ", "--at ", 1) if "time" in where else str(e)) from None


def legs_of(meas: Any, turn_rate: float | None) -> Any:
    """Return the own ship's legs (None when its sensors are not on one own ship, or still)."""
    import numpy as np

    from ..results.own_legs import TURN_RATE_DEG_S, own_ship_legs, own_ship_sensors

    rate = TURN_RATE_DEG_S if turn_rate is None else turn_rate
    if not rate > 0:
        raise fail(f"--turn-rate {turn_rate!r}: expected a heading rate > 0 (deg/s)")
    v, block = meas.sensor_state, 1 << 16  # by blocks, up to the first moving row
    moving = any(np.any(np.hypot(v[lo:lo + block, 3], v[lo:lo + block, 4]) > 0.05)
                 for lo in range(0, len(meas), block))
    if not moving or len(own_ship_sensors(meas)) != len(meas.sensors):
        return None
    return own_ship_legs(meas, turn_rate_deg_s=rate)


def leg_window(meas: Any, leg: int | None, start: str | None, stop: str | None, snap: bool,
               turn_rate: float | None) -> tuple[str | None, str | None, Any]:
    """Return ``--from``/``--to`` (seconds as text) for ``--leg N`` or ``--snap``."""
    legs = legs_of(meas, turn_rate)
    if legs is None:
        raise fail("--leg/--snap: own-ship legs need one moving own ship (its sensors within "
                   "2 km of each other, moving as one); the set has "
                   f"{len(meas.sensors)} sensor(s): {', '.join(meas.sensors)}")
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

    def snapped(text: str | None, option: str, ends: list[float], other: list[float]) -> str | None:
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


def print_legs(meas: Any, result: Any, units: str) -> None:
    """Print the own-ship legs and turns and a manoeuvre fit's contact legs (``extra``)."""
    from ..results.own_legs import HOLDS_COURSE_SPEED

    unit, scale = SPEED_UNITS[units]
    legs, target = result.extra.get("legs"), result.extra.get("contact_legs")
    lines = [f"own-ship legs of {legs['sensor']} ({legs['thresholds']}):"] if legs else []
    for k, leg in enumerate(legs["legs"] if legs else []):
        heading = ("stationary" if leg["speed"] < HOLDS_COURSE_SPEED  # its heading is noise
                   else f"heading {leg['course_deg']:.1f} deg")
        lines.append(f"  leg {k + 1}: {_span(meas, leg)}, {heading} at "
                     f"{leg['speed'] / scale:.3g} {unit}")
        if k < len(legs["turns"]):
            u = legs["turns"][k]
            lines.append(f"  turn: {_span(meas, u)}, {u['change_deg']:+.0f} deg")
    if legs and legs["legs"]:  # a path that starts or ends turning (a drone circling)
        t = meas.time  # (the legs are those of every sensor of the one own ship)
        first, last = legs["legs"][0]["start"], legs["legs"][-1]["stop"]
        if float(t.min()) < first:
            lines.insert(1, f"  turning: {_span(meas, {'start': float(t.min()), 'stop': first})}"
                            " (no straight leg before leg 1)")
        if float(t.max()) > last:
            lines.append(f"  turning: {_span(meas, {'start': last, 'stop': float(t.max())})} "
                         f"(no straight leg after leg {len(legs['legs'])})")
    lines += ["contact legs (the manoeuvre fit's segments):"] if target else []
    for k, leg in enumerate(target or []):
        course = (f"course {leg['course_deg']:.1f} deg" if leg["turn_deg"] is None
                  or abs(leg["turn_deg"]) < 1.0 else
                  f"turning {leg['course_start_deg']:.1f} to {leg['course_deg']:.1f} deg")
        lines.append(f"  leg {k + 1}: {_span(meas, leg)}, {course}, speed "
                     f"{leg['speed'] / scale:.3g} {unit}")
    for line in lines:
        out.print(line, soft_wrap=True)


def fit_with_ambiguity(meas: Any, fit: Any,
                       turns: tuple[bool, float | None, float | None], as_json: bool,
                       legs: Any = None) -> tuple[Any, Any]:
    """Fit, resolving a towed array's ambiguity when the bearings carry twins."""
    from ..batch.ambiguity import SETTLE_S
    from ..results.own_legs import TURN_RATE_DEG_S

    keep_turn_cuts, settle, turn_rate = turns
    amb = resolved_sides(meas, err if as_json else out, fit=fit, keep_turn_cuts=keep_turn_cuts,
                         settle_s=SETTLE_S if settle is None else settle,
                         turn_rate_deg_s=TURN_RATE_DEG_S if turn_rate is None else turn_rate,
                         legs=legs)
    if amb is None:
        if keep_turn_cuts or settle is not None:
            err.print("note: --keep-turn-cuts/--settle apply to towed-array cuts with a second, "
                      "ambiguous bearing; these data have none")
        return fit(meas), meas
    return amb.result, amb.measurements


def resolved_sides(meas: Any, say: Any, *args: Any, **options: Any) -> Any:
    """Resolve a towed array's ambiguity, the decisions said; None when no bearing has a twin."""
    import numpy as np

    if meas.ambiguous_si is None or not np.any(~np.isnan(meas.ambiguous_si)):
        return None
    from ..batch.ambiguity import resolve_ambiguity

    with failing():
        amb = resolve_ambiguity(meas, *args, **options)
    for line in amb.lines(meas):
        say.print(line, soft_wrap=True)
    return amb


def sides_for_filter(meas: Any, dim: int) -> Any:
    """``tma track``: each ambiguous cut on the side the batch fit chooses, decisions printed."""
    amb = resolved_sides(meas, err, f"cv{dim}d")
    if amb is None:
        return meas
    if not amb.resolved:
        err.print("note: a filter follows one bearing per cut: the track takes the best fit's "
                  "side of each unresolved leg, and the mirror track fits about as well (tma "
                  "estimate reports both)", soft_wrap=True)
    return amb.measurements


@dataclass
class SolutionOutputs:
    """The page and exports asked for, checked (see :func:`check_solution_outputs`)."""

    html: Path | None = None
    exports: list[Path] = field(default_factory=list)
    every: float = 60.0
    range_bearing: bool = False
    name: str | None = None
    force: bool = False
    title: str = ""
    options: dict[str, Any] = field(default_factory=dict)

    def __bool__(self) -> bool:
        """Whether anything is to be written."""
        return self.html is not None or bool(self.exports)


def check_solution_outputs(html: Path | None, exports: list[Path] | None, force: bool,
                           files: list[Path], every: float = 60.0,
                           range_bearing: bool = False, name: str | None = None,
                           taken: list[Path | None] | None = None,
                           options: dict[str, Any] | None = None) -> SolutionOutputs:
    """Check ``--html`` and ``--export`` before any work."""
    if not every > 0:
        raise fail(f"--export-every {every:g}: expected seconds > 0")
    if range_bearing and not any(Path(p).suffix.lower() == ".rep" for p in exports or []):
        raise fail("--export-rb adds ;TMA_RB: lines to a .rep export: give --export FILE.rep")
    checked = check_outputs([("--html", html, "page"),
                             *(("--export", p, "solution") for p in exports or [])], force)
    plots = {Path(p).resolve() for p in taken or [] if p is not None}
    for option, p in zip(["--html", *["--export"] * len(exports or [])], checked, strict=True):
        if p is not None and p.resolve() in plots:
            raise fail(f"{option} {p}: the same file as --plot")
    return SolutionOutputs(html=checked[0], exports=[p for p in checked[1:] if p is not None],
                           every=every, range_bearing=range_bearing, name=name, force=force,
                           title=" + ".join(map(str, files)),
                           options=dict(options or {}))


def check_exports(exports: list[Path], meas: Any, every: float = 60.0) -> None:
    """Refuse, before the fit, an export the data cannot place (no origin, no clock times)."""
    from ..io.solution_files import check_solution_data

    for path in exports:
        with failing("--export "):
            check_solution_data(path, meas, every)


def write_solution_outputs(meas: Any, result: Any, outputs: SolutionOutputs, answers: bool,
                           say: Any) -> None:
    """Write the page and the exports; say what was written (or why an export was not)."""
    if outputs.html is not None:
        from ..plot.page import write_solution_page

        title = f"{outputs.title}: {result.method} estimate, {result.motion.name}"
        write_picture(outputs.html, outputs.force, lambda tmp: write_solution_page(
            meas, result, tmp, options=outputs.options, title=title))
        say.print(f"wrote {outputs.html} (open it in a browser: no network needed)", soft_wrap=True)
    if not outputs.exports:
        return
    if not answers:
        say.print(f"not written: {', '.join(map(str, outputs.exports))}: the estimate is no answer")
        return
    from ..io.solution_files import write_solution

    for path in outputs.exports:
        with failing("--export ", written=path):
            write_solution(path, meas, result, every=outputs.every,
                           range_bearing=outputs.range_bearing, name=outputs.name,
                           force=outputs.force)
        say.print(f"wrote {path}", soft_wrap=True)


def report(**arguments: Any) -> None:
    """Write the interactive solution page of a measurement file (and print the estimate).

    The page (one self-contained .html file, no network needed to open it) shows the
    geography with the sensors' tracks and legs, the bearing fan, the solution with its
    ellipses, and the stacked dots of each kind; drag the solution in the page to see the
    dots and chi-square follow. Every option of tma estimate applies (--export too).
    """
    estimate(**arguments)


def _report_signature() -> inspect.Signature:
    """``tma estimate``'s parameters, ``--html`` replaced by a required ``-o/--output``."""
    page = inspect.Parameter(
        "html", inspect.Parameter.POSITIONAL_OR_KEYWORD,
        annotation=Annotated[Path, typer.Option(
            "-o", "--output", "--html", metavar="FILE", help="the page to write (.html)")])
    params = [page if p.name == "html" else p  # (resolved by reads_logs)
              for p in inspect.signature(estimate).parameters.values()]
    # a parameter without default after those with one: move the page after the files
    params.remove(page)
    params.insert(1, page)
    return inspect.Signature(params, return_annotation=None)


report.__signature__ = _report_signature()  # type: ignore[attr-defined]
