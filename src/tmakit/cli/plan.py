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

from .common import (
    ForceOption,
    NoProgressOption,
    check_outputs,
    check_particles,
    err,
    fail,
    out,
    write_picture,
)


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
            err.print(f"warning: {escape(warning)}", highlight=False)
        from ..montecarlo.planned import plan as run_plan

        result = run_plan(setup, runs=runs, rng=seed, duration=duration,
                          particles=particles, tracker=tracker, planner=planner,
                          progress=not no_progress)
    except ScenarioFileError as e:
        raise fail(escape(str(e))) from None
    except ValueError as e:
        message = str(e)
        for name in ("duration", "runs", "particles", "planner"):
            if message.startswith(f"{name} "):
                message = f"--{message}"
        raise fail(escape(f"{scenario}: {message}")) from None
    if as_json:
        import json

        typer.echo(json.dumps(json_summary(result, seed)))
    else:
        print_summary(result, seed)
    for warning in result.warnings():
        err.print(f"warning: {escape(warning)}", highlight=False)
    write_outputs(result, output, plot, force, err if as_json else out)


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
                  console: Any) -> None:
    """Write the per-step table and the picture, saying so on ``console``."""
    if output is not None:
        from ..io.tables import write_table

        write_table(output, result.table(), force=force, what="the per-step table")
        console.print(f"wrote {output}", highlight=False)
    if plot is not None:
        from ..plot.tracks import plot_plan

        write_picture(plot, force, lambda tmp: plot_plan(result, tmp))
        console.print(f"wrote {plot}", highlight=False)


def print_summary(result: Any, seed: int) -> None:
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
        cells = []
        for c in cases:
            v = summaries[c][key]
            cell = form.format(v)
            if key == "rmse_over_pcrb":
                cell += interval(summaries[c]["rmse_over_pcrb_low"],
                                 summaries[c]["rmse_over_pcrb_high"])
            cells.append(cell)
        table.add_row(label, *cells)
    out.print(table)
    p = s.planner
    constraints = ", ".join(c.name + (" (hard)" if c.hard else " (penalty)")
                            for c in p.constraints) or "none"
    out.print(f"planned path: {describe(s)}; constraints: {constraints}", highlight=False)
    out.print("bound: the posterior CRB at the true target along the flown paths (Gamma the "
              "mean over the runs, the tracker's prior and process noise); RMSE / bound with "
              "its 95 % Monte Carlo interval. Planning criterion: what the planner believed "
              "(Gamma over the tracker's cloud), not a bound.", highlight=False)
    found = result.comparison()
    if found is None:
        out.print(f"fixed pattern: none ({result.fixed_note})", highlight=False)
    else:
        out.print(f"planned / fixed final RMSE: {found['planned_over_fixed']:.3f}"
                  f"{interval(found['low'], found['high'])}, same seeds: {found['verdict']}",
                  highlight=False)


def interval(low: float | None, high: float | None) -> str:
    """Return `` (95 %: low-high)``, or that the runs are too few for an interval."""
    from ..montecarlo.closed_loop import MIN_RUNS_INTERVAL

    if low is None or high is None:
        return f" (no interval under {MIN_RUNS_INTERVAL} runs)"
    return f" (95 %: {low:.2f}-{high:.2f})"
