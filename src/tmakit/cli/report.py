"""``tma report``: the interactive solution page of a measurement file (``tma estimate --html``).

The same command as ``tma estimate``, options and all, with the page as its required output
``-o``: one implementation, two doors.
"""

from __future__ import annotations

import inspect
import typing
from pathlib import Path
from typing import Annotated, Any

import typer

from .estimate import estimate


# `tma report`: the docstring is its --help text, so no numpydoc sections (help= has them).
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
    hints = typing.get_type_hints(estimate, include_extras=True)  # (the annotations resolved)
    params = [page if p.name == "html" else p.replace(annotation=hints[p.name])
              for p in inspect.signature(estimate).parameters.values()]
    # a parameter without default after those with one: move the page after the files
    params.remove(page)
    params.insert(1, page)
    return inspect.Signature(params, return_annotation=None)


report.__signature__ = _report_signature()  # type: ignore[attr-defined]
