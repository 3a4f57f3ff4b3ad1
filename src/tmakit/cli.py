"""The ``tma`` command.

    tma scenarios                                  list the built-in scenarios
    tma simulate SCENARIO [--seed N] [--no-noise] -o FILE [--force]
    tma show FILE [--plot out.png] [--origin LAT,LON,ALT] [--force]
    tma demo [--out-dir DIR] [--seed N] [--force]
    tma crlb FILE --motion cv2d --truth x=..,y=.. [--known-nuisance] [--json]
    tma crlb SCENARIO [--known-nuisance] [--at T] [--json]
    tma estimate FILE [--motion cv2d] [--init x=..,y=..] [--method ml] [--json]
    tma reproduce gu2007|doppler-lecture|hoerst2010|chen-sun [--runs N] [--seed S] [--plot FILE]
    tma montecarlo SCENARIO [--runs N] [--seed S] [--estimator ml] [--dask ADDR] [-o FILE]
    tma track FILE [--filter ekf|ukf|mgekf|pf] [--q Q] [--json] [-o track.csv] [--plot out.png]

Every command refuses to overwrite an existing output unless ``--force`` is given, and
reports bad input as ``error: ...`` naming the file, row and field, with exit status 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="tmakit: passive emitter localisation and target motion analysis.")
out = Console()
err = Console(stderr=True)


def _fail(message: str) -> typer.Exit:
    err.print(f"[bold red]error:[/] {message}", highlight=False, markup=True, soft_wrap=True)
    return typer.Exit(2)


def _refuse_existing(path: Path, force: bool) -> None:
    if path.exists() and not force:
        raise _fail(f"{path} already exists; use --force to overwrite it")


def _parse_origin(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        lat, lon, alt = (float(v) for v in text.split(","))
    except ValueError:
        raise _fail(f"--origin {text!r}: expected LAT,LON,ALT in degrees, degrees, "
                    "metres") from None
    return lat, lon, alt


def _load_scenario(name: str):
    from .scenario_file import ScenarioFileError, load_scenario

    try:
        return load_scenario(name)
    except ScenarioFileError as e:
        raise _fail(str(e)) from None


def _read(path: Path, origin: tuple[float, float, float] | None = None):
    from .io.measurement_files import MeasurementFileError, read_measurements

    if not path.exists():
        raise _fail(f"{path}: no such file")
    try:
        return read_measurements(path, origin=origin)
    except (MeasurementFileError, ValueError) as e:
        raise _fail(str(e)) from None


def _write(meas, path: Path, force: bool) -> None:
    from .io.measurement_files import write_measurements

    try:
        write_measurements(meas, path, force=force)
    except FileExistsError:
        raise _fail(f"{path} already exists; use --force to overwrite it") from None
    except ValueError as e:
        raise _fail(str(e)) from None


def _summary_table(meas, title: str) -> Table:
    table = Table(title=title, title_justify="left")
    for col, justify in (("sensor", "left"), ("kind", "left"), ("n", "right"),
                         ("time (s)", "right"), ("value range", "right"),
                         ("median sigma", "right"), ("unit", "left")):
        table.add_column(col, justify=justify)  # type: ignore[arg-type]
    for r in meas.summary_rows():
        table.add_row(r["sensor"], r["kind"], str(r["count"]),
                      f"{r['t_first']:g} .. {r['t_last']:g}",
                      f"{r['value_min']:.10g} .. {r['value_max']:.10g}",
                      f"{r['sigma_median']:.4g}", r["unit"])
    return table


def _describe_sensors(meas) -> Table:
    table = Table(title="sensors", title_justify="left")
    for col in ("sensor", "start (E, N, U) m", "end (E, N, U) m", "mean speed (m/s)"):
        table.add_column(col)
    import numpy as np

    for s in meas.sensors:
        sel = meas.sensor == s
        st = meas.sensor_state[sel]
        order = np.argsort(meas.time[sel], kind="stable")
        a, b = st[order[0]], st[order[-1]]
        speed = float(np.mean(np.linalg.norm(st[:, 3:], axis=1)))
        table.add_row(s, f"{a[0]:.1f}, {a[1]:.1f}, {a[2]:.1f}",
                      f"{b[0]:.1f}, {b[1]:.1f}, {b[2]:.1f}", f"{speed:.2f}")
    return table


@app.command()
def scenarios() -> None:
    """List the built-in scenarios, one line each."""
    from .scenario_file import builtin_scenarios

    table = Table(show_header=True, box=None)
    table.add_column("name", style="bold")
    table.add_column("what it is")
    for name, title in builtin_scenarios():
        table.add_row(name, title)
    out.print(table)


@app.command()
def simulate(
    scenario: Annotated[str, typer.Argument(help="built-in scenario name or TOML file")],
    output: Annotated[Path, typer.Option("-o", "--output",
                                         help="measurement file to write (.csv or .parquet)")],
    seed: Annotated[int | None, typer.Option(help="random seed (same seed, same data)")] = None,
    no_noise: Annotated[bool, typer.Option("--no-noise", help="noise-free values")] = False,
    force: Annotated[bool, typer.Option(help="overwrite an existing output file")] = False,
) -> None:
    """Simulate a scenario's measurements and write them to a file."""
    _refuse_existing(output, force)
    scn = _load_scenario(scenario)
    meas = scn.simulate(rng=seed, noise=not no_noise)
    _write(meas, output, force)
    out.print(f"wrote {len(meas)} measurements of {scn.name} to {output}"
              + (f" (seed {seed})" if seed is not None else "")
              + (" without noise" if no_noise else ""), highlight=False)


