"""``tma montecarlo``: simulate and estimate a scenario many times; RMSE against the CRLB."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any

import typer

from .common import (
    ForceOption,
    NoProgressOption,
    check_outputs,
    claim_outputs,
    err,
    fail,
    load_scenario_or_fail,
    out,
    print_wide,
)

#: Default limit of ``--runs`` (raise with ``--max-runs``).
MAX_RUNS = 1_000_000


# `tma montecarlo`: the docstring is its --help text, so no numpydoc sections (help= has them).
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
    partial = None if output is None else output.with_name(
        f"{output.stem}.partial{output.suffix}")
    output, json_file, partial = check_outputs(
        [("-o", output, "table"), ("--json", json_file, "json"),
         ("-o (partial results)", partial, "table")], force)
    if runs > max_runs:
        raise fail(f"--runs {runs:,}: more than the limit of {max_runs:,} runs; raise it with "
                   "--max-runs")
    scn = load_scenario_or_fail(scenario)
    with claim_outputs([output, json_file, partial]):  # a second run to them is refused now
        res = _study(scn, partial, estimator=estimator, runs=runs, rng=seed,
                     known_nuisance=known_nuisance, progress=not no_progress, dask=dask,
                     chunk=chunk, workers=workers)
        print_summary(res)
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


def _write_results(res: Any, output: Path | None, json_file: Path | None,
                   force: bool) -> None:
    """Write the table and the JSON; a file that appeared meanwhile: the results go beside it."""
    from ..io import atomic_write
    from ..io.study_files import write_study_table

    def write_json(path: Path, force: bool) -> None:
        with atomic_write(path, force=force) as tmp:
            tmp.write_text(res.to_json() + "\n")

    def write_table(path: Path, force: bool) -> None:
        write_study_table(res, path, force=force)

    lost = False
    for path, write in ((output, write_table), (json_file, write_json)):
        if path is None:
            continue
        try:
            write(path, force)
            out.print(f"wrote {path}", highlight=False)
        except FileExistsError:  # written by another program while the study ran
            elsewhere = path.with_name(f"{path.stem}.{os.getpid()}{path.suffix}")
            write(elsewhere, False)
            err.print(f"error: {path} appeared while the study ran (another program wrote "
                      f"it); nothing was written over: the results are in {elsewhere}",
                      highlight=False, soft_wrap=True)
            lost = True
    if lost:
        raise typer.Exit(1)


def save_partial(finished: list[Any], scn: Any, partial: Path | None) -> None:
    """Write the finished runs of a study that did not end (``NAME.partial.csv``)."""
    if partial is None or not finished:
        return
    from ..io.tables import write_table
    from ..montecarlo import finished_runs_table

    table = finished_runs_table(finished, scn.motion.param_names)
    write_table(partial, table, force=True, what="the finished runs")
    err.print(f"saved the {len(table)} finished runs to {partial}", highlight=False)


def print_summary(res: Any) -> None:
    """Print the Monte Carlo summary table and the convergence and speed line."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    counts = ", ".join(f"{k} {v}" for k, v in res.status_counts.items())
    table = Table(title=f"{res.estimator} on {res.scenario}: {res.runs} runs (seed {res.seed}), "
                        f"nuisance {'known' if res.known_nuisance else 'unknown'}",
                  title_justify="left")
    from ..results.answers import parameter_display

    for col in ("parameter", "unit", "truth", "bias", "RMSE", "CRLB", "RMSE/CRLB",
                "95 % interval"):
        table.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    for r in res.summary_table():
        # The unit shown for the parameter (angles in degrees); bias, RMSE, CRLB scale with it.
        truth, one, unit = parameter_display(r["parameter"], r["truth"], 1.0)
        table.add_row(r["parameter"], unit or "-", f"{truth:.6g}", f"{r['bias'] * one:.4g}",
                      f"{r['rmse'] * one:.4g}", f"{r['crlb'] * one:.4g}", f"{r['ratio']:.3f}",
                      f"{r['ratio_low']:.3f} .. {r['ratio_high']:.3f}")
    print_wide(table)
    out.print(f"converged {res.convergence_rate:.1%} ({counts}); {res.wall_time:.1f} s, "
              f"{res.runs_per_second:.1f} runs/s ({res.executor})", highlight=False)
