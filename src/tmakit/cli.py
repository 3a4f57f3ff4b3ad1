"""The ``tma`` command.

    tma scenarios                                  list the built-in scenarios
    tma simulate SCENARIO [--seed N] [--no-noise] -o FILE [--force]
    tma show FILE [--plot out.png] [--origin LAT,LON,ALT] [--force]
    tma demo [--out-dir DIR] [--seed N] [--force]

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
    from .files import MeasurementFileError, read_measurements

    if not path.exists():
        raise _fail(f"{path}: no such file")
    try:
        return read_measurements(path, origin=origin)
    except (MeasurementFileError, ValueError) as e:
        raise _fail(str(e)) from None


def _write(meas, path: Path, force: bool) -> None:
    from .files import write_measurements

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
