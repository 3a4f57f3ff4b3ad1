"""``tma estimate``: the emitter's trajectory from a measurement file.

By maximum likelihood (``ml``, also for manoeuvring targets) or by one of the papers' methods.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from .answers_out import (
    AtOption,
    SensorOption,
    UnitsOption,
    answer_or_fail,
    check_units,
    parse_time,
    print_answers,
    print_solutions,
    print_warnings,
    select_window,
)
from .common import (
    BearingSigmaOption,
    ContactOption,
    DriftOption,
    FilesArgument,
    ForceOption,
    FormatOption,
    FreeExponentOption,
    FrequencySigmaOption,
    JsonOption,
    KindsOption,
    MappingOption,
    MotionOption,
    OriginOption,
    OwnshipOption,
    PropagationSpeedOption,
    RangeSigmaOption,
    RangesOption,
    RefTimeOption,
    SensorPositionSigmaOption,
    check_ref_time,
    err,
    fail,
    file_ref_time,
    model_options,
    motion_or_fail,
    out,
    parse_assignments,
    parse_origin,
    reader_options,
)
from .legs_out import (
    KeepTurnCutsOption,
    LegOption,
    SettleOption,
    SnapOption,
    TurnRateOption,
    fit_with_ambiguity,
    leg_window,
    legs_of,
    print_legs,
)
from .outputs import check_output
from .reading import read_or_fail
from .solution_out import (
    ExportEveryOption,
    ExportNameOption,
    ExportOption,
    ExportRbOption,
    HtmlOption,
    SolutionOutputs,
    check_solution_outputs,
    write_solution_outputs,
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
    "--from", help="solve one leg: first time (seconds, a UTC clock time, or HH:MM[:SS] on "
                   "the data's day)")]
ToOption = Annotated[str | None, typer.Option(
    "--to", help="solve one leg: last time (seconds, a UTC clock time, or HH:MM[:SS] on "
                 "the data's day)")]
PlotOption = Annotated[Path | None, typer.Option(
    help="draw the solution: geometry, bearing lines, ellipses, residuals (PNG, PDF, SVG)")]


# `tma estimate`: the docstring is its --help text, so no numpydoc sections (help= has them).
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
    origin: OriginOption = None, format: FormatOption = None,
    ownship: OwnshipOption = None, contact: ContactOption = None,
    mapping: MappingOption = None,
    bearing_sigma: BearingSigmaOption = None, range_sigma: RangeSigmaOption = None,
    frequency_sigma: FrequencySigmaOption = None,
    kinds: KindsOption = None, ranges: RangesOption = None,
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
    plot = check_output(plot, "--plot", force, "picture", files)
    model = model_options(drift, free_exponent, propagation_speed)
    more = check_solution_outputs(html, export, force, list(files), export_every, export_rb,
                                  export_name, taken=[plot], options=model, files=files)
    options = reader_options(format, ownship, contact, mapping, bearing_sigma, range_sigma,
                             frequency_sigma, kinds=kinds, ranges=ranges)
    meas, record_legs = read_leg_window(files, parse_origin(origin), options, (start, stop),
                                        leg, snap, turn_rate)
    meas = grouped_by_kind(meas)  # the last reference to the file's order: freed
    fit = fitter(meas, motion, ref_time, parse_assignments(init, "--init") or None, method,
                 model, (exact, criterion, alpha, accelerations), dim, sensor_position_sigma)
    result, meas = fit_leg_by_leg(meas, fit, (keep_turn_cuts, settle, turn_rate), as_json,
                                  record_legs)
    factors = None
    if scale_sigma:
        meas, result, factors = refit_scaled(meas, result, fit, model)
    answer = answer_or_fail(result, meas, sensor, time=parse_time(at, meas, "--at"))
    warnings = result.warnings(meas)
    print_estimate(meas, result, as_json, answer=answer, units=units, warnings=warnings,
                   factors=factors, plot=(plot, " + ".join(map(str, files)), model), more=more)


def read_leg_window(files: list[Path], origin: Any, options: dict[str, Any],
                    window: tuple[str | None, str | None], leg: int | None, snap: bool,
                    turn_rate: float | None) -> tuple[Any, Any]:
    """Read the files and keep ``--from``/``--to``, ``--leg N`` or the snapped window."""
    start, stop = window
    if leg is None and not snap:  # a replay's window is applied before its reader's checks
        return select_window(read_or_fail(files, origin, window=window, **options), start,
                             stop), None
    meas = read_or_fail(files, origin, window=(None, None), **options)
    start, stop, legs = leg_window(meas, leg, start, stop, snap, turn_rate)
    return select_window(meas, start, stop), legs


def fit_leg_by_leg(meas: Any, fit: Any, turns: tuple[bool, float | None, float | None],
                   as_json: bool, legs: Any) -> tuple[Any, Any]:
    """Fit (the ambiguity resolved where the bearings have twins); keep the legs in the result."""
    result, fitted = fit_with_ambiguity(meas, fit, turns, as_json, legs)
    keep_legs(meas, fitted, result, turns[2], legs)
    return result, fitted


def keep_legs(navigation: Any, meas: Any, result: Any, turn_rate: float | None,
              legs: Any = None) -> None:
    """Keep the own ship's legs and a manoeuvre fit's contact legs in the result (``extra``)."""
    from ..results.own_legs import contact_legs

    legs = legs_of(navigation, turn_rate) if legs is None else legs
    if legs is not None:
        result.extra["legs"] = {"sensor": navigation.sensors[0], **legs.as_dict()}
    target = contact_legs(result, meas)
    if target is not None:
        result.extra["contact_legs"] = target


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
        return sensor_error_fitter(meas, motion, ref_time, method, options,
                                   sensor_position_sigma)
    exact, criterion, alpha, accelerations = manoeuvre
    if dim not in (None, 2, 3):
        raise fail(f"--dim {dim}: expected 2 or 3")
    name = motion if motion is not None else meas.metadata.get("motion")
    if name is not None and getattr(motion_or_fail(name, ref_time, meas), "manoeuvres",
                                                None) is not None:
        if dim is not None:
            raise fail("--dim applies to static2d and cv2d fits, not to --motion "
                       f"{name} (a manoeuvring target moves on the surface)")
        if method != "ml":
            raise fail(f"--method {method}: manoeuvring targets (--motion {name}) are "
                       "estimated by ml only")
        if ref_time is None and motion is None and (ref_time := file_ref_time(meas)) is not None:
            check_ref_time(ref_time, meas.time, "the file's ref_time")
        return lambda m: estimate_manoeuvring(m, name, start, options, ref_time, exact,
                                              criterion, alpha, accelerations)
    if exact or criterion is not None or alpha is not None or accelerations is not None:
        raise fail("--exact, --criterion, --alpha and --accelerations apply to --motion "
                   "curvilinear[:M] only")
    model = motion_or_fail(motion, ref_time, meas)
    if dim is not None and method != "ml":
        raise fail(f"--dim: the height is fitted by ml only, not by --method {method}")

    def fit(m: Any) -> Any:
        try:
            if method == "ml":
                from ..batch import estimate as run

                return with_height(m, run(m, model, init=start, options=options), options,
                                   dim)
            from ..batch.methods import estimate_with

            return estimate_with(method, m, model, init=start, options=options)
        except ValueError as e:
            raise fail(str(e)) from None

    return fit


def sensor_error_fitter(meas: Any, motion: str | None, ref_time: float | None, method: str,
                        options: dict[str, Any], sigma: float) -> Any:
    """Return the fit that accounts for sensor position errors (``--sensor-position-sigma``)."""
    import math

    from ..batch.ml import estimate_with_sensor_errors

    if not (math.isfinite(sigma) and sigma >= 0):
        raise fail(f"--sensor-position-sigma {sigma}: expected a distance >= 0 (m)")
    if method != "ml":
        raise fail(f"--sensor-position-sigma: fitted by ml only, not --method {method}")
    model = motion_or_fail(motion, ref_time, meas)
    if getattr(model, "manoeuvres", None) is not None:
        raise fail("--sensor-position-sigma: for a motion without manoeuvres (cv2d, cv3d, "
                   "static2d, static3d)")

    def fit(m: Any) -> Any:
        try:
            return estimate_with_sensor_errors(m, model, sigma, options=options)[0]
        except ValueError as e:
            raise fail(f"--sensor-position-sigma: {e}") from None

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


def refit_scaled(meas: Any, result: Any, fit: Any, options: dict[str, Any]
                 ) -> tuple[Any, Any, dict[str, float]]:
    """``--scale-sigma``: rescale each kind's sigma from the residuals and fit again."""
    from ..results import normalised_residuals, scale_sigma

    try:
        scaled, factors = scale_sigma(meas, normalised_residuals(result, meas, options),
                                      result.dof)
    except ValueError as e:
        raise fail(f"--scale-sigma: {e}") from None
    return scaled, fit(scaled), factors