@app.command()
def show(
    file: Annotated[Path, typer.Argument(help="measurement file (.csv or .parquet)")],
    plot: Annotated[Path | None, typer.Option(help="write a picture (PNG, PDF, SVG)")] = None,
    origin: Annotated[str | None, typer.Option(
        help="ENU origin LAT,LON,ALT for files with sensor_lat/sensor_lon")] = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing picture")] = False,
) -> None:
    """Summarise a measurement file per sensor and kind, and optionally draw it."""
    if plot is not None:
        _refuse_existing(plot, force)
    meas = _read(file, _parse_origin(origin))
    meta = meas.metadata
    title = f"{file}: {len(meas)} measurements"
    if "scenario" in meta:
        title += f" of scenario {meta['scenario']}"
        if "seed" in meta:
            title += f" (seed {meta['seed']})"
    out.print(_summary_table(meas, title))
    out.print(_describe_sensors(meas))
    if "truth" in meta:
        out.print(f"truth ({meta.get('motion', '?')}): {meta['truth']}", highlight=False)
    if plot is not None:
        from .plot import plot_measurements

        plot_measurements(meas, plot, title=title)
        out.print(f"wrote {plot}", highlight=False)


def _parse_assignments(text: str | None, option: str) -> dict[str, float]:
    """``"x=1,y=2"`` -> {"x": 1.0, "y": 2.0}, with a clear error for anything else."""
    if text is None:
        return {}
    out: dict[str, float] = {}
    for part in text.split(","):
        name, eq, value = part.partition("=")
        try:
            if not eq or not name.strip():
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise _fail(f"{option} {text!r}: expected name=value pairs separated by commas, "
                        f"e.g. x=3200,y=3200,vx=-21.65,vy=-12.5 (problem at {part!r})"
                        ) from None
    return out


def _motion(name: str | None, ref_time: float | None, meas=None):
    from .motion import motion_from_name

    if name is None:
        if meas is not None and "motion" in meas.metadata:
            name = meas.metadata["motion"]
            if ref_time is None and "ref_time" in meas.metadata:
                ref_time = float(meas.metadata["ref_time"])
        else:
            raise _fail("--motion is needed (cv2d, cv3d, static2d, static3d)")
    try:
        return motion_from_name(name, 0.0 if ref_time is None else ref_time)
    except ValueError as e:
        raise _fail(str(e)) from None


def _model_options(drift: bool, free_exponent: bool) -> dict[str, dict[str, object]]:
    return {"frequency": {"drift": drift}, "power": {"exponent": None if free_exponent else 2.0}}


# Options shared by the commands that fit or bound a motion model.
MotionOption = Annotated[str | None, typer.Option(
    help="cv2d, cv3d, static2d, static3d, curvilinear[:M]")]
