"""``tma scenarios``, ``tma simulate``, ``tma show`` and ``tma demo``.

The built-in scenarios, their simulated measurement files, and a file's summary and picture.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from .common import (
    BearingSigmaOption,
    ContactOption,
    FilesArgument,
    FormatOption,
    FrequencySigmaOption,
    KindsOption,
    MappingOption,
    OriginOption,
    OwnshipOption,
    RangeSigmaOption,
    RangesOption,
    fail,
    load_scenario_or_fail,
    out,
    parse_origin,
    print_wide,
    reader_options,
    write_or_fail,
)
from .outputs import check_output, write_picture
from .reading import read_or_fail

if TYPE_CHECKING:
    from rich.table import Table


def summary_table(meas: Any, title: str) -> Table:
    """One row per sensor and kind: count, time span (s; UTC when known), values, median sigma."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    from ..results.context import clock_time

    clock = clock_time(meas, 0.0) is not None
    table = Table(title=title, title_justify="left")
    for col, justify in (("sensor", "left"), ("kind", "left"), ("n", "right"),
                         ("time (s)", "right"), *([("UTC", "left")] if clock else []),
                         ("min", "right"), ("max", "right"),
                         ("unit", "left"), ("median sigma", "right"), ("sigma unit", "left")):
        table.add_column(col, justify=justify, no_wrap=True)  # type: ignore[arg-type]
    for r in meas.summary_rows():
        unit = str(r["unit"])
        table.add_row(r["sensor"], r["kind"], str(r["count"]),
                      f"{r['t_first']:g} .. {r['t_last']:g}",
                      *([f"{clock_time(meas, float(r['t_first']))}"[:19] + " .. "
                         + f"{clock_time(meas, float(r['t_last']))}"[11:19]] if clock else []),
                      f"{r['value_min']:.10g}", f"{r['value_max']:.10g}", unit,
                      f"{r['sigma_median']:.4g}", sigma_unit(unit))
    return table


def sigma_unit(unit: str) -> str:
    """Return the unit of a standard deviation of values in ``unit``."""
    return "dB" if unit.startswith("dB") else unit


def truth_text(meta: dict[str, str]) -> str:
    """Return the file's true motion parameters as ``name = value unit`` text."""
    import json

    from ..results.answers import parameter_display

    try:
        truth = json.loads(meta["truth"])
    except (ValueError, TypeError):
        return str(meta["truth"])
    parts = []
    for name, value in truth.items():
        v, _, unit = parameter_display(name, float(value), 0.0)
        parts.append(f"{name} = {v:g}" + (f" {unit}" if unit else ""))
    return ", ".join(parts)


