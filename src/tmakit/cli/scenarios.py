"""File commands: ``tma scenarios``, ``simulate``, ``show``, ``demo``, ``import``, ``examples``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from .common import (
    BearingSigmaOption,
    ContactOption,
    FilesArgument,
    ForceOption,
    FrequencySigmaOption,
    KindsOption,
    MappingOption,
    OriginOption,
    OwnshipOption,
    RangeSigmaOption,
    RangesOption,
    check_dim,
    check_output,
    check_ranges,
    fail,
    load_scenario_or_fail,
    out,
    parse_origin,
    print_wide,
    read_or_fail,
    reads_logs,
    refuse_existing,
    write_or_fail,
    write_picture,
)

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
                      f"{r['sigma_median']:.4g}", "dB" if unit.startswith("dB") else unit)
    return table


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
              + (" without noise" if no_noise else ""))


def simulate_or_fail(scn: Any, seed: int | None, noise: bool) -> Any:
    """Simulate a scenario, errors of its values (``ValueError``) as ``error: ...``."""
    from numpy.linalg import LinAlgError

    try:
        return scn.simulate(rng=seed, noise=noise)
    except LinAlgError:  # a numerical failure, not bad input: the guard reports it
        raise
    except ValueError as e:
        raise fail(f"scenario {scn.name}: {e}") from None


@reads_logs(after="origin")
def show(
    files: FilesArgument,
    plot: Annotated[Path | None, typer.Option(help="write a picture (PNG, PDF, SVG)")] = None,
    origin: OriginOption = None,
    force: Annotated[bool, typer.Option(help="overwrite an existing picture")] = False,
    *, logs: dict[str, Any],
) -> None:
    """Summarise a measurement file per sensor and kind, and optionally draw it."""
    plot = check_output(plot, "--plot", force, "picture")
    meas = read_or_fail(files, parse_origin(origin), **logs)
    meta = meas.metadata
    title = f"{' + '.join(map(str, files))}: {len(meas)} measurements"
    if "scenario" in meta:
        title += f" of scenario {meta['scenario']}"
        if "seed" in meta:
            title += f" (seed {meta['seed']})"
    print_wide(summary_table(meas, title))
    out.print(describe_sensors(meas))
    if "truth" in meta:
        out.print(f"truth ({meta.get('motion', '?')}): {truth_text(meta)}")
    if "time_origin" in meta:  # a real log: its clock time and frame
        print_import(meas, None)
    from ..results import measurement_warnings
    from .estimate import print_warnings

    print_warnings(measurement_warnings(meas))
    if plot is not None:
        from ..plot.tracks import plot_measurements

        write_picture(plot, force, lambda tmp: plot_measurements(meas, tmp, title=title))
        out.print(f"wrote {plot}")


#: The file that marks a folder as written by ``tma demo`` (so that a re-run may replace it).
DEMO_MARK = ".tma-demo"


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
    out.print(scn.summary())
    meas = scn.simulate(rng=seed)
    write_or_fail(meas, csv, force=True)
    out.print(f"wrote {csv}")
    show([csv], plot=png, origin=None, force=True)


def make_output_folder(folder: Path, option: str) -> None:
    """Make an output folder (and its parents), or end naming it and why it cannot be one."""
    if folder.exists() and not folder.is_dir():
        raise fail(f"{option}{folder}: a file of that name exists; expected a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise fail(f"{option}{folder}: the folder cannot be made ({e.strerror or e})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise fail(f"{option}{folder}: the folder cannot be written")


def prepare_demo_folder(folder: Path, force: bool) -> None:
    """Make ``folder`` an empty demo folder, replacing an earlier demo's."""
    import shutil

    make_output_folder(folder, "--out-dir ")
    if any(folder.iterdir()):
        if not (folder / DEMO_MARK).exists() and not force:
            raise fail(f"--out-dir {folder}: the folder holds files that tma demo did not "
                       "write; choose another folder or use --force to replace it")
        shutil.rmtree(folder)
        folder.mkdir()
    (folder / DEMO_MARK).write_text("written by tma demo; replaced when it runs again\n")


#: The formats of ``tma import`` and how many files each takes (0: one or more, one replay).
IMPORT_FORMATS = {"rep": 0, "dsf": 0, "wide": 1, "gpx": 2, "nmea": 2}
#: The sample logs shipped in ``tmakit/examples`` (written by ``tma examples``): tmakit's
#: simulated logs, and a public Debrief sample (a sensor file, the own ship's and the subject's
#: tracks, with their source and licence in ``debrief-samples.txt``).
EXAMPLE_FILES = ("contact.rep", "drone.csv", "drone.toml", "own.gpx", "own.nmea",
                 "bearings.csv", "bearings.toml", "truth.json", "Freq_BlueSensor.rep",
                 "Freq_BlueTrack.rep", "Freq_RedTrack.rep", "Ambig_cuts_TA.rep",
                 "Ambig_tracks2.rep", "debrief-samples.txt", "EPL-1.0.txt")


