"""``tma crlb`` and ``tma gdop``: the Cramér-Rao lower bound of a file or a scenario; its map."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from .common import (
    DriftOption,
    FreeExponentOption,
    JsonOption,
    MotionOption,
    PropagationSpeedOption,
    RefTimeOption,
    SensorPositionSigmaOption,
    check_outputs,
    err,
    fail,
    failing,
    file_ref_time,
    load_scenario_or_fail,
    model_options,
    motion_or_fail,
    out,
    parse_assignments,
    read_or_fail,
    reads_logs,
    write_picture,
)
from .estimate import SPEED_UNITS, UnitsOption, check_units


@reads_logs(after="as_json")
def crlb(
    sources: Annotated[list[str], typer.Argument(
        metavar="SOURCE...", help="measurement file (several Debrief files: one replay), or a "
                                  "scenario name/TOML")],
    motion: MotionOption = None,
    ref_time: RefTimeOption = None,
    truth: Annotated[str | None, typer.Option(
        help="where to evaluate the bound, e.g. x=3200,y=3200,vx=-21.65,vy=-12.5")] = None,
    known_nuisance: Annotated[bool, typer.Option(
        help="treat carrier, drift, power constant and exponent as known")] = False,
    drift: DriftOption = False,
    propagation_speed: PropagationSpeedOption = None,
    free_exponent: FreeExponentOption = False,
    at: Annotated[float | None, typer.Option(
        help="also give position, speed, course and a 90 % ellipse at this time (s)")] = None,
    as_json: JsonOption = False,
    units: UnitsOption = "si",
    sensor_position_sigma: SensorPositionSigmaOption = None,
    *, logs: dict[str, Any],
) -> None:
    """Cramér-Rao lower bound: the best standard deviation any unbiased estimator can reach.

    For a file the bound is evaluated at --truth from the file's times, sensors, kinds and
    sigmas (its measured values are not used).  Nuisance parameters are unknown unless
    --known-nuisance is given.
    """
    check_units(units)
    if sensor_position_sigma is not None and not sensor_position_sigma >= 0:  # (nan, inf: guard)
        raise fail(f"--sensor-position-sigma {sensor_position_sigma}: expected a distance >= 0 (m)")
    from ..io import find_format  # the registry: a new format is a measurement file here too

    source = sources[0]
    if len(sources) > 1 or find_format(source, reading=True) or logs["format"] is not None:
        bound, warnings, meas, opts = bound_of_file(
            [Path(s) for s in sources], motion, ref_time, truth, known_nuisance,
            model_options(drift, free_exponent, propagation_speed),
            logs)
    else:
        given = [flag for flag, value in (("--motion", motion), ("--ref-time", ref_time),
                                          ("--truth", truth),
                                          ("--propagation-speed", propagation_speed))
                 if value is not None]
        if given:  # (not silently ignored)
            raise fail(f"{', '.join(given)}: for a measurement file; a scenario's bound is "
                       f"taken at its own truth and motion ({source} is a scenario)")
        bound, meas, opts = bound_of_scenario(source, known_nuisance, drift, free_exponent)
        warnings = []
    loss = None
    if sensor_position_sigma is not None:
        if known_nuisance:
            raise fail("--sensor-position-sigma: the bound with sensor errors takes the "
                       "nuisance as unknown; leave --known-nuisance out")
        bound, loss = with_sensor_errors(bound, meas, opts, sensor_position_sigma)
    derived = None if at is None else derived_at(bound, checked_at(at, meas))
    if derived is not None and bound.rank == len(bound.parameters) and not all(
            math.isfinite(derived["ellipse_90"][k]) for k in ("east", "north", "major")):
        raise fail(f"--at {at:g}: the bound overflows so far from the measurement times; "
                   "give a time near them (s)")
    print_bound(bound, derived, as_json, units, warnings)
    if loss is not None and not as_json:
        out.print(loss)


def with_sensor_errors(bound: Any, meas: Any, options: dict[str, Any], sigma: float
                       ) -> tuple[Any, str]:
    """Give the bound with sensor position errors and a sentence on its loss."""
    from ..bounds.fim import crlb_with_sensor_errors
    from ..scenario import Scenario

    if isinstance(meas, Scenario):
        meas = meas.simulate(rng=0, noise=False)
    p = bound.motion.n_params
    with failing("--sensor-position-sigma: "):
        errors, known = crlb_with_sensor_errors(meas, bound.motion, bound.values[:p], sigma,
                                                nuisance=bound.nuisance_values,
                                                options=options)
    parts = [f"{name} {a / b:.3g}x" for name, a, b in zip(
        errors.parameters[:p], errors.std[:p], known.std[:p], strict=True)]
    return errors, (f"sensor positions known to {sigma:g} m per axis: std against perfectly "
                    f"known positions {', '.join(parts)}")


def bound_of_file(file: Path | list[Path], motion: str | None, ref_time: float | None,
                  truth: str | None, known_nuisance: bool, kind_options: dict[str, dict[str, Any]],
                  options: dict[str, Any] | None = None
                  ) -> tuple[Any, list[Any], Any, dict[str, Any]]:
    """Compute the bound of a measurement file's times, sensors, kinds and sigmas."""
    import json

    from ..bounds import crlb as compute
    from ..results.checks import measurement_warnings

    meas = read_or_fail(file, **(options or {}))
    if meas.ambiguous_si is not None:  # a bound reads times and sigmas, not values
        err.print(f"note: the bound takes the side of the {int(meas.kind_mask('bearing').sum())}"
                  " towed-array cuts as known (resolved), turn cuts included; tma estimate "
                  "resolves the sides", soft_wrap=True)
    model = motion_or_fail(motion, ref_time, meas)
    values = parse_assignments(truth, "--truth")
    if not values and "truth" in meas.metadata and motion is None:
        from ..motion import default_ref_time

        stated = file_ref_time(meas)
        stated = default_ref_time(meas.time) if stated is None else stated
        if ref_time is not None and ref_time != stated:
            # The file's truth is stated at its own reference time: read at another it would
            # be another trajectory.
            raise fail(f"--ref-time {ref_time:.15g}: the file's truth is stated at its "
                       f"reference time {stated:.15g} s; give --truth at --ref-time, or leave "
                       "--ref-time out")
        values = json.loads(meas.metadata["truth"])
    if not values:
        raise fail("--truth is needed to evaluate the bound of a measurement file")
    opts = kind_options
    try:
        return (compute(meas, model, values, known_nuisance=known_nuisance, options=opts),
                measurement_warnings(meas), meas, opts)
    except ValueError as e:
        msg = str(e)
        if msg.startswith("truth ") and truth is not None:
            msg = f"--truth {truth}: {msg}"
        raise fail(msg) from None


