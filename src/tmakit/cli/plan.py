"""``tma plan``: steer a scenario's sensor by the predicted PCRB in the closed loop, many times.

The scenario's ``[planning]`` table (``docs/planning.md``) names the steered sensor, its limits,
actions, criterion, constraints and tracker; the command writes the per-step table (flown path,
truth, estimates, bound) and prints the summary.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape

from .common import ForceOption, err, fail, out
from .outputs import check_outputs as _check_paths


def check_outputs(paths: list[tuple[str, Path | None]], force: bool) -> list[Path | None]:
    """Refuse bad output paths before running (:func:`tmakit.cli.outputs.check_outputs`).

    Parameters
    ----------
    paths : list of (str, Path or None)
        ``("-o", path)`` and ``("--plot", path)``.
    force : bool
        ``--force``.

    Returns
    -------
    list of Path or None
        The exact files that will be written.

    Raises
    ------
    typer.Exit
        Status 2 for the first bad path.
    """
    return _check_paths([(option, path, "picture" if option == "--plot" else "table")
                         for option, path in paths], force)


# `tma plan`: the docstring is its --help text, so no numpydoc sections (help= has them).
def plan(
    scenario: Annotated[str, typer.Argument(
        help="TOML scenario file with a [planning] table, or a built-in name "
             "(plan-bearings-only)")],
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the per-step table (.csv or .parquet)")] = None,
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
    as_json: Annotated[bool, typer.Option("--json", help="print the summary as JSON")] = False,
    no_progress: Annotated[bool, typer.Option("--no-progress", help="no progress bar")] = False,
    force: ForceOption = False,
) -> None:
    """Steer the scenario's sensor by the predicted posterior CRB, in the closed loop."""
    output, plot = check_outputs([("-o", output), ("--plot", plot)], force)
    if runs is not None and runs < 1:
        raise fail("--runs must be 1 or more")
    if particles is not None and particles < 2:
        raise fail("--particles must be 2 or more")
    from .outputs import check_particles

    check_particles(particles)
    from ..scenario_planning import PLANNING_TRACKERS

    if tracker is not None and tracker not in PLANNING_TRACKERS:
        raise fail(f"--tracker {tracker!r}: expected one of {', '.join(PLANNING_TRACKERS)}")
    from ..scenario_file import ScenarioFileError, load_planning

    try:
        setup = load_planning(scenario)
        if particles is not None and (tracker or setup.tracker) != "pf":
            raise fail(f"--particles applies only to the particle filter (pf), not to the "
                       f"{tracker or setup.tracker} tracker "
                       f"{'given by --tracker' if tracker else 'of ' + str(scenario)}")
        for warning in start_warnings(setup):
            err.print(f"warning: {escape(warning)}", highlight=False)
        from ..montecarlo.planned import plan as run_plan

        result = run_plan(setup, runs=runs, rng=seed, duration=duration,
                          particles=particles, tracker=tracker,
                          progress=not (as_json or no_progress))
    except ScenarioFileError as e:
        raise fail(escape(str(e))) from None
    except ValueError as e:
        message = str(e)
        for name in ("duration", "runs", "particles"):
            if message.startswith(f"{name} "):
                message = f"--{message}"
        raise fail(escape(f"{scenario}: {message}")) from None
    summary = result.summary()
    if as_json:
        import json

        typer.echo(json.dumps({"scenario": setup.scenario.name, "seed": seed, **summary}))
    else:
        print_summary(result, summary, seed)
    write_outputs(result, output, plot, force, err if as_json else out)


def start_warnings(setup: Any) -> list[str]:
    """Say which constraints the steered sensor already breaks where it starts.

    Parameters
    ----------
    setup : tmakit.scenario_planning.PlanningSetup
        The loaded planning table.

    Returns
    -------
    list of str
        One sentence per constraint broken at the start (by the true target's position for
        the range limits): the planner steers out of it, and the steps until then are counted
        as violated.
    """
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
                  console: Any) -> None:
    """Write the per-step table and the picture, saying so on ``console``.

    Parameters
    ----------
    result : tmakit.montecarlo.planned.PlanRun
        The runs.
    output, plot : Path or None
        ``-o`` and ``--plot``.
    force : bool
        Overwrite existing files.
    console : rich.console.Console
        Where the "wrote" lines go (standard error with --json).
    """
    if output is not None:
        from ..io.tables import write_table

        write_table(output, result.table(), force=force, what="the per-step table")
        console.print(f"wrote {output}", highlight=False)
    if plot is not None:
        from ..plot import plot_plan
        from .outputs import write_picture

        write_picture(plot, force, lambda tmp: plot_plan(result, tmp))
        console.print(f"wrote {plot}", highlight=False)


def print_summary(result: Any, summary: dict[str, Any], seed: int) -> None:
    """Print the summary table of the planned runs.

    Parameters
    ----------
    result : tmakit.montecarlo.planned.PlanRun
        The runs.
    summary : dict
        ``result.summary()``.
    seed : int
        The seed, for the title.
    """
    from rich.table import Table  # (loaded where a table is made: not for --help)

    s = result.setup
    p = s.planner
    table = Table(title=f"{s.scenario.name}: sensor {s.sensor!r} planned over "
                        f"{s.steps} decisions of {s.interval:g} s, {summary['runs']} run(s) "
                        f"(seed {seed}), tracker {s.tracker}",
                  title_justify="left")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    rows = [("final position RMSE (m)", f"{summary['final_rmse_m']:.4g}"),
            ("final bound along the flown path (m)", f"{summary['final_bound_m']:.4g}"),
            ("RMSE / bound", f"{summary['final_rmse_m'] / summary['final_bound_m']:.3f}"),
            ("minimum range (m)", f"{summary['min_range_m']:.6g}"),
            ("steps with a constraint violated", str(summary["violations"])),
            ("largest violation (m)", f"{summary['max_violation_m']:.4g}"),
            ("mean decision time (ms)", f"{summary['mean_decision_ms']:.3g}")]
    for row in rows:
        table.add_row(*row)
    out.print(table)
    constraints = ", ".join(c.name + (" (hard)" if c.hard else " (penalty)")
                            for c in p.constraints) or "none"
    out.print(f"criterion {p.criterion.name}, gamma {p.gamma}, horizon {p.horizon}, "
              f"{len(p.actions)} actions; constraints: {constraints}", highlight=False)
