"""``tma scenarios``, ``tma simulate``, ``tma show`` and ``tma demo``.

The built-in scenarios, their simulated measurement files, and a file's summary and picture.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from .common import (
    OriginOption,
    fail,
    load_scenario_or_fail,
    out,
    parse_origin,
    read_or_fail,
    write_or_fail,
)
from .outputs import check_output, write_picture


def summary_table(meas: Any, title: str) -> Table:
    """One row per sensor and kind: count, time span (s), value range, median sigma, unit.

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements.
    title : str
        The table's title.

    Returns
    -------
    rich.table.Table
        The table.
    """
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


def describe_sensors(meas: Any) -> Table:
    """One row per sensor: first and last position (ENU, m) and mean speed (m/s).

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements.

    Returns
    -------
    rich.table.Table
        The table.
    """
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


# `tma scenarios`: the docstring is its --help text, so no numpydoc sections (help= has them).
def scenarios() -> None:
    """List the built-in scenarios, one line each."""
    from ..scenario_catalog import builtin_scenarios

    table = Table(show_header=True, box=None)
    table.add_column("name", style="bold")
    table.add_column("what it is")
    for name, title in builtin_scenarios():
        table.add_row(name, title)
    out.print(table)


# `tma simulate`: the docstring is its --help text, so no numpydoc sections (help= has them).
def simulate(
    scenario: Annotated[str, typer.Argument(help="built-in scenario name or TOML file")],
    output: Annotated[Path, typer.Option("-o", "--output",
                                         help="measurement file to write (.csv or .parquet)")],
    seed: Annotated[int | None, typer.Option(
        min=0, help="random seed, 0 or more (same seed, same data)")] = None,
    no_noise: Annotated[bool, typer.Option("--no-noise", help="noise-free values")] = False,
    force: Annotated[bool, typer.Option(help="overwrite an existing output file")] = False,
) -> None:
    """Simulate a scenario's measurements and write them to a file."""
    output = check_output(output, "-o", force, "measurements")
    scn = load_scenario_or_fail(scenario)
    meas = simulate_or_fail(scn, seed, not no_noise)
    write_or_fail(meas, output, force)
    out.print(f"wrote {len(meas)} measurements of {scn.name} to {output}"
              + (f" (seed {seed})" if seed is not None else "")
              + (" without noise" if no_noise else ""), highlight=False)


def simulate_or_fail(scn: Any, seed: int | None, noise: bool) -> Any:
    """Simulate a scenario, errors of its values (``ValueError``) as ``error: ...``.

    Parameters
    ----------
    scn : tmakit.scenario.Scenario
        The scenario.
    seed : int or None
        Random seed.
    noise : bool
        Add the measurement noise.

    Returns
    -------
    tmakit.data.MeasurementSet
        The simulated measurements.

    Raises
    ------
    typer.Exit
        Status 2 when the scenario cannot be simulated (the message says why).
    """
    from numpy.linalg import LinAlgError

    try:
        return scn.simulate(rng=seed, noise=noise)
    except LinAlgError:  # a numerical failure, not bad input: the guard reports it
        raise
    except ValueError as e:
        raise fail(f"scenario {scn.name}: {e}") from None


# `tma show`: the docstring is its --help text, so no numpydoc sections (help= has them).
def show(
    file: Annotated[Path, typer.Argument(help="measurement file (.csv or .parquet)")],
    plot: Annotated[Path | None, typer.Option(help="write a picture (PNG, PDF, SVG)")] = None,
    origin: OriginOption = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing picture")] = False,
) -> None:
    """Summarise a measurement file per sensor and kind, and optionally draw it."""
    plot = check_output(plot, "--plot", force, "picture")
    meas = read_or_fail(file, parse_origin(origin))
    meta = meas.metadata
    title = f"{file}: {len(meas)} measurements"
    if "scenario" in meta:
        title += f" of scenario {meta['scenario']}"
        if "seed" in meta:
            title += f" (seed {meta['seed']})"
    out.print(summary_table(meas, title))
    out.print(describe_sensors(meas))
    if "truth" in meta:
        out.print(f"truth ({meta.get('motion', '?')}): {meta['truth']}", highlight=False)
    if plot is not None:
        from ..plot import plot_measurements

        write_picture(plot, force, lambda tmp: plot_measurements(meas, tmp, title=title))
        out.print(f"wrote {plot}", highlight=False)


# `tma demo`: the docstring is its --help text, so no numpydoc sections (help= has them).
def demo(
    out_dir: Annotated[Path, typer.Option(help="folder for the demo's files")] = Path(
        "tma-demo"),
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    force: Annotated[bool, typer.Option(help="overwrite earlier demo files")] = False,
) -> None:
    """Simulate the gu2007 scenario, summarise it and draw it."""
    csv = out_dir / "gu2007.csv"
    png = out_dir / "gu2007.png"
    if out_dir.exists() and not out_dir.is_dir():
        raise fail(f"--out-dir {out_dir}: is a file, not a folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    check_output(csv, "--out-dir", force, "measurements")
    check_output(png, "--out-dir", force, "picture")
    scn = load_scenario_or_fail("gu2007")
    out.print(scn.summary(), highlight=False)
    meas = scn.simulate(rng=seed)
    write_or_fail(meas, csv, force)
    out.print(f"wrote {csv}", highlight=False)
    show(csv, plot=png, origin=None, force=force)
