"""The commands that run many simulations: ``tma montecarlo``, ``reproduce`` and ``plan``."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from .common import (
    ForceOption,
    JsonOption,
    NoProgressOption,
    check_outputs,
    check_particles,
    claim_outputs,
    err,
    fail,
    load_scenario_or_fail,
    out,
    print_wide,
    write_picture,
)

#: Default limit of ``--runs`` (raise with ``--max-runs``).
MAX_RUNS = 1_000_000


def montecarlo(
    scenario: Annotated[str, typer.Argument(help="built-in scenario name or TOML file")],
    runs: Annotated[int, typer.Option(min=1, help="number of Monte Carlo runs")] = 100,
    seed: Annotated[int, typer.Option(min=0, help="random seed (same seed, same table)")] = 0,
    estimator: Annotated[str, typer.Option(
        help="ml (default) or another method of tmakit.batch.methods")] = "ml",
    known_nuisance: Annotated[bool, typer.Option(
        "--known-nuisance", help="give the estimator (and the bound) the true carrier, "
        "power constant, ...; default: unknown, estimated")] = False,
    dask: Annotated[str | None, typer.Option(
        help="Dask scheduler address (tcp://host:8786); default: run here")] = None,
    chunk: Annotated[int | None, typer.Option(min=1, help="runs per task")] = None,
    workers: Annotated[int, typer.Option(
        min=1, help="worker processes on this machine, BLAS on one thread each, at most one "
        "per CPU (same table for any number); not with --dask")] = 1,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the per-run table (.csv or .parquet); if the study is "
        "interrupted or fails, the finished runs go to NAME.partial.csv")] = None,
    json_file: Annotated[Path | None, typer.Option(
        "--json", help="write the summary as JSON")] = None,
    no_progress: NoProgressOption = False, force: ForceOption = False,
    max_runs: Annotated[int, typer.Option(
        min=1, help="refuse more runs than this (each run holds its seed and table row; "
        "raise it for a larger study)")] = MAX_RUNS,
) -> None:
    """Simulate and estimate a scenario many times; compare the RMSE with the CRLB."""
    partial = None if output is None else output.with_name(f"{output.stem}.partial{output.suffix}")
    output, json_file, partial = check_outputs(
        [("-o", output, "table"), ("--json", json_file, "json"),
         ("-o (partial results)", partial, "table")], force)
    check_runs(runs, max_runs, "; raise it with --max-runs")
    scn = load_scenario_or_fail(scenario)
    with claim_outputs([output, json_file, partial]):  # a second run to them is refused now
        res = _study(scn, partial, estimator=estimator, runs=runs, rng=seed,
                     known_nuisance=known_nuisance, progress=not no_progress, dask=dask,
                     chunk=chunk, workers=workers)
        print_study_summary(res)
        _write_results(res, output, json_file, force)


def _study(scn: Any, partial: Path | None, **options: Any) -> Any:
    """Run the study; on any failure the finished runs go to ``partial`` first."""
    from ..montecarlo import keep_freed_memory, monte_carlo

    keep_freed_memory()  # tma's own process: the allocator keeps what the chunks free
    finished: list[Any] = []
    try:
        return monte_carlo(scn, on_chunk=finished.append, **options)
    except (ValueError, ImportError) as e:
        save_partial(finished, scn, partial)
        raise fail(str(e)) from None
    except OSError as e:  # the Dask scheduler cannot be reached
        save_partial(finished, scn, partial)
        raise fail(f"Dask scheduler {options.get('dask')}: {e}") from None
    except BaseException:  # interrupted, or an internal error: keep the finished runs
        save_partial(finished, scn, partial)
        raise


def _write_results(res: Any, output: Path | None, json_file: Path | None, force: bool) -> None:
    """Write the table and the JSON; a file that appeared meanwhile: the results go beside it."""
    from ..io import atomic_write, write_table

    def write_json(path: Path, force: bool) -> None:
        with atomic_write(path, force=force) as tmp:
            tmp.write_text(res.to_json() + "\n")

    def write_runs(path: Path, force: bool) -> None:
        write_table(path, res.table, force=force, what="the per-run table")

    lost = False
    for path, write in ((output, write_runs), (json_file, write_json)):
        if path is None:
            continue
        try:
            write(path, force)
            out.print(f"wrote {path}")
        except FileExistsError:  # written by another program while the study ran
            elsewhere = path.with_name(f"{path.stem}.{os.getpid()}{path.suffix}")
            write(elsewhere, False)
            err.print(f"error: {path} appeared while the study ran (another program wrote "
                      f"it); nothing was written over: the results are in {elsewhere}",
                      soft_wrap=True)
            lost = True
    if lost:
        raise typer.Exit(1)


def check_runs(runs: int | None, limit: int = MAX_RUNS, hint: str = "") -> None:
    """Refuse more ``--runs`` than ``limit`` (a billion runs' seeds alone fill the memory)."""
    if runs is not None and runs > limit:
        raise fail(f"--runs {runs:,}: more than the limit of {limit:,} runs{hint}")


def save_partial(finished: list[Any], scn: Any, partial: Path | None) -> None:
    """Write the finished runs of a study that did not end (``NAME.partial.csv``)."""
    if partial is None or not finished:
        return
    from ..io.tables import write_table
    from ..montecarlo import finished_runs_table

    table = finished_runs_table(finished, scn.motion.param_names)
    write_table(partial, table, force=True, what="the finished runs")
    err.print(f"saved the {len(table)} finished runs to {partial}")


def print_study_summary(res: Any) -> None:
    """Print the Monte Carlo summary table and the convergence and speed line."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    counts = ", ".join(f"{k} {v}" for k, v in res.status_counts.items())
    table = Table(title=f"{res.estimator} on {res.scenario}: {res.runs} runs (seed {res.seed}), "
                        f"nuisance {'known' if res.known_nuisance else 'unknown'}",
                  title_justify="left")
    from ..results.answers import parameter_display

    for col in ("parameter", "unit", "truth", "bias", "RMSE", "CRLB", "RMSE/CRLB", "95 % interval"):
        table.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    for r in res.summary_table():
        # The unit shown for the parameter (angles in degrees); bias, RMSE, CRLB scale with it.
        truth, one, unit = parameter_display(r["parameter"], r["truth"], 1.0)
        table.add_row(r["parameter"], unit or "-", f"{truth:.6g}", f"{r['bias'] * one:.4g}",
                      f"{r['rmse'] * one:.4g}", f"{r['crlb'] * one:.4g}", f"{r['ratio']:.3f}",
                      f"{r['ratio_low']:.3f} .. {r['ratio_high']:.3f}")
    print_wide(table)
    out.print(f"converged {res.convergence_rate:.1%} ({counts}); {res.wall_time:.1f} s, "
              f"{res.runs_per_second:.1f} runs/s ({res.executor})")


def reproduce(
    name: Annotated[str, typer.Argument(
        help="gu2007, doppler-lecture, hoerst2010, chen-sun, hurtado2008, chan-ho1994 or "
             "ho-xu2004")],
    runs: Annotated[int | None, typer.Option(
        help="Monte Carlo runs where the paper has them (0 to skip; default: the paper's "
             "number, gu2007 200, chen-sun 30, hurtado2008 100)")] = None,
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    as_json: JsonOption = False,
    plot: Annotated[Path | None, typer.Option(
        help="draw the paper's figure (PNG, PDF, SVG; hoerst2010, chen-sun: Fig. 2; "
             "chan-ho1994, ho-xu2004: MSE against noise; "
             "hurtado2008: Figs. 1-3)")] = None,
    force: Annotated[bool, typer.Option(help="overwrite existing --plot / --output files")
                     ] = False,
    particles: Annotated[int | None, typer.Option(
        help="hurtado2008: particles of the particle filter (default 2000)")] = None,
    steps: Annotated[int | None, typer.Option(
        help="hurtado2008: decisions per run (default 600, 300 s at 0.5 s)")] = None,
    radar: Annotated[str | None, typer.Option(
        help="hurtado2008: radar noise, derived (default), resolution or scenario")] = None,
    tracker: Annotated[str | None, typer.Option(
        help="hurtado2008: tracker, pf (default), ekf or ukf")] = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="hurtado2008: write the per-step table of every run "
        "(.parquet or .csv; finished chunks saved as they end)")] = None,
    dask: Annotated[str | None, typer.Option(
        help="hurtado2008: Dask scheduler address (tcp://host:8786); default: run here")
    ] = None,
    chunk: Annotated[int | None, typer.Option(help="hurtado2008: runs per task")] = None,
    no_progress: Annotated[bool, typer.Option(
        "--no-progress", help="no progress bar (it is drawn on standard error, also with "
        "--json)")] = False,
) -> None:
    """Reproduce a paper's tables and figures next to the paper's own numbers."""
    import importlib

    from ..montecarlo import keep_freed_memory
    from ..reproduce import REPRODUCTIONS

    if name not in REPRODUCTIONS:
        raise fail(f"no reproduction named {name!r}; available: {', '.join(REPRODUCTIONS)}")
    keep_freed_memory()  # tma's own process: the allocator keeps what the Monte Carlo frees
    if runs is not None and runs < 0:
        raise fail("--runs must be 0 or more")
    check_runs(runs)
    module = importlib.import_module(REPRODUCTIONS[name])
    extra = _extra_options(name, module, particles=particles, steps=steps, radar=radar,
                           tracker=tracker, dask=dask, chunk=chunk, output=output)
    if plot is not None and not hasattr(module, "plot"):
        drawn = [n for n, m in REPRODUCTIONS.items() if hasattr(importlib.import_module(m), "plot")]
        raise fail(f"--plot: reproduction {name!r} draws no figure (figures: {', '.join(drawn)})")
    check_particles(particles)
    plot, output = check_outputs([("--plot", plot, "picture"), ("--output", output, "table")],
                                 force)
    checkpoint = None if output is None else _checkpoint(output, force)
    if checkpoint is not None:
        extra["on_chunk"] = checkpoint
    try:
        with _telling_kept_chunks(checkpoint):
            rep = module.run(**({} if runs is None else {"runs": runs}), seed=seed,
                             progress=not no_progress, **extra)
    except (ValueError, ImportError) as e:  # ("steps must be ...": named by its flag)
        text = str(e)
        raise fail(f"--{text}" if text.split(" ")[0] in extra or text.startswith("runs ")
                   else text) from None
    if checkpoint is not None:
        checkpoint.finish(rep.study)
    if plot is not None:
        write_picture(plot, force, lambda tmp: module.plot(rep, tmp))
    if as_json:
        import json

        out.print_json(json.dumps(rep.as_dict(), default=float))
        return
    print_report(rep)
    for path in (plot, output):
        if path is not None:
            out.print(f"wrote {path}")


def _extra_options(name: str, module: Any, **given: Any) -> dict[str, Any]:
    """Return the options given that the reproduction takes; refuse others and bad values."""
    takes = getattr(module, "OPTIONS", ())
    extra: dict[str, Any] = {}
    for key, value in given.items():
        if value is None:
            continue
        if key not in takes and not (key == "output" and "on_chunk" in takes):
            raise fail(f"--{key}: reproduction {name!r} takes no such option")
        if key != "output":
            extra[key] = value
    for key, low in (("particles", 2), ("steps", 3), ("chunk", 1)):
        if key in extra and extra[key] < low:
            raise fail(f"--{key} must be {low} or more, got {extra[key]}")
    for key, names in (("radar", getattr(module, "RADARS", ())),
                       ("tracker", getattr(module, "TRACKERS", ()))):
        if key in extra and extra[key] not in names:
            raise fail(f"--{key} must be one of {', '.join(names)}, got {extra[key]!r}")
    return extra


@contextmanager
def _telling_kept_chunks(checkpoint: Any) -> Iterator[None]:
    """On a run that ends early (interrupted, terminated, failed), say where its chunks are."""
    try:
        yield
    except BaseException:
        if checkpoint is not None and checkpoint.saved:
            err.print(f"{len(checkpoint.saved)} finished chunk(s) of the per-step table kept in "
                      f"{checkpoint.parts}{os.sep}", markup=False, soft_wrap=True)
        raise


def _checkpoint(output: Path, force: bool) -> Any:
    """Return the per-step table writer, which saves each chunk as it is finished."""
    from ..io.tables import LoopCheckpoint

    try:
        return LoopCheckpoint(output, force)
    except ValueError as e:
        raise fail(f"--output: {e}") from None
    except FileExistsError as e:
        raise fail(f"{e.args[0].split(';')[0]}; use --force to overwrite it") from None


def print_report(rep: Any) -> None:
    """Print a reproduction's sections as tables (with their notes) and its figures."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    for section in rep.sections:
        table = Table(title=section.title, title_justify="left")
        header, rows = with_unit_column(section.header, section.rows)
        for col in header:
            table.add_column(col)
        for row in rows:
            table.add_row(*(f"{v:.10g}" if isinstance(v, float) else str(v) for v in row))
        out.print(table)
        if section.note:
            out.print(section.note)
    for key, value in (rep.figures.items() if rep.print_figures else ()):
        labels = getattr(rep, "labels", {}).get(key)
        if labels and isinstance(value, list) and len(value) == len(labels):
            text = ", ".join(f"{n} {plain(v)}" + (f" {u}" if u else "")
                             for (n, u), v in zip(labels, value, strict=True))
        else:
            text = plain(value)
        out.print(f"{key.replace('_', ' ')}: {text}")


def with_unit_column(header: list[str], rows: list[list[Any]]) -> tuple[list[str], list[list[Any]]]:
    """Add a ``unit`` column after a ``parameter`` column that has none (printed tables only)."""
    from ..results.answers import parameter_display

    if "parameter" not in header or any("unit" in h for h in header):
        return header, rows
    j = header.index("parameter") + 1
    return ([*header[:j], "unit", *header[j:]],
            [[*r[:j], parameter_display(str(r[j - 1]), 0.0, 0.0)[2] or "-", *r[j:]]
             for r in rows])


def plain(value: Any) -> str:
    """Return a figure as plain words: numbers to 6 digits, lists and mappings unbracketed."""
    if isinstance(value, bool) or value is None:
        return str(value).lower() if value is not None else "none"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, dict):
        return "; ".join(f"{k} = {plain(v)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        return ", ".join(plain(v) for v in value)
    return str(value)


def plan(
    scenario: Annotated[str, typer.Argument(
        help="TOML scenario file with a [planning] table, or a built-in name "
             "(plan-bearings-only)")],
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the per-step table (.csv or .parquet; finished chunks "
                               "saved as they end, in NAME.parts/)")] = None,
    plot: Annotated[Path | None, typer.Option(
        help="draw the paths, the range to the target and the error against the bound "
             "(PNG, PDF, SVG)")] = None,
    runs: Annotated[int | None, typer.Option(
        help="Monte Carlo runs (default: the table's runs)")] = None,
    seed: Annotated[int, typer.Option(help="random seed (same seed, same table)")] = 0,
    duration: Annotated[float | None, typer.Option(
        help="planned time (s), a whole number of decision intervals (default: the "
             "table's)")] = None,
    particles: Annotated[int | None, typer.Option(
        help="particles of the particle filter (default: the table's)")] = None,
    tracker: Annotated[str | None, typer.Option(
        help="pf, ekf or ukf (default: the table's)")] = None,
    planner: Annotated[str | None, typer.Option(
        help="auto (the mission planner for a sensor that measures no range, else the "
             "horizon planner), mission or horizon (default: the table's, auto)")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the summary as JSON")] = False,
    no_progress: NoProgressOption = False,
    force: ForceOption = False,
) -> None:
    """Steer the scenario's sensor by the predicted posterior CRB, beside its fixed pattern."""
    output, plot = check_outputs([("-o", output, "table"), ("--plot", plot, "picture")], force)
    if runs is not None and runs < 1:
        raise fail("--runs must be 1 or more")
    check_runs(runs)
    if particles is not None and particles < 2:
        raise fail("--particles must be 2 or more")
    check_particles(particles)
    from ..scenario.planning_table import PLANNERS, PLANNING_TRACKERS

    if tracker is not None and tracker not in PLANNING_TRACKERS:
        raise fail(f"--tracker {tracker!r}: expected one of {', '.join(PLANNING_TRACKERS)}")
    if planner is not None and planner not in PLANNERS:
        raise fail(f"--planner {planner!r}: expected one of {', '.join(PLANNERS)}")
    from ..planning.setup import load_planning
    from ..scenario.files import ScenarioFileError

    try:
        setup = load_planning(scenario)
        if particles is not None and (tracker or setup.tracker) != "pf":
            raise fail(f"--particles applies only to the particle filter (pf), not to the "
                       f"{tracker or setup.tracker} tracker "
                       f"{'given by --tracker' if tracker else 'of ' + str(scenario)}")
        for warning in start_warnings(setup):
            err.print(f"warning: {warning}")
        from ..montecarlo.planned import plan as run_plan

        checkpoint = None if output is None else _checkpoint(output, force)
        with _telling_kept_chunks(checkpoint):
            result = run_plan(setup, runs=runs, rng=seed, duration=duration,
                              particles=particles, tracker=tracker, planner=planner,
                              progress=not no_progress, on_chunk=checkpoint)
    except ScenarioFileError as e:
        raise fail(str(e)) from None
    except ValueError as e:
        message = str(e)
        for name in ("duration", "runs", "particles", "planner"):
            if message.startswith(f"{name} "):
                message = f"--{message}"
        raise fail(f"{scenario}: {message}") from None
    if as_json:
        import json

        typer.echo(json.dumps(json_summary(result, seed)))
    else:
        print_plan_summary(result, seed)
    for warning in result.warnings():
        err.print(f"warning: {warning}")
    write_outputs(result, output, plot, force, err if as_json else out, checkpoint)


def json_summary(result: Any, seed: int) -> dict[str, Any]:
    """Return what ``tma plan --json`` prints."""
    from ..montecarlo.planned import CASE, FIXED, describe

    has_fixed = FIXED in result.study.cases
    return {"scenario": result.setup.scenario.name, "seed": seed,
            "runs": result.study.runs(CASE), "steps": result.setup.steps,
            "planner": result.setup.kind, "planner_description": describe(result.setup),
            "planned": result.summary(CASE),
            "fixed": result.summary(FIXED) if has_fixed else None,
            "fixed_note": result.fixed_note, "comparison": result.comparison(),
            "warnings": result.warnings()}


def start_warnings(setup: Any) -> list[str]:
    """Say which constraints the steered sensor already breaks where it starts."""
    import numpy as np

    start = np.asarray(setup.start.position, dtype=float)[None, :]
    dim = setup.target.shape[0] // 2
    target = np.zeros(3)
    target[:dim] = setup.target[:dim]
    said = []
    for c in setup.planner.constraints:
        amount = float(c.check(start, target).amount[0])
        if amount > 1e-3:
            said.append(f"sensor {setup.sensor!r} starts in breach of its {c.name} constraint "
                        f"(by {amount:,.0f} m); the planner steers out of it, and the steps "
                        "until then count as violated")
    return said


def write_outputs(result: Any, output: Path | None, plot: Path | None, force: bool,
                  console: Any, checkpoint: Any = None) -> None:
    """Write the per-step table (its chunks' parts then removed) and the picture."""
    if output is not None:
        from ..io.tables import write_table

        if checkpoint is not None:
            checkpoint.finish(result.study, result.table())
        else:
            write_table(output, result.table(), force=force, what="the per-step table")
        console.print(f"wrote {output}")
    if plot is not None:
        from ..plot.tracks import plot_plan

        write_picture(plot, force, lambda tmp: plot_plan(result, tmp))
        console.print(f"wrote {plot}")


def print_plan_summary(result: Any, seed: int) -> None:
    """Print the planned path's figures beside the fixed pattern's."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    from ..montecarlo.planned import CASE, FIXED, describe

    s = result.setup
    cases = [c for c in (CASE, FIXED) if c in result.study.cases]
    summaries = {c: result.summary(c) for c in cases}
    tracker = s.tracker + (f" ({s.particles} particles)" if s.tracker == "pf" else "")
    table = Table(title=f"{s.scenario.name}: sensor {s.sensor!r} over {s.steps} decisions of "
                        f"{s.interval:g} s, {result.study.runs(CASE)} run(s) (seed {seed}), "
                        f"tracker {tracker}", title_justify="left")
    table.add_column("quantity")
    for c in cases:
        table.add_column("planned path" if c == CASE else "fixed pattern", justify="right")
    rows = [("final position RMSE (m)", "final_rmse_m", "{:.4g}"),
            ("posterior CRB at the truth (bound, m)", "final_pcrb_m", "{:.4g}"),
            ("RMSE / bound", "rmse_over_pcrb", "{:.3f}"),
            ("planning criterion along the path (m)", "final_criterion_m", "{:.4g}"),
            ("minimum range (m)", "min_range_m", "{:.6g}"),
            ("steps with a constraint violated", "violations", "{}"),
            ("largest violation (m)", "max_violation_m", "{:.4g}"),
            ("mean decision time (ms)", "mean_decision_ms", "{:.3g}")]
    for label, key, form in rows:
        ends = {c: interval(summaries[c][f"{key}_low"], summaries[c][f"{key}_high"])
                if key == "rmse_over_pcrb" else "" for c in cases}
        table.add_row(label, *(form.format(summaries[c][key]) + ends[c] for c in cases))
    out.print(table)
    p = s.planner
    constraints = ", ".join(c.name + (" (hard)" if c.hard else " (penalty)")
                            for c in p.constraints) or "none"
    out.print(f"planned path: {describe(s)}; constraints: {constraints}")
    out.print("bound: the posterior CRB at the true target along the flown paths (Gamma the "
              "mean over the runs, the tracker's prior and process noise); RMSE / bound with "
              "its 95 % Monte Carlo interval. Planning criterion: what the planner believed "
              "(Gamma over the tracker's cloud), not a bound.")
    found = result.comparison()
    if found is None:
        out.print(f"fixed pattern: none ({result.fixed_note})")
    else:
        out.print(f"planned / fixed final RMSE: {found['planned_over_fixed']:.3f}"
                  f"{interval(found['low'], found['high'])}, same seeds: {found['verdict']}")


def interval(low: float | None, high: float | None) -> str:
    """Return `` (95 %: low-high)``, or that the runs are too few for an interval."""
    from ..montecarlo.closed_loop import MIN_RUNS_INTERVAL

    if low is None or high is None:
        return f" (no interval under {MIN_RUNS_INTERVAL} runs)"
    return f" (95 %: {low:.2f}-{high:.2f})"
