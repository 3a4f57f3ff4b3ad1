"""The solution's page and exports (``tma estimate --html``, ``--export``; ``tma report``).

Each output is checked before any work (:func:`check_solution_outputs`) and written atomically
after the fit (:func:`write_solution_outputs`): the page always (it shows why there is no
solution when there is none), the exports only for an answer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import typer

from .common import fail

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
                           inputs: list[Path], every: float = 60.0,
                           range_bearing: bool = False, name: str | None = None,
                           taken: list[Path | None] | None = None,
                           options: dict[str, Any] | None = None,
                           files: list[Path] | None = None) -> SolutionOutputs:
    """Check ``--html`` and ``--export`` before any work."""
    from .outputs import check_outputs

    if not every > 0:
        raise fail(f"--export-every {every:g}: expected seconds > 0")
    if range_bearing and not any(Path(p).suffix.lower() == ".rep" for p in exports or []):
        raise fail("--export-rb adds ;TMA_RB: lines to a .rep export: give --export FILE.rep")
    checked = check_outputs([("--html", html, "page"),
                             *(("--export", p, "solution") for p in exports or [])],
                            force, inputs)
    plots = {Path(p).resolve() for p in taken or [] if p is not None}
    for option, p in zip(["--html", *["--export"] * len(exports or [])], checked, strict=True):
        if p is not None and p.resolve() in plots:
            raise fail(f"{option} {p}: the same file as --plot")
    return SolutionOutputs(html=checked[0], exports=[p for p in checked[1:] if p is not None],
                           every=every, range_bearing=range_bearing, name=name, force=force,
                           title=" + ".join(map(str, files or inputs)),
                           options=dict(options or {}))


def check_page(html: Path | None, force: bool, inputs: list[Path], plot: Path | None
               ) -> Path | None:
    """Check ``--html`` alone (``tma track``): :func:`check_solution_outputs` without exports."""
    return check_solution_outputs(html, None, force, inputs, taken=[plot]).html


def write_solution_outputs(meas: Any, result: Any, outputs: SolutionOutputs, answers: bool,
                           say: Any) -> None:
    """Write the page and the exports; say what was written (or why an export was not)."""
    from .outputs import write_picture

    if outputs.html is not None:
        from ..plot.page import write_solution_page

        title = f"{outputs.title}: {result.method} estimate, {result.motion.name}"
        write_picture(outputs.html, outputs.force, lambda tmp: write_solution_page(
            meas, result, tmp, options=outputs.options, title=title))
        say.print(f"wrote {outputs.html} (open it in a browser: no network needed)",
                  highlight=False, soft_wrap=True)
    if not outputs.exports:
        return
    if not answers:
        say.print(f"not written: {', '.join(map(str, outputs.exports))}: the estimate is no "
                  "answer", highlight=False)
        return
    from ..io.solution_files import write_solution

    for path in outputs.exports:
        try:
            write_solution(path, meas, result, every=outputs.every,
                           range_bearing=outputs.range_bearing, name=outputs.name,
                           force=outputs.force)
        except FileExistsError:
            raise fail(f"{path} already exists; use --force to overwrite it") from None
        except ValueError as e:
            raise fail(f"--export {e}") from None
        say.print(f"wrote {path}", highlight=False, soft_wrap=True)