def _check_track_suffix(fmt: str, track: Path) -> None:
    """Refuse a track whose suffix says the other format (tracks are read by suffix)."""
    is_gpx = track.suffix.lower() == ".gpx"
    if is_gpx != (fmt == "gpx") and track.is_file():  # a folder or none: the reader says so
        other = "gpx" if is_gpx else "nmea"
        raise fail(f"import {fmt}: the track {track} would be read as "
                   f"{'GPX' if is_gpx else 'NMEA 0183'} (a track is read by its suffix: .gpx "
                   f"is GPX, any other NMEA 0183); use tma import {other}, or rename the file")


def _mapping(mapping: Path | None, map_text: str | None, measure: list[str] | None,
             fmt: str, track: Path | None = None) -> Any:
    if map_text is None and not measure:
        return mapping
    if fmt in ("rep", "dsf"):  # (the schema would say its measurement list is empty)
        raise fail(f"--map and --measure apply to wide logs (and the measurement log of gpx "
                   f"and nmea), not to Debrief replays ({fmt})")
    if mapping is not None:
        raise fail("give the column mapping as --mapping FILE.toml or as --map/--measure, not both")
    from ..io.log_mapping import MappingError, mapping_from_text

    try:
        return mapping_from_text(map_text or "", list(measure or []),
                                 None if track is None else str(track))
    except MappingError as e:
        raise fail(str(e)) from None


def import_(
    format: Annotated[str, typer.Argument(
        metavar="FORMAT", help="rep or dsf (Debrief: one or more files, read as one replay), "
                               "wide (CSV/Parquet log + mapping), gpx or nmea (own track, "
                               "then the measurement log)")],
    files: Annotated[list[Path], typer.Argument(metavar="FILE...",
                                                help="the file(s) to read")],
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="tmakit measurement file to write (.parquet or .csv)")] = None,
    ownship: OwnshipOption = None,
    contact: ContactOption = None,
    bearing_sigma: BearingSigmaOption = None,
    range_sigma: RangeSigmaOption = None,
    frequency_sigma: FrequencySigmaOption = None,
    kinds: KindsOption = None,
    ranges: RangesOption = None,
    mapping: MappingOption = None,
    map_text: Annotated[str | None, typer.Option(
        "--map", help="the mapping inline: time=COL,lat=COL,lon=COL,alt=COL,vn=COL,ve=COL,"
                      "vd=COL,sensor=NAME,altitude=msl")] = None,
    measure: Annotated[list[str] | None, typer.Option(
        help="with --map, one per measurement column: COLUMN=KIND:UNIT:SIGMA")] = None,
    origin: OriginOption = None,
    dim: Annotated[int | None, typer.Option(
        help="2 or 3: override the surface rule (default: 2-D when the sensors' altitudes "
             "stay within 25 m of the origin's)")] = None,
    force: ForceOption = False,
    guess: Annotated[bool, typer.Option(
        "--guess", help="wide logs: print a column mapping (TOML) proposed from the file's "
                        "header, to check and pass as --mapping; nothing is imported")] = False,
) -> None:
    """Read a real log (Debrief, wide CSV/Parquet, GPX or NMEA) into a tmakit file.

    The clock time of t = 0 and the ENU origin (default: the first fix) go into the file's
    metadata and are printed; see docs/your-own-data.md.
    """
    fmt = format.lower()
    if fmt not in IMPORT_FORMATS:
        raise fail(f"unknown format {format!r}: expected one of {', '.join(IMPORT_FORMATS)}")
    if guess:
        print_guess(fmt, files, output)
        return
    if output is None:
        raise fail("give the measurement file to write: -o obs.parquet (or --guess to "
                   "propose a mapping)")
    if IMPORT_FORMATS[fmt] and len(files) != IMPORT_FORMATS[fmt]:
        what = ("the own track and the measurement log" if IMPORT_FORMATS[fmt] == 2 else "one file")
        raise fail(f"import {fmt} takes {what}; got {len(files)} file(s)")
    check_dim(dim)
    check_output(output, "-o", force, "measurements")
    for f in files:
        if not f.exists():
            raise fail(f"{f}: no such file")
    check_ranges(ranges)
    options: dict[str, Any] = {
        "format": "rep" if fmt == "dsf" else fmt, "ownship": ownship, "contact": contact,
        "mapping": _mapping(mapping, map_text, measure, fmt,
                            files[0] if fmt in ("gpx", "nmea") else None),
        "bearing_sigma": bearing_sigma, "range_sigma": range_sigma,
        "frequency_sigma": frequency_sigma, "kinds": kinds, "ranges": ranges, "dim": dim}
    if fmt in ("gpx", "nmea"):
        _check_track_suffix(fmt, files[0])
        options["measurements"] = files[1]
    meas = read_or_fail(files if fmt in ("rep", "dsf") else files[0], parse_origin(origin),
                        **options)
    write_or_fail(meas, output, force)
    print_import(meas, output)