def estimate_manoeuvring(meas: Any, name: str, start: dict[str, float] | None,
                         options: dict[str, Any], ref_time: float | None, exact: bool,
                         criterion: str | None, alpha: float | None,
                         accelerations: str | None) -> Any:
    """Compute the ML estimate of a manoeuvring target (``--motion curvilinear[:M]``)."""
    from ..batch.curvilinear import estimate_for

    try:
        return estimate_for(meas, name, init=start, options=options, ref_time=ref_time,
                            exact=exact, criterion=criterion or "bic",
                            alpha=0.01 if alpha is None else alpha,
                            accelerations=accelerations)
    except ValueError as e:
        raise fail(str(e)) from None


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
        out.print(result.summary(units), highlight=False)
        if factors is not None:
            out.print("--scale-sigma: sigma multiplied by " + ", ".join(
                f"{f:.3g} ({k})" for k, f in factors.items()) + " from the first fit's "
                "residuals; the estimate and covariance above are of the refit",
                highlight=False)
        if shown is not None:
            print_answers(shown, units, meas,
                          None if trust.answer else "what the data determine (no answer: "
                                                    f"the estimate is {result.status})")
        out.print(f"trust: {trust.level}" + ("" if trust.level == "ok" else
                                             f" ({len(trust.reasons)} reason"
                                             f"{'s' if len(trust.reasons) > 1 else ''}: "
                                             + ", ".join(r.code for r in trust.reasons) + ")"),
                  highlight=False)
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
    say.print(f"wrote {path}", highlight=False)
