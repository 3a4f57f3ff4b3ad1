"""``tma reproduce``: a paper's tables and figures next to the paper's own numbers."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from .common import JsonOption, check_outputs, check_particles, fail, out, write_picture


# `tma reproduce`: the docstring is its --help text, so no numpydoc sections (help= has them).
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
    module = importlib.import_module(REPRODUCTIONS[name])
    extra = _extra_options(name, module, particles=particles, steps=steps, radar=radar,
                           tracker=tracker, dask=dask, chunk=chunk, output=output)
    if plot is not None:
        if not hasattr(module, "plot"):
            drawn = [n for n, m in REPRODUCTIONS.items()
                     if hasattr(importlib.import_module(m), "plot")]
            raise fail(f"--plot: reproduction {name!r} draws no figure (figures: "
                       f"{', '.join(drawn)})")
    check_particles(particles)
    plot, output = check_outputs([("--plot", plot, "picture"), ("--output", output, "table")],
                                 force)
    checkpoint = None
    if output is not None:
        checkpoint = _checkpoint(output, force)
        extra["on_chunk"] = checkpoint
    try:
        rep = module.run(**({} if runs is None else {"runs": runs}), seed=seed,
                         progress=not no_progress, **extra)
    except (ValueError, ImportError) as e:
        raise fail(str(e)) from None
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
            out.print(f"wrote {path}", highlight=False)


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


def _checkpoint(output: Path, force: bool) -> Any:
    """Return the per-step table writer, which saves each chunk as it is finished."""
    from ..io.loop_files import LoopCheckpoint

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
            out.print(section.note, highlight=False)
    for key, value in (rep.figures.items() if rep.print_figures else ()):
        labels = getattr(rep, "labels", {}).get(key)
        if labels and isinstance(value, list) and len(value) == len(labels):
            text = ", ".join(f"{n} {plain(v)}" + (f" {u}" if u else "")
                             for (n, u), v in zip(labels, value, strict=True))
        else:
            text = plain(value)
        out.print(f"{key.replace('_', ' ')}: {text}", highlight=False)


def with_unit_column(header: list[str], rows: list[list[Any]]
                     ) -> tuple[list[str], list[list[Any]]]:
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