def bound_of_scenario(source: str, known_nuisance: bool, drift: bool,
                      free_exponent: bool) -> tuple[Any, Any, dict[str, Any]]:
    """Compute the bound of a scenario at its truth."""
    from ..bounds import crlb as compute

    scn = load_scenario_or_fail(source)
    opts = scn.measurement_options
    if drift:
        opts.setdefault("frequency", {})["drift"] = True
    if free_exponent:
        opts.setdefault("power", {})["exponent"] = None
    with failing(f"scenario {source}: "):  # e.g. the truth crosses a sensor at a measurement time
        return compute(scn, known_nuisance=known_nuisance, options=opts), scn, opts


def checked_at(at: float, meas: Any) -> float:
    """Refuse an ``--at`` far from the data as ``tma estimate`` does (rules.time_problem)."""
    from ..rules import time_problem
    from ..scenario import Scenario

    times = (meas.simulate(rng=0, noise=False) if isinstance(meas, Scenario) else meas).time
    if (far := time_problem(at, times, "--at")) is not None:
        raise fail(far)
    return at


def derived_at(bound: Any, at: float) -> dict[str, Any]:
    """Position, speed, course with their standard deviations, and the 90 % ellipse, at a time."""
    data = {"time": at, **{k: {"value": v, "std": sd if sd == sd and sd != float(
        "inf") else None} for k, (v, sd) in bound.derived(at).items()},
        "ellipse_90": bound.ellipse(at, 0.9)}
    if "course" in data:  # the command line's angles are degrees (true); "course" stays rad
        from ..results.answers import parameter_display

        c = data["course"]
        value, sd, _ = parameter_display("course", c["value"], c["std"] or float("nan"))
        data["course_deg"] = {"value": value, "std": sd if c["std"] is not None else None}
    return data