RefTimeOption = Annotated[float | None, typer.Option(
    help="reference time of the motion parameters (s)")]
DriftOption = Annotated[bool, typer.Option(help="model a linear carrier drift")]
FreeExponentOption = Annotated[bool, typer.Option(help="the path-loss exponent is unknown too")]


def _is_measurement_file(text: str) -> bool:
    return Path(text).suffix.lower() in (".csv", ".parquet", ".pq")


@app.command()
def crlb(
    source: Annotated[str, typer.Argument(help="measurement file, or a scenario name/TOML")],
    motion: MotionOption = None,
    ref_time: RefTimeOption = None,
    truth: Annotated[str | None, typer.Option(
        help="where to evaluate the bound, e.g. x=3200,y=3200,vx=-21.65,vy=-12.5")] = None,
    known_nuisance: Annotated[bool, typer.Option(
        help="treat carrier, drift, power constant and exponent as known")] = False,
    drift: DriftOption = False,
    free_exponent: FreeExponentOption = False,
    at: Annotated[float | None, typer.Option(
        help="also give position, speed, course and a 90 % ellipse at this time (s)")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON")] = False,
) -> None:
    """Cramér-Rao lower bound: the best standard deviation any unbiased estimator can reach.

    For a file the bound is evaluated at --truth from the file's times, sensors, kinds and
    sigmas (its measured values are not used).  Nuisance parameters are unknown unless
    --known-nuisance is given.
    """
    import json

    from .bounds import crlb as compute

    if _is_measurement_file(source):
        meas = _read(Path(source))
        model = _motion(motion, ref_time, meas)
        values = _parse_assignments(truth, "--truth")
        if not values and "truth" in meas.metadata and motion is None:
            values = json.loads(meas.metadata["truth"])
        if not values:
            raise _fail("--truth is needed to evaluate the bound of a measurement file")
        try:
            bound = compute(meas, model, values, known_nuisance=known_nuisance,
                            options=_model_options(drift, free_exponent))
        except ValueError as e:
            raise _fail(str(e)) from None
    else:
        scn = _load_scenario(source)
        opts = scn.measurement_options
        if drift:
            opts.setdefault("frequency", {})["drift"] = True
        if free_exponent:
            opts.setdefault("power", {})["exponent"] = None
        bound = compute(scn, known_nuisance=known_nuisance, options=opts)
    derived = None
    if at is not None:
        derived = {"time": at, **{k: {"value": v, "std": sd if sd == sd and sd != float(
            "inf") else None} for k, (v, sd) in bound.derived(at).items()},
            "ellipse_90": bound.ellipse(at, 0.9)}
    if as_json:
        data = bound.as_dict()
        if derived is not None:
            data["at"] = derived
        out.print_json(json.dumps(data, default=lambda x: None))
        return
    out.print(bound.summary(), highlight=False)
    if derived is not None:
        out.print(f"at t = {at:g} s:", highlight=False)
        for k, v in derived.items():
            if isinstance(v, dict) and "value" in v:
                sd = v["std"]
                out.print(f"  {k:<6} {v['value']:14.6g}  std "
                          + (f"{sd:.4g}" if sd is not None else "unobservable"),
                          highlight=False)
        e = derived["ellipse_90"]
        out.print(f"  90 % ellipse: semi-axes {e['major']:.4g} m x {e['minor']:.4g} m, "
                  f"major axis bearing {e['bearing_deg']:.1f} deg", highlight=False)


@app.command()
def estimate(
    file: Annotated[Path, typer.Argument(help="measurement file (.csv or .parquet)")],
    motion: MotionOption = None,
    ref_time: RefTimeOption = None,
    init: Annotated[str | None, typer.Option(
        help="optional starting point, e.g. x=3000,y=3000,vx=-20,vy=-10")] = None,
    method: Annotated[str, typer.Option(
        help="ml (default), or a paper's method: gu-direct, ratio, ratio-power, "
             "ratio-doppler, lecture-gn")] = "ml",
    drift: DriftOption = False,
    free_exponent: FreeExponentOption = False,
    origin: Annotated[str | None, typer.Option(
        help="ENU origin LAT,LON,ALT for files with sensor_lat/sensor_lon")] = None,
    exact: Annotated[bool, typer.Option(
        "--exact", help="curvilinear:M: fit exactly M manoeuvres (default: 0 to M)")] = False,
    criterion: Annotated[str | None, typer.Option(
        help="curvilinear: how the number of manoeuvres is chosen, bic (default) or lrt")
    ] = None,
    alpha: Annotated[float | None, typer.Option(
        help="curvilinear, --criterion lrt: level of the likelihood-ratio tests "
             "(default 0.01)")] = None,
    accelerations: Annotated[str | None, typer.Option(
        help="curvilinear: select (default: hold at zero the accelerations the data do not "
             "need, by the same criterion) or all")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON")] = False,
) -> None:
    """Estimate the emitter's trajectory from a measurement file (no initial guess needed).

    --motion curvilinear[:M] searches 0 to M manoeuvres (default M = 2) and chooses their
    number by BIC or likelihood-ratio tests, and holds at zero the accelerations the data do
    not need (tmakit.batch.curvilinear)."""
    meas = _read(file, _parse_origin(origin))
    start = _parse_assignments(init, "--init") or None
    options = _model_options(drift, free_exponent)
    # -- manoeuvring targets: tmakit.batch.curvilinear --------------------------------------
    name = motion if motion is not None else meas.metadata.get("motion")
    if name is not None and getattr(_motion(name, ref_time), "manoeuvres", None) is not None:
        if method != "ml":
            raise _fail(f"--method {method}: manoeuvring targets (--motion {name}) are "
                        "estimated by ml only")
        if ref_time is None and motion is None and "ref_time" in meas.metadata:
            ref_time = float(meas.metadata["ref_time"])
        from .batch.curvilinear import estimate_for

        try:
            result = estimate_for(meas, name, init=start, options=options, ref_time=ref_time,
                                  exact=exact, criterion=criterion or "bic",
                                  alpha=0.01 if alpha is None else alpha,
                                  accelerations=accelerations)
        except ValueError as e:
            raise _fail(str(e)) from None
        _print_estimate(meas, result, as_json)
        return
    if exact or criterion is not None or alpha is not None or accelerations is not None:
        raise _fail("--exact, --criterion, --alpha and --accelerations apply to --motion "
                    "curvilinear[:M] only")
    # -------------------------------------------------------------------------------------
    model = _motion(motion, ref_time, meas)
    try:
        if method == "ml":
            from .batch import estimate as run

            result = run(meas, model, init=start, options=options)
        else:
            from .batch.methods import estimate_with

            result = estimate_with(method, meas, model, init=start, options=options)
    except ValueError as e:
        raise _fail(str(e)) from None
    _print_estimate(meas, result, as_json)


def _print_estimate(meas, result, as_json: bool) -> None:
    """Print an estimate (text or JSON); exit status 1 unless it converged."""
    geo = _geodetic_position(meas, result)
    if as_json:
        import json

        data = result.as_dict()
        if geo is not None:
            data["geodetic"] = geo
        out.print_json(json.dumps(data))
    else:
        out.print(result.summary(), highlight=False)
        if geo is not None:
            out.print(f"position at t = {geo['time']:g} s: lat {geo['lat']:.7f} deg, "
                      f"lon {geo['lon']:.7f} deg, alt {geo['alt']:.1f} m (WGS-84)",
                      highlight=False)
    if result.status != "converged":
        raise typer.Exit(1)


def _geodetic_position(meas, result) -> dict[str, float] | None:
    """The estimated position at the motion model's reference time in WGS-84, when the file
    gives the ENU origin (``origin_lat``, ``origin_lon``, ``origin_alt``)."""
    meta = meas.metadata
    if not {"origin_lat", "origin_lon"} <= set(meta) or not result.estimate.size:
        return None
    import numpy as np

    from .geodesy import enu_to_geodetic

    t = float(getattr(result.motion, "ref_time", meas.time.min()))
    state = result.motion.states(result.estimate, np.array([t]))[0]
    if not np.all(np.isfinite(state[:3])):
        return None
    origin = (float(meta["origin_lat"]), float(meta["origin_lon"]),
              float(meta.get("origin_alt", 0.0)))
    lat, lon, alt = enu_to_geodetic(state[0], state[1], state[2], origin)
    return {"time": t, "lat": float(lat), "lon": float(lon), "alt": float(alt)}


@app.command()
def reproduce(
    name: Annotated[str, typer.Argument(
        help="gu2007, doppler-lecture, hoerst2010 or chen-sun")],
    runs: Annotated[int | None, typer.Option(
        help="Monte Carlo runs where the paper has them (0 to skip; default: the paper's "
             "number, gu2007 200, chen-sun 30)")] = None,
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON")] = False,
    plot: Annotated[Path | None, typer.Option(
        help="draw the paper's figure (PNG, PDF, SVG; hoerst2010, chen-sun: Fig. 2)")
    ] = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing --plot file")] = False,
) -> None:
    """Reproduce a paper's tables and figures next to the paper's own numbers."""
    import importlib

    from .reproduce import REPRODUCTIONS

    if name not in REPRODUCTIONS:
        raise _fail(f"no reproduction named {name!r}; available: {', '.join(REPRODUCTIONS)}")
    if runs is not None and runs < 0:
        raise _fail("--runs must be 0 or more")
    module = importlib.import_module(REPRODUCTIONS[name])
    if plot is not None:
        if not hasattr(module, "plot"):
            drawn = [n for n, m in REPRODUCTIONS.items()
                     if hasattr(importlib.import_module(m), "plot")]
            raise _fail(f"--plot: reproduction {name!r} draws no figure (figures: "
                        f"{', '.join(drawn)})")
        _refuse_existing(plot, force)
    rep = module.run(**({} if runs is None else {"runs": runs}), seed=seed,
                     progress=not as_json)
    if plot is not None:
        module.plot(rep, plot)
    if as_json:
        import json

        out.print_json(json.dumps(rep.as_dict(), default=float))
        return
    for section in rep.sections:
        table = Table(title=section.title, title_justify="left")
        for col in section.header:
            table.add_column(col)
        for row in section.rows:
            table.add_row(*(f"{v:.10g}" if isinstance(v, float) else str(v) for v in row))
        out.print(table)
        if section.note:
            out.print(section.note, highlight=False)
    for key, value in rep.figures.items():
        out.print(f"{key}: {value}", highlight=False)
    if plot is not None:
        out.print(f"wrote {plot}", highlight=False)


@app.command()
def montecarlo(
    scenario: Annotated[str, typer.Argument(help="built-in scenario name or TOML file")],
    runs: Annotated[int, typer.Option(help="number of Monte Carlo runs")] = 100,
    seed: Annotated[int, typer.Option(help="random seed (same seed, same table)")] = 0,
    estimator: Annotated[str, typer.Option(
        help="ml (default) or another method of tmakit.batch.methods")] = "ml",
    known_nuisance: Annotated[bool, typer.Option(
        "--known-nuisance", help="give the estimator (and the bound) the true carrier, "
        "power constant, ...; default: unknown, estimated")] = False,
    dask: Annotated[str | None, typer.Option(
        help="Dask scheduler address (tcp://host:8786); default: run here")] = None,
    chunk: Annotated[int | None, typer.Option(help="runs per task")] = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the per-run table (.csv or .parquet)")] = None,
    json_file: Annotated[Path | None, typer.Option(
        "--json", help="write the summary as JSON")] = None,
    no_progress: Annotated[bool, typer.Option("--no-progress",
                                              help="no progress bar")] = False,
    force: Annotated[bool, typer.Option(help="overwrite existing output files")] = False,
) -> None:
    """Simulate and estimate a scenario many times; compare the RMSE with the CRLB."""
    for path in (output, json_file):
        if path is not None:
            _refuse_existing(path, force)
    if output is not None and output.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise _fail(f"{output}: the per-run table is written as .csv or .parquet")
    scn = _load_scenario(scenario)
    from .montecarlo import monte_carlo

    try:
        res = monte_carlo(scn, estimator=estimator, runs=runs, seed=seed,
                          known_nuisance=known_nuisance, progress=not no_progress,
                          dask=dask, chunk=chunk)
    except (ValueError, ImportError) as e:
        raise _fail(str(e)) from None
    except OSError as e:  # the Dask scheduler cannot be reached
        raise _fail(f"Dask scheduler {dask}: {e}") from None
    counts = ", ".join(f"{k} {v}" for k, v in res.status_counts.items())
    table = Table(title=f"{res.estimator} on {res.scenario}: {res.runs} runs (seed {res.seed}), "
                        f"nuisance {'known' if res.known_nuisance else 'unknown'}",
                  title_justify="left")
    for col in ("parameter", "truth", "bias", "RMSE", "CRLB", "RMSE/CRLB", "95 % interval"):
        table.add_column(col, justify="left" if col == "parameter" else "right")
    for r in res.summary_table():
        table.add_row(r["parameter"], f"{r['truth']:.6g}", f"{r['bias']:.4g}",
                      f"{r['rmse']:.4g}", f"{r['crlb']:.4g}", f"{r['ratio']:.3f}",
                      f"{r['ratio_low']:.3f} .. {r['ratio_high']:.3f}")
    out.print(table)
    out.print(f"converged {res.convergence_rate:.1%} ({counts}); {res.wall_time:.1f} s, "
              f"{res.runs_per_second:.1f} runs/s ({res.executor})", highlight=False)
    if output is not None:
        res.save(output, force=force)
        out.print(f"wrote {output}", highlight=False)
    if json_file is not None:
        json_file.write_text(res.to_json() + "\n")
        out.print(f"wrote {json_file}", highlight=False)


@app.command()
def track(
    file: Annotated[Path, typer.Argument(help="measurement file (.csv or .parquet)")],
    filter_name: Annotated[str, typer.Option(
        "--filter", help="ekf, ukf, mgekf or pf (the filters of tmakit.filters.FILTERS)")
    ] = "ekf",
    q: Annotated[str, typer.Option(
        "--q", help="process noise: acceleration std (m/s^2), one value or per axis "
                    "qx,qy[,qz]; 0 = constant velocity")] = "0",
    particles: Annotated[int | None, typer.Option(
        help="number of particles (particle filter only)")] = None,
    seed: Annotated[int | None, typer.Option(
        help="random seed (particle filter only; same seed, same track)")] = None,
    prior: Annotated[str | None, typer.Option(
        help="start from this state instead of a batch estimate, e.g. "
             "x=4000,y=9000,vx=-6,vy=-3 (m, m/s); needs --prior-std")] = None,
    prior_std: Annotated[str | None, typer.Option(
        help="the prior's standard deviations, e.g. x=3000,y=3000,vx=10,vy=10")] = None,
    prior_time: Annotated[float | None, typer.Option(
        help="time of the prior (s); default: the first measurement time")] = None,
    nuisance: Annotated[str | None, typer.Option(
        help="known nuisance values with --prior, e.g. carrier=9.4e9 (Hz, dBW)")] = None,
    init_window: Annotated[int | None, typer.Option(
        help="start from a batch estimate over this many first measurement times "
             "(default: the shortest window good enough, see --start-std)")] = None,
    start_std: Annotated[float, typer.Option(
        help="start quality: the batch start's position std must be below this fraction "
             "of the range")] = 0.25,
    dim: Annotated[int | None, typer.Option(
        help="2 or 3 (default: 3 when the data or the file's motion need it)")] = None,
    drift: DriftOption = False,
    free_exponent: FreeExponentOption = False,
    origin: Annotated[str | None, typer.Option(
        help="ENU origin LAT,LON,ALT for files with sensor_lat/sensor_lon")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the track as JSON")] = False,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the track table (.csv or .parquet)")] = None,
    plot: Annotated[Path | None, typer.Option(
        help="draw the track (PNG, PDF, SVG); with the truth in the file, its error "
             "against the posterior CRB")] = None,
    ellipses: Annotated[int, typer.Option(
        help="number of 90 %/95 % position ellipses drawn along the track")] = 8,
    rows: Annotated[int, typer.Option(help="rows of the summary table")] = 12,
    force: Annotated[bool, typer.Option(help="overwrite existing output files")] = False,
) -> None:
    """Track the emitter with a recursive filter: state and covariance after every update.

    No initial guess is needed: the filter starts from a batch estimate over the shortest
    initial window of the data that determines the position well enough (or from --prior).
    """
    import json

    from . import tracking
    from .filters import FILTERS

    for path in (output, plot):
        if path is not None:
            _refuse_existing(path, force)
    if output is not None and output.suffix.lower() not in tracking.TABLE_SUFFIXES:
        raise _fail(f"{output}: the track table is written as .csv or .parquet")
    if filter_name not in FILTERS:
        raise _fail(f"--filter {filter_name!r}: expected one of {', '.join(sorted(FILTERS))}")
    random_filters = tracking.random_filters()
    for option, value in (("--particles", particles), ("--seed", seed)):
        if value is not None and filter_name not in random_filters:
            raise _fail(f"{option} applies only to the particle filter"
                        f"{'s' if len(random_filters) > 1 else ''} "
                        f"({', '.join(random_filters) or 'none registered'}), not to "
                        f"{filter_name}")
    if ellipses < 0 or rows < 1:
        raise _fail("--ellipses must be 0 or more and --rows 1 or more")
    meas = _read(file, _parse_origin(origin))
    try:
        d = tracking.filter_dim(meas, dim)
        q_axes = tracking.parse_q(q, d)
    except ValueError as e:
        raise _fail(f"--{e}") from None
    prior_mean = _parse_assignments(prior, "--prior") or None
    prior_sd = _parse_assignments(prior_std, "--prior-std") or None
    known = _parse_assignments(nuisance, "--nuisance") or None
    if (prior_mean is None) != (prior_sd is None):
        raise _fail("--prior and --prior-std go together (the state and its standard "
                    "deviations, by name)")
    if known is not None and prior_mean is None:
        raise _fail("--nuisance goes with --prior; a batch start estimates the nuisance "
                    "values itself")
    if prior_mean is not None and init_window is not None:
        raise _fail("--init-window chooses the batch start; it cannot be used with --prior")
    try:
        tr = tracking.track(meas, filter_name, q=q_axes, particles=particles,
                            prior=prior_mean, prior_std=prior_sd, prior_time=prior_time,
                            init_window=init_window, max_relative_std=start_std, rng=seed,
                            dim=d, options=_model_options(drift, free_exponent),
                            nuisance=known)
    except ValueError as e:
        raise _fail(str(e)) from None
    truth = tracking.truth_states(meas, tr.times, d)
    say = err if as_json else out
    if as_json:  # one line: the track is long, and rich's JSON printer slow on it
        typer.echo(json.dumps(tracking.track_dict(tr)))
    else:
        _print_track(tr, truth, rows)
    if output is not None:
        try:
            tracking.write_track(tr, output, force=force)
        except FileExistsError:
            raise _fail(f"{output} already exists; use --force to overwrite it") from None
        say.print(f"wrote {output}", highlight=False)
    if plot is not None:
        from .plot import plot_track

        bound, note = (tracking.track_pcrb(meas, tr, truth) if truth is not None
                       else (None, ""))
        title = f"{file}: {tr.filter_name} track"
        if "scenario" in meas.metadata:
            title += f" of scenario {meas.metadata['scenario']}"
        plot_track(tr, meas, plot, truth=truth, pcrb=bound, pcrb_note=note,
                   ellipses=ellipses, title=title)
        say.print(f"wrote {plot}", highlight=False)


def _start_sentence(tr) -> str:
    s = tr.extra["start"]
    if s["method"] == "prior":
        return f"start: the given prior at t = {s['time']:g} s"
    text = (f"start: batch ML estimate over the first {s['window']} measurement times "
            f"({s['rows']} rows, t <= {s['time']:g} s), {s['status']}, position std "
            f"{s['relative_position_std']:.1%} of the range")
    if s.get("max_relative_std") is not None:
        text += f" (needed < {s['max_relative_std']:.0%})"
    if s.get("nuisance"):
        text += ("; nuisance held at " + ", ".join(
            f"{k} = {v['value']:.10g} (std {v['std']:.3g})" for k, v in s["nuisance"].items())
            + " (the filter does not carry their uncertainty)")
    check = s.get("confirmation")
    if check and check["dof"]:
        text += (f"; confirmed by the next {check['updates']} updates (NIS {check['nis']:.1f} "
                 f"on {check['dof']} dof, p = {check['p_value']:.2g})")
    for r in s.get("rejected", []):
        text += (f"; rejected first: the window of {r['window']} times (t <= {r['time']:g} s), "
                 f"NIS {r['nis']:.1f} on {r['dof']} dof over the next {r['updates']} updates "
                 f"(p = {r['p_value']:.2g})")
    return text


def _print_track(tr, truth, n_rows: int) -> None:
    import numpy as np

    dim = len(tr.state_names) // 2
    k_sel = np.unique(np.linspace(0, len(tr) - 1, min(n_rows, len(tr))).round().astype(int))
    q = ", ".join(f"{v:g}" for v in tr.extra["q"])
    table = Table(title=f"{tr.filter_name} track: {len(tr)} rows, t = {tr.times[0]:g} .. "
                        f"{tr.times[-1]:g} s, q = {q} m/s^2 ({len(k_sel)} rows shown)",
                  title_justify="left")
    cols = ["t\n(s)", *(f"{n}\n(m)" for n in tr.state_names[:dim]), "std\n(m)",
            "speed\n(m/s)", "course\n(deg)", "NIS/\ndof"]
    if truth is not None:
        cols.append("error\n(m)")
    for c in cols:
        table.add_column(c, justify="right", no_wrap=True)
    pos_sd = np.sqrt(np.einsum("kii->k", tr.covariances[:, :dim, :dim]))
    for k in k_sel:
        v = tr.states[k, dim:]
        speed = float(np.linalg.norm(v))
        course = float(np.degrees(np.arctan2(v[0], v[1])) % 360.0)
        nis = (f"{tr.nis[k]:.2f}/{tr.dof[k]}" if tr.dof[k] > 0 else "start")
        row = [f"{tr.times[k]:g}", *(f"{x:.1f}" for x in tr.states[k, :dim]),
               f"{pos_sd[k]:.1f}", f"{speed:.2f}", f"{course:.1f}", nis]
        if truth is not None:
            row.append(f"{np.linalg.norm(tr.states[k, :dim] - truth[k, :dim]):.1f}")
        table.add_row(*row)
    out.print(table)
    out.print("std: position RMS std sqrt(trace P); NIS: normalised innovation squared",
              highlight=False)
    out.print(_start_sentence(tr), highlight=False)
    used = tr.dof > 0
    if np.any(used):
        mean_nis = float(np.sum(tr.nis[used]) / np.sum(tr.dof[used]))
        out.print(f"{int(np.sum(used))} updates, mean NIS per degree of freedom "
                  f"{mean_nis:.3f} (1 when consistent), log-likelihood "
                  f"{tr.log_likelihood[-1]:.2f}", highlight=False)
    if truth is not None:
        e = tr.states[-1, :dim] - truth[-1, :dim]
        cov = tr.covariances[-1, :dim, :dim]
        m = float(np.sqrt(e @ np.linalg.solve(cov, e)))
        out.print(f"truth known (file metadata): final position error "
                  f"{np.linalg.norm(e):.1f} m, {m:.2f} sigma (Mahalanobis, {dim}-D)",
                  highlight=False)


@app.command()
def demo(
    out_dir: Annotated[Path, typer.Option(help="folder for the demo's files")] = Path(
        "tma-demo"),
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    force: Annotated[bool, typer.Option(help="overwrite earlier demo files")] = False,
) -> None:
    """Simulate the gu2007 scenario, summarise it and draw it."""
    csv = out_dir / "gu2007.csv"
    png = out_dir / "gu2007.png"
    for p in (csv, png):
        _refuse_existing(p, force)
    out_dir.mkdir(parents=True, exist_ok=True)
    scn = _load_scenario("gu2007")
    out.print(scn.summary(), highlight=False)
    meas = scn.simulate(rng=seed)
    _write(meas, csv, force)
    out.print(f"wrote {csv}", highlight=False)
    show(csv, plot=png, origin=None, force=force)


def main() -> None:
    """Entry point of the ``tma`` console script."""
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
