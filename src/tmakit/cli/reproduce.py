"""``tma reproduce``: a paper's tables and figures next to the paper's own numbers."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from .common import JsonOption, fail, out, refuse_existing


# `tma reproduce`: the docstring is its --help text, so no numpydoc sections (help= has them).
def reproduce(
    name: Annotated[str, typer.Argument(
        help="gu2007, doppler-lecture, hoerst2010 or chen-sun")],
    runs: Annotated[int | None, typer.Option(
        help="Monte Carlo runs where the paper has them (0 to skip; default: the paper's "
             "number, gu2007 200, chen-sun 30)")] = None,
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    as_json: JsonOption = False,
    plot: Annotated[Path | None, typer.Option(
        help="draw the paper's figure (PNG, PDF, SVG; hoerst2010, chen-sun: Fig. 2)")
    ] = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing --plot file")] = False,
) -> None:
    """Reproduce a paper's tables and figures next to the paper's own numbers."""
    import importlib

    from ..reproduce import REPRODUCTIONS

    if name not in REPRODUCTIONS:
        raise fail(f"no reproduction named {name!r}; available: {', '.join(REPRODUCTIONS)}")
    if runs is not None and runs < 0:
        raise fail("--runs must be 0 or more")
    module = importlib.import_module(REPRODUCTIONS[name])
    if plot is not None:
        if not hasattr(module, "plot"):
            drawn = [n for n, m in REPRODUCTIONS.items()
                     if hasattr(importlib.import_module(m), "plot")]
            raise fail(f"--plot: reproduction {name!r} draws no figure (figures: "
                       f"{', '.join(drawn)})")
        refuse_existing(plot, force)
    rep = module.run(**({} if runs is None else {"runs": runs}), seed=seed,
                     progress=not as_json)
    if plot is not None:
        module.plot(rep, plot)
    if as_json:
        import json

        out.print_json(json.dumps(rep.as_dict(), default=float))
        return
    print_report(rep)
    if plot is not None:
        out.print(f"wrote {plot}", highlight=False)


def print_report(rep: Any) -> None:
    """Print a reproduction's sections as tables (with their notes) and its figures.

    Parameters
    ----------
    rep : tmakit.reproduce.common.Reproduction
        The reproduction's report.
    """
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