def print_guess(fmt: str, files: list[Path], output: Path | None = None) -> None:
    """Print the mapping proposed for a wide log's header (``--guess``)."""
    if fmt != "wide" or len(files) != 1:
        raise fail("--guess proposes the mapping of one wide log: tma import wide FILE --guess")
    if output is not None:  # (it was left unwritten without a word)
        raise fail(f"-o {output}: --guess only prints a mapping and imports nothing; check it, "
                   "then import with --mapping FILE.toml -o")
    from ..io.errors import MeasurementFileError, refuse_unreadable
    from ..io.log_mapping import guess_mapping

    path = files[0]
    if not path.exists():
        raise fail(f"{path}: no such file")
    try:
        refuse_unreadable(path, binary=path.suffix.lower() in (".parquet", ".pq"))
        proposal = guess_mapping(path)
    except (MeasurementFileError, ValueError, OSError) as e:
        raise fail(str(e)) from None
    typer.echo(proposal.toml(path.name), nl=False)


def print_import(meas: Any, output: Path | None) -> None:
    """Print what was imported: rows, clock time, frame, and the choices made."""
    meta = meas.metadata
    counts = ", ".join(f"{r['count']} {r['kind']} ({r['unit']}) from {r['sensor']}"
                       for r in meas.summary_rows())
    if output is not None:
        out.print(f"wrote {output}: {len(meas)} measurements: {counts}", soft_wrap=True)
    if "source" in meta:
        out.print(f"  source: {meta['source']}", soft_wrap=True)
    if "duplicates_merged" in meta:
        out.print(f"  note: {meta['duplicates_merged']} rows repeated an earlier row (same "
                  "sensor, kind, time, value and sigma) and were merged into it", soft_wrap=True)
    if "time_origin" in meta:
        out.print(f"  t = 0 s is {meta['time_origin']} (UTC); the data span "
                  f"{meas.time.min():g} .. {meas.time.max():g} s")
    if "origin_lat" in meta:
        out.print(f"  ENU origin: lat {float(meta['origin_lat']):.7f} deg, lon "
                  f"{float(meta['origin_lon']):.7f} deg, alt {float(meta['origin_alt']):.1f} m "
                  f"({meta.get('altitude_reference', 'ellipsoid')})"
                  + (f", {meta['origin_source']}" if "origin_source" in meta else ""))
    for key, label in (("dim_rule", "frame"), ("velocity_source", "sensor velocity")):
        if key in meta:
            out.print(f"  {label}: {meta[key]}", soft_wrap=True)
    if "bearing_sigma_deg" in meta:
        out.print("  " + _replay_sigmas(meta, set(meas.kinds)), soft_wrap=True)
    if output is not None and meas.ambiguous_si is not None:
        import numpy as np

        out.print(f"  note: the {int((~np.isnan(meas.ambiguous_si)).sum())} ambiguous twin "
                  "bearings (a towed array's mirror) are not written: a measurement file has "
                  "no column for them, and the first bearing of each cut is kept; resolve the "
                  "side from the log itself (tma estimate LOG...)", soft_wrap=True)


def _replay_sigmas(meta: dict[str, str], kinds: set[str]) -> str:
    """Say which sigmas a Debrief file's rows got: the lines' accuracies or the defaults."""
    given = [f"{kind} {float(meta[key]):g} {unit}" for kind, key, unit in (
        ("bearing", "bearing_sigma_deg", "deg"), ("range", "range_sigma_m", "m"),
        ("frequency", "frequency_sigma_hz", "Hz")) if kind in kinds and key in meta]
    if "bearing_sigma_by_sensor_deg" in meta and "bearing" in kinds:
        given.append(f"bearing by sensor {meta['bearing_sigma_by_sensor_deg']} deg")
    stated = int(meta.get("sigma_from_file", "0"))
    where = (f"; {stated} ;SENSOR3: lines state their own accuracy" if stated
             else " (not in the file)")
    return "sigma: " + ", ".join(given) + where


def examples(
    folder: Annotated[Path, typer.Argument(help="folder to write the sample logs into")],
    force: ForceOption = False,
) -> None:
    """Write the sample logs shipped with tmakit (made by its own simulation) into FOLDER.

    contact.rep (Debrief), drone.csv + drone.toml (wide log), own.gpx, own.nmea,
    bearings.csv + bearings.toml (own track + bearings), truth.json (what the simulation
    put in them), and Debrief's public TA_DUMMY sample: Freq_BlueSensor.rep (sensor file),
    Freq_BlueTrack.rep (own ship), Freq_RedTrack.rep (the subject's truth), and its AssetData
    towed-array pair: Ambig_cuts_TA.rep (ambiguous cuts), Ambig_tracks2.rep (own ship and
    subject), with their source in debrief-samples.txt and their licence in EPL-1.0.txt; see
    docs/your-own-data.md and docs/analyst.md.
    """
    from importlib import resources

    targets = [folder / name for name in EXAMPLE_FILES]
    for t in targets:
        refuse_existing(t, force)
    make_output_folder(folder, "")
    from ..io import atomic_write

    for name, target in zip(EXAMPLE_FILES, targets, strict=True):
        data = (resources.files("tmakit") / "examples" / name).read_bytes()
        with atomic_write(target, force=force) as tmp:
            Path(tmp).write_bytes(data)
    out.print(f"wrote {len(targets)} sample logs to {folder}: {', '.join(EXAMPLE_FILES)}")