def describe_sensors(meas: Any) -> Table:
    """One row per sensor: first and last position (ENU, m) and mean speed (m/s)."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    table = Table(title="sensors", title_justify="left")
    for col in ("sensor", "start (E, N, U) m", "end (E, N, U) m", "mean speed (m/s)"):
        table.add_column(col)
    import numpy as np

    for s in meas.sensors:  # no copy of the states of a set's only sensor (large files)
        sel = meas.sensor_mask(s)
        whole = bool(sel.all())
        t = meas.time if whole else meas.time[sel]
        st = meas.sensor_state if whole else meas.sensor_state[sel]
        a, b = st[int(np.argmin(t))], st[t.shape[0] - 1 - int(np.argmax(t[::-1]))]
        v = st[:, 3:]
        speed = float(np.mean(np.sqrt(np.einsum("ij,ij->i", v, v))))
        table.add_row(s, f"{a[0]:.1f}, {a[1]:.1f}, {a[2]:.1f}",
                      f"{b[0]:.1f}, {b[1]:.1f}, {b[2]:.1f}", f"{speed:.2f}")
    return table


# `tma scenarios`: the docstring is its --help text, so no numpydoc sections (help= has them).
def scenarios() -> None:
    """List the built-in scenarios, one line each."""
    from rich.table import Table  # (loaded where a table is made: not for --help)

    from ..scenario.catalog import builtin_scenarios

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
    written = check_output(output, "-o", force, "measurements")
    assert written is not None  # (-o is required)
    output = written
    scn = load_scenario_or_fail(scenario)
    meas = simulate_or_fail(scn, seed, not no_noise)
    write_or_fail(meas, output, force)
    out.print(f"wrote {len(meas)} measurements of {scn.name} to {output}"
              + (f" (seed {seed})" if seed is not None else "")
              + (" without noise" if no_noise else ""), highlight=False)


def simulate_or_fail(scn: Any, seed: int | None, noise: bool) -> Any:
    """Simulate a scenario, errors of its values (``ValueError``) as ``error: ...``."""
    from numpy.linalg import LinAlgError

    try:
        return scn.simulate(rng=seed, noise=noise)
    except LinAlgError:  # a numerical failure, not bad input: the guard reports it
        raise
    except ValueError as e:
        raise fail(f"scenario {scn.name}: {e}") from None


# `tma show`: the docstring is its --help text, so no numpydoc sections (help= has them).
def show(
    files: FilesArgument,
    plot: Annotated[Path | None, typer.Option(help="write a picture (PNG, PDF, SVG)")] = None,
    origin: OriginOption = None,
    format: FormatOption = None,
    ownship: OwnshipOption = None,
    contact: ContactOption = None,
    mapping: MappingOption = None,
    bearing_sigma: BearingSigmaOption = None,
    range_sigma: RangeSigmaOption = None,
    frequency_sigma: FrequencySigmaOption = None,
    kinds: KindsOption = None,
    ranges: RangesOption = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing picture")] = False,
) -> None:
    """Summarise a measurement file per sensor and kind, and optionally draw it."""
    plot = check_output(plot, "--plot", force, "picture", files)
    meas = read_or_fail(files, parse_origin(origin),
                        **reader_options(format, ownship, contact, mapping, bearing_sigma,
                                         range_sigma, frequency_sigma, kinds=kinds,
                                         ranges=ranges))
    meta = meas.metadata
    title = f"{' + '.join(map(str, files))}: {len(meas)} measurements"
    if "scenario" in meta:
        title += f" of scenario {meta['scenario']}"
        if "seed" in meta:
            title += f" (seed {meta['seed']})"
    print_wide(summary_table(meas, title))
    out.print(describe_sensors(meas))
    if "truth" in meta:
        out.print(f"truth ({meta.get('motion', '?')}): {truth_text(meta)}", highlight=False)
    if "time_origin" in meta:  # a real log: its clock time and frame
        from .importing import print_import

        print_import(meas, None)
    from ..results import measurement_warnings
    from .answers_out import print_warnings

    print_warnings(measurement_warnings(meas))
    if plot is not None:
        from ..plot.tracks import plot_measurements

        write_picture(plot, force, lambda tmp: plot_measurements(meas, tmp, title=title))
        out.print(f"wrote {plot}", highlight=False)


#: The file that marks a folder as written by ``tma demo`` (so that a re-run may replace it).
DEMO_MARK = ".tma-demo"


# `tma demo`: the docstring is its --help text, so no numpydoc sections (help= has them).
def demo(
    out_dir: Annotated[Path, typer.Option(
        help="the demo's own folder, replaced on every run")] = Path("tma-demo"),
    seed: Annotated[int, typer.Option(help="random seed")] = 1,
    force: Annotated[bool, typer.Option(
        help="replace the folder even if tma demo did not make it")] = False,
) -> None:
    """Simulate the gu2007 scenario, summarise it and draw it, in a folder of its own.

    Re-running replaces the folder that an earlier tma demo made; a folder that tma demo did
    not make is left alone unless --force is given.
    """
    prepare_demo_folder(out_dir, force)
    csv = out_dir / "gu2007.csv"
    png = out_dir / "gu2007.png"
    scn = load_scenario_or_fail("gu2007")
    out.print(scn.summary(), highlight=False)
    meas = scn.simulate(rng=seed)
    write_or_fail(meas, csv, force=True)
    out.print(f"wrote {csv}", highlight=False)
    show([csv], plot=png, origin=None, force=True)


def prepare_demo_folder(folder: Path, force: bool) -> None:
    """Make ``folder`` an empty demo folder, replacing an earlier demo's."""
    import shutil

    if folder.exists() and not folder.is_dir():
        raise fail(f"--out-dir {folder}: a file of that name exists")
    if folder.is_dir() and any(folder.iterdir()):
        if not (folder / DEMO_MARK).exists() and not force:
            raise fail(f"--out-dir {folder}: the folder holds files that tma demo did not "
                       "write; choose another folder or use --force to replace it")
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / DEMO_MARK).write_text("written by tma demo; replaced when it runs again\n")