def print_bound(bound: Any, derived: dict[str, Any] | None, as_json: bool,
                units: str = "si", warnings: list[Any] | None = None) -> None:
    """Print the bound, and what :func:`derived_at` gave, as text or JSON."""
    import json

    from ..results.trust import bound_trust
    from .estimate import print_warnings

    trust = bound_trust(bound, warnings or [])
    if as_json:
        data = {**bound.as_dict(), **trust.as_dict()}
        if derived is not None:
            data["at"] = derived
        out.print_json(json.dumps(data, default=lambda x: None))
        return
    out.print(bound.summary())
    out.print(f"trust: {trust.level}")
    print_warnings(list(warnings or []))
    if derived is not None:
        out.print(f"at t = {derived['time']:g} s:")
        from ..results.answers import parameter_display

        for k, v in derived.items():  # course_deg is the JSON's copy of course, in degrees
            if isinstance(v, dict) and "value" in v and k != "course_deg":
                sd = v["std"]
                value, sd_shown, unit = parameter_display(
                    k, v["value"], sd if sd is not None else float("nan"))
                if unit == "m/s":
                    unit, scale = SPEED_UNITS[units]
                    value, sd_shown = value / scale, sd_shown / scale
                out.print(f"  {k:<6} {value:14.6g}  std "
                          + (f"{sd_shown:.4g}" if sd is not None else "unobservable")
                          + f" {unit}")
        e = derived["ellipse_90"]
        out.print(f"  90 % ellipse: semi-axes {e['major']:.4g} m x {e['minor']:.4g} m, "
                  f"major axis bearing {e['bearing_deg']:.1f} deg")


def gdop(
    layout: Annotated[str, typer.Argument(
        help="scenario name or TOML file: its sensors and tdoa/fdoa measurements")],
    plot: Annotated[Path | None, typer.Option(
        help="draw CEP50 and CEP90 over the grid (PNG, PDF, SVG)")] = None,
    points: Annotated[int, typer.Option(help="grid points per side")] = 100,
    half_width: Annotated[float | None, typer.Option(
        help="half the grid's side (m); default twice the sensors' spread")] = None,
    height: Annotated[float, typer.Option(help="the emitter's known ENU height (m)")] = 0.0,
    as_json: JsonOption = False,
    force: Annotated[bool, typer.Option(help="overwrite an existing --plot file")] = False,
) -> None:
    """Geolocation accuracy map: CEP50/CEP90 of a stationary emitter over a grid.

    The circle about the true position holding the best unbiased estimate (the CRLB) with
    probability 50 % and 90 %, from the layout's TDOA and FDOA rows (noise shared through
    each reference sensor), the emitter's height known.
    """
    import numpy as np

    from ..plot.gdop import cep_map, plot_cep_map

    if points < 2 or points > 2000:
        raise fail(f"--points {points}: expected 2 to 2000 per side")
    scenario = load_scenario_or_fail(layout)
    (plot,) = check_outputs([("--plot", plot, "picture")], force)
    try:
        result = cep_map(scenario, points, half_width, height)
    except ValueError as e:  # the grid's options by their flags, the layout's problems by file
        text = str(e)
        for keyword, flag in (("half_width:", "--half-width"), ("height:", "--height")):
            if text.startswith(keyword):
                raise fail(flag + text.removeprefix(keyword[:-1])) from None
        raise fail(f"{layout}: {text}") from None
    finite50 = result.cep50[np.isfinite(result.cep50)]
    finite90 = result.cep90[np.isfinite(result.cep90)]
    summary = {
        "layout": scenario.name, "points": points,
        "east_m": [float(result.east[0]), float(result.east[-1])],
        "north_m": [float(result.north[0]), float(result.north[-1])],
        "cep50_m": _stats(finite50), "cep90_m": _stats(finite90),
        "unobservable_points": int(result.cep50.size - finite50.size),
        "ignored_kinds": result.ignored,
    }
    if plot is not None:
        write_picture(plot, force, lambda tmp: plot_cep_map(result, tmp, scenario.name))
    if as_json:
        import json

        out.print_json(json.dumps(summary))
        return
    out.print(f"{scenario.name}: {points} x {points} emitter positions, east "
              f"{result.east[0]:.0f}..{result.east[-1]:.0f} m, north {result.north[0]:.0f}.."
              f"{result.north[-1]:.0f} m, height {height:g} m (known)")
    for name, stats in (("CEP50", summary["cep50_m"]), ("CEP90", summary["cep90_m"])):
        out.print(f"{name}: min {stats['min']:.4g} m, median {stats['median']:.4g} m, "
                  f"max {stats['max']:.4g} m")
    if summary["unobservable_points"]:
        out.print(f"{summary['unobservable_points']} points unobservable (no finite bound)")
    if result.ignored:
        out.print(f"not in the map: the {', '.join(result.ignored)} measurements (the map "
                  "takes tdoa and fdoa)")
    if plot is not None:
        out.print(f"wrote {plot}")


def _stats(values: object) -> dict[str, float]:
    import numpy as np

    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"min": float("inf"), "median": float("inf"), "max": float("inf")}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}
