"""What every ``tma`` command shares: consoles, errors, options, reading files, checking outputs.

Nothing numerical is imported at module level (``tma --help`` stays light).
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import math
import os
import re
import typing
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

# No markup but where asked for: a file name, a sensor name or a message may hold brackets
# ("log [final].csv", "give [position] columns") that rich would take for style tags.
out = Console(highlight=False, markup=False)
err = Console(stderr=True, highlight=False, markup=False)


def print_wide(renderable: object) -> None:
    """Print a table at the terminal's width, or 160 columns when output is not a terminal."""
    (out if out.is_terminal else Console(width=160, markup=False)).print(renderable)


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on standard error and return the exit (status 2) to raise."""
    err.print(f"[bold red]error:[/] {escape(message)}", markup=True, soft_wrap=True)
    return typer.Exit(2)


@contextlib.contextmanager
def failing(prefix: str = "", written: Path | None = None,
            errors: tuple[type[Exception], ...] = (ValueError,)) -> Iterator[None]:
    """Turn ``errors`` into ``error: prefix message``, ``FileExistsError`` into the --force hint."""
    try:
        yield
    except FileExistsError:
        if written is None:
            raise
        raise fail(f"{written} already exists; use --force to overwrite it") from None
    except errors as e:
        raise fail(f"{prefix}{e}") from None


def refuse_existing(path: Path, force: bool) -> None:
    """Refuse to overwrite an existing output file unless ``--force`` was given."""
    if path.exists() and not force:
        raise fail(f"{path} already exists; use --force to overwrite it")


def parse_origin(text: str | None) -> tuple[float, float, float] | None:
    """``--origin LAT,LON,ALT`` as ``(lat_deg, lon_deg, alt_m)``, or None when not given."""
    if text is None:
        return None
    try:
        lat, lon, alt = (float(v) for v in text.split(","))
    except ValueError:
        raise fail(f"--origin {text!r}: expected LAT,LON,ALT in degrees, degrees, metres") from None
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 360.0 and math.isfinite(alt)):
        raise fail(f"--origin {text!r}: expected a latitude in [-90, 90] deg, a longitude in "
                   "[-180, 360] deg and a finite altitude (m)")
    return lat, lon, alt


def parse_assignments(text: str | None, option: str) -> dict[str, float]:
    """``"x=1,y=2"`` -> ``{"x": 1.0, "y": 2.0}``, with a clear error for anything else."""
    if text is None:
        return {}
    values: dict[str, float] = {}
    for part in text.split(","):
        name, eq, value = (s.strip() for s in part.partition("="))
        try:
            if not eq or not name:
                raise ValueError
            number = float(value)
        except ValueError:
            raise fail(f"{option} {text!r}: expected name=value pairs separated by commas, "
                       f"e.g. x=3200,y=3200,vx=-21.65,vy=-12.5 (problem at {part!r})"
                       ) from None
        if name in values:
            raise fail(f"{option} {text!r}: {name} is given twice")
        if not math.isfinite(number):
            raise fail(f"{option} {text!r}: {name}={value} is not a finite number")
        values[name] = number
    return values


def load_scenario_or_fail(name: str) -> Any:
    """Load a built-in scenario by name or a TOML scenario file, errors as ``error: ...``."""
    from ..scenario.files import ScenarioFileError, load_scenario

    try:
        return load_scenario(name)
    except ScenarioFileError as e:
        raise fail(str(e)) from None


def write_or_fail(meas: Any, path: Path, force: bool) -> None:
    """Write a measurement file, errors as ``error: ...``."""
    from ..io.measurement_files import write_measurements

    with failing(written=path):
        write_measurements(meas, path, force=force)


def file_ref_time(meas: Any) -> float | None:
    """Give the reference time a file's metadata states (s), or None (absent or empty)."""
    text = meas.metadata.get("ref_time", "")
    return None if text == "" else float(text)


def check_ref_time(ref_time: float, times: Any, source: str) -> None:
    """Refuse a reference time far from the data (:func:`tmakit.rules.time_problem`)."""
    from ..rules import time_problem  # (not at import: ``tma --help`` loads no numpy)

    problem = time_problem(ref_time, times, source)
    if problem is None:
        return
    remedy = ("give --ref-time near the data, or --motion (then the file's reference time is "
              "not used)" if source != "--ref-time"
              else "give a time near the data, in the file's time scale, or leave --ref-time "
              "out (a time near the data is chosen)")
    raise fail(f"{problem} and the fit would lose its digits: {remedy}")


def motion_or_fail(name: str | None, ref_time: float | None, meas: Any = None) -> Any:
    """Return the motion model named by ``--motion``, errors as ``error: ...``."""
    from ..motion import Stationary, default_ref_time, motion_from_name

    source = "--ref-time"
    if name is None:
        if meas is not None and "motion" in meas.metadata:
            name = meas.metadata["motion"]
            if ref_time is None and (ref_time := file_ref_time(meas)) is not None:
                source = "the file's ref_time"
        else:
            raise fail("--motion is needed (cv2d, cv3d, static2d, static3d)")
    with failing():
        chosen = ref_time is not None
        if ref_time is None:  # inside the data: the fit does not depend on the time origin
            ref_time = 0.0 if meas is None else default_ref_time(meas.time)
        model = motion_from_name(name, ref_time)
    if chosen and meas is not None and not isinstance(model, Stationary):
        check_ref_time(ref_time, meas.time, source)  # (a fixed emitter has no velocity)
    if meas is not None and model.n_params > len(meas):  # work limit: not identifiable
        raise fail(f"--motion {name}: {model.n_params:,} parameters from {len(meas):,} "
                   "measurements cannot be identified (at most one parameter per "
                   "measurement); choose a motion with fewer parameters")
    manoeuvres = getattr(model, "manoeuvres", None)
    if manoeuvres is not None and manoeuvres > max_manoeuvres():  # work limit: run time
        raise fail(f"--motion {name}: {manoeuvres:,} manoeuvres is more than the limit of "
                   f"{max_manoeuvres():,} (an estimate searches the change-over times of every "
                   "manoeuvre: seconds to minutes each on a long log); raise it with "
                   "TMA_MAX_MANOEUVRES=N")
    return model


def max_manoeuvres() -> int:
    """Give the most manoeuvres ``--motion curvilinear:M`` may search (``TMA_MAX_MANOEUVRES``)."""
    try:
        return max(0, int(os.environ.get("TMA_MAX_MANOEUVRES", "5")))
    except ValueError:
        return 5


def check_dim(dim: int | None) -> int | None:
    """Refuse ``--dim`` other than 2 or 3 (None: chosen from the data)."""
    if dim not in (None, 2, 3):
        raise fail(f"--dim {dim}: expected 2 or 3")
    return dim


def model_options(drift: bool, free_exponent: bool, propagation_speed: float | None = None
                  ) -> dict[str, dict[str, object]]:
    """Return the model options of ``--drift``, ``--free-exponent`` and ``--propagation-speed``."""
    from ..core.units import SPEED_OF_LIGHT
    from ..measurements.frequency import PROPAGATION_SPEED

    if propagation_speed is not None and not 0 < propagation_speed <= SPEED_OF_LIGHT:
        raise fail(f"--propagation-speed {propagation_speed:g}: {PROPAGATION_SPEED}")
    speed = {} if propagation_speed is None else {"propagation_speed": propagation_speed}
    return {"frequency": {"drift": drift, **speed},
            "power": {"exponent": None if free_exponent else 2.0}}


def note_unused_model_options(meas: Any, options: dict[str, dict[str, object]]) -> None:
    """Note each of --drift, --free-exponent, --propagation-speed that the data leave idle."""
    frequency, power = options["frequency"], options["power"]
    for given, option, kind in ((frequency["drift"], "--drift", "frequency"),
                                ("propagation_speed" in frequency, "--propagation-speed",
                                 "frequency"),
                                (power["exponent"] is None, "--free-exponent", "power")):
        if given and kind not in meas.kinds:
            err.print(f"note: {option} models the {kind} measurements, and these data have "
                      "none", soft_wrap=True)


# Options shared by the commands that fit or bound a motion model.
MotionOption = Annotated[str | None, typer.Option(
    help="cv2d, cv3d, static2d, static3d, curvilinear[:M]")]
RefTimeOption = Annotated[float | None, typer.Option(
    help="reference time of the motion parameters (s)")]
DriftOption = Annotated[bool, typer.Option(help="model a linear carrier drift")]
PropagationSpeedOption = Annotated[float | None, typer.Option(
    metavar="M/S", help="speed that carries the frequencies: 1500 for sonar tonals (sound in "
                        "sea water), 299792458 for radio; default the file's (Debrief "
                        "replays: 1500), else light's")]
SensorPositionSigmaOption = Annotated[float | None, typer.Option(
    help="sensor positions known to this std per axis (m): their errors in the bound and the "
         "fit (Ho, Lu & Kovavisaruch 2007), and the loss against known positions")]
FreeExponentOption = Annotated[bool, typer.Option(help="the path-loss exponent is unknown too")]
OriginOption = Annotated[str | None, typer.Option(
    help="ENU origin LAT,LON,ALT for files with sensor_lat/sensor_lon")]
ForceOption = Annotated[bool, typer.Option(help="overwrite existing output files")]
NoProgressOption = Annotated[bool, typer.Option("--no-progress", help="no progress bar")]
JsonOption = Annotated[bool, typer.Option("--json", help="print JSON")]
# Options of the readers of real logs (docs/your-own-data.md).
FormatOption = Annotated[str | None, typer.Option(
    "--format", help="file format when the suffix does not say it: csv, parquet, rep, wide, "
                     "gpx, nmea")]
OwnshipOption = Annotated[str | None, typer.Option(
    help="Debrief: the own ship's track name (when several tracks have sensor lines)")]
ContactOption = Annotated[str | None, typer.Option(
    help="Debrief: the contact, a sensor name or the first word of the sensor labels")]
MappingOption = Annotated[Path | None, typer.Option(
    help="wide CSV/Parquet log: its column mapping (TOML file)")]
BearingSigmaOption = Annotated[str | None, typer.Option(
    help="Debrief: bearing noise std (deg), or one per sensor NAME=DEG,... (a hull and a towed "
         "array: HM=0.5,TA=2); default a ;SENSOR3: line's accuracy, else 1")]
RangeSigmaOption = Annotated[float | None, typer.Option(
    metavar="M", help="Debrief: range noise std (m), default 100")]
FrequencySigmaOption = Annotated[float | None, typer.Option(
    metavar="HZ", help="Debrief: frequency noise std (Hz); default a ;SENSOR3: line's "
                       "accuracy, else 0.1")]

KindsOption = Annotated[str | None, typer.Option(
    metavar="KIND[,KIND...]", help="keep only these kinds of the file, e.g. bearing (bearings-"
                                   "only TMA of a file with ranges) or bearing,frequency")]
RangesOption = Annotated[str | None, typer.Option(
    metavar="use|ignore", help="Debrief: fit every range (use) or none (ignore); default: "
                               "placeholder ranges (0, or the same on every cut) left out")]
FilesArgument = Annotated[list[Path], typer.Argument(
    metavar="FILE", help="measurement file, or several Debrief files read as one replay (a "
                            "sensor file and the own ship's track file)")]


#: The options of the readers of real logs, in the order every command lists them.
READER_OPTIONS = {"format": FormatOption, "ownship": OwnshipOption, "contact": ContactOption,
                  "mapping": MappingOption, "bearing_sigma": BearingSigmaOption,
                  "range_sigma": RangeSigmaOption, "frequency_sigma": FrequencySigmaOption,
                  "kinds": KindsOption, "ranges": RangesOption}


def reads_logs(after: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Give a command :data:`READER_OPTIONS` after its option ``after``, passed as ``logs``."""

    def add(command: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(command)
        def run(*args: Any, **given: Any) -> Any:
            logs = {name: given.pop(name, None) for name in READER_OPTIONS}
            check_ranges(logs["ranges"])
            return command(*args, logs=logs, **given)

        hints = typing.get_type_hints(command, include_extras=True)  # (typer reads these)
        params = [p.replace(annotation=hints[p.name])
                  for p in inspect.signature(command).parameters.values() if p.name != "logs"]
        at = [p.name for p in params].index(after) + 1
        params[at:at] = [inspect.Parameter(name, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                           default=None, annotation=option)
                         for name, option in READER_OPTIONS.items()]
        run.__signature__ = inspect.Signature(params, return_annotation=None)  # type: ignore[attr-defined]
        return run

    return add


def check_ranges(ranges: str | None) -> None:
    """Refuse a ``--ranges`` other than use or ignore."""
    if ranges is not None and ranges not in ("use", "ignore"):
        raise fail(f"--ranges {ranges!r}: expected use or ignore")


def bearing_sigmas(text: str | float) -> float | dict[str, float]:
    """Parse ``--bearing-sigma``: one std (deg), or ``NAME=DEG,...`` one per sensor."""
    try:
        return sigma_option("--bearing-sigma", text, float(text), "bearing")
    except ValueError:
        pass
    out: dict[str, float] = {}
    for part in str(text).split(","):
        name, eq, value = part.partition("=")
        if name.strip() in out:
            raise fail(f"--bearing-sigma {text!r}: {name.strip()} is given twice")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            name = ""
        if not eq or not name.strip():
            raise fail(f"--bearing-sigma {text!r}: expected a std in degrees (0.5), or one per "
                       "sensor, NAME=DEG,... (HM=0.5,TA=2)") from None
        sigma_option("--bearing-sigma", text, out[name.strip()], "bearing")
    return out


def sigma_options(options: dict[str, Any]) -> dict[str, Any]:
    """Check the sigma options of Debrief replays; ``--bearing-sigma`` as ``bearing_sigma_deg``."""
    if "bearing_sigma" in options:  # --bearing-sigma is in degrees
        options["bearing_sigma_deg"] = bearing_sigmas(options.pop("bearing_sigma"))
    for kind in ("range", "frequency"):
        if (sigma := options.get(f"{kind}_sigma")) is not None:
            sigma_option(f"--{kind}-sigma", f"{sigma:g}", sigma, kind)
    return options


def sigma_option(option: str, text: object, sigma: float, kind: str) -> float:
    """Refuse a sigma option (file unit) that is not > 0 or above its kind's ceiling."""
    from ..measurements import KINDS
    from ..rules import sigma_ceiling, sigma_ceiling_text

    limit = sigma_ceiling(kind)
    if not sigma > 0:
        raise fail(f"{option} {text}: expected a noise standard deviation > 0 "
                   f"({KINDS[kind].file_unit})")
    if limit is not None and sigma > limit:
        raise fail(f"{option} {text}: expected {sigma_ceiling_text(kind)}")
    return sigma


class FaultInWrittenLines(typer.Exit):
    """A followed file's complete lines break the file contract: more lines cannot mend it."""


def read_or_fail(path: Path | list[Path], origin: tuple[float, float, float] | None = None,
                 notes: bool = True, shown_as: dict[Path, Path] | None = None,
                 **options: Any) -> Any:
    """Read a measurement file (or several read as one), errors as ``error: ...``.

    ``shown_as`` maps the paths read to the names the user gave (``tma track --follow`` reads
    snapshots of the files): errors name the user's file, and one that names a row or line
    raises :class:`FaultInWrittenLines`.
    """
    from ..io.errors import reader_notes
    from ..io.measurement_files import (
        ForeignOptionError,
        MeasurementFileError,
        read_measurements,
    )

    paths = [path] if isinstance(path, Path) else list(path)
    for p in paths:
        if (stray := stray_value(p)) is not None:
            raise fail(stray)
        if not p.exists():
            raise fail(f"{p}: no such file")
        if p.is_dir():
            raise fail(f"{p}: is a folder, not a measurement file")
    options = {k: v for k, v in options.items() if v is not None}
    kinds = parse_kinds(options.pop("kinds", None))
    options = log_options(paths, options, kinds)
    options = sigma_options(options)
    try:
        meas = read_measurements(paths[0] if len(paths) == 1 else paths, origin=origin, **options)
    except OSError as e:
        raise fail(f"{e.filename or paths[0]}: cannot be read ({e.strerror or e})") from None
    except ForeignOptionError as e:
        flags = [f"--{n.removesuffix('_deg').replace('_', '-')}" for n in e.foreign]
        raise fail(f"{', '.join(flags)} {'apply' if len(flags) > 1 else 'applies'} to other "
                   f"formats, not to {e.label} files ({paths[0]})") from None
    except (MeasurementFileError, ValueError) as e:
        from ..io.checker import ORIGIN_HINT

        message = str(e).replace(ORIGIN_HINT, "--origin LAT,LON,ALT")
        if shown_as is None:
            raise fail(message) from None
        for read, given in shown_as.items():
            message = message.replace(str(read), str(given))
        if any(re.match(r"(row|line) \d+", p) for p in getattr(e, "problems", [])):
            fail(message + "\n(the lines already written cannot change: correct the file and "
                 "follow it again)")
            raise FaultInWrittenLines(2) from None
        raise fail(message) from None
    for note in reader_notes(meas.metadata, pop=True):
        if notes:
            err.print(note, markup=False, soft_wrap=True)
    if origin is not None and "origin_lat" not in meas.metadata:
        err.print(f"warning: --origin is for files with sensor_lat/sensor_lon; {paths[0].name} "
                  "gives ENU positions, so it is not used")
    return only_kinds(meas, kinds, paths)


#: The running command's arguments as given, and its options that take a value (True: may be
#: given several times), set by its parser (:class:`tmakit.cli.PlainCommand`).
_GIVEN: dict[str, Any] = {"arguments": [], "takes": {}}


def note_given(arguments: list[str], takes: dict[str, bool]) -> None:
    """Remember the running command's arguments as given and the options that take a value."""
    _GIVEN.update(arguments=list(arguments), takes=dict(takes))


def stray_value(path: Path) -> str | None:
    """Say why a file argument is an option's second value (``--export a.rep b.kml``), or None.

    Only a file that is missing or of no format read, standing right after an option's value.
    """
    from ..io import find_format

    if path.exists() and find_format(path, reading=True) is not None:
        return None
    given: list[str] = _GIVEN["arguments"]
    takes: dict[str, bool] = _GIVEN["takes"]
    for at, arg in enumerate(given[:given.index("--") if "--" in given else None]):
        if at == 0 or arg.startswith("-") or Path(arg) != path:
            continue
        name, eq, value = given[at - 1].partition("=")
        if not (eq and name in takes):
            if at < 2 or given[at - 2] not in takes or given[at - 1].startswith("-"):
                continue
            name, value = given[at - 2], given[at - 1]
        what = "no such file" if not path.exists() else "not a measurement file"
        again = (f", so give {name} once per file: {name} {value} {name} {path}" if takes[name]
                 else f" (values of a list joined by commas), so {path} was read as a "
                 "measurement file")
        return (f"{path}: {what}, and it stands after {name} {value}: an option takes one "
                f"value{again}")
    return None


def parse_kinds(text: str | None) -> list[str] | None:
    """Read ``--kinds bearing,frequency``: the measurement kinds to keep (None: all)."""
    if text is None:
        return None
    from ..measurements import KINDS

    kinds = [k.strip() for k in text.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        raise fail(f"--kinds {text!r}: expected measurement kinds separated by commas, from "
                   f"{', '.join(KINDS)}" + (f" (not {', '.join(unknown)})" if unknown else ""))
    return kinds


def only_kinds(meas: Any, kinds: list[str] | None, paths: list[Path]) -> Any:
    """Keep the rows of the kinds asked for (``--kinds``); refuse when none is left."""
    if kinds is None:
        return meas
    import numpy as np

    keep = np.isin(meas.kinds, kinds)
    if not keep.any():
        have = ", ".join(sorted(set(meas.kinds)))
        raise fail(f"--kinds {','.join(kinds)}: {' + '.join(map(str, paths))} has no "
                   f"measurement of these kinds (it has {have})")
    return meas if keep.all() else meas.take(keep)


def log_options(paths: list[Path], options: dict[str, Any],
                 kinds: list[str] | None) -> dict[str, Any]:
    """Keep the reader options of real logs for real logs; refuse them for tmakit's files."""
    from ..io import find_format

    path = paths[0]
    if "mapping" in options and "format" not in options and path.suffix.lower() in (
            ".csv", ".parquet", ".pq"):
        options["format"] = "wide"  # a column mapping: the file is a wide log
    with failing("--format: "):
        fmt = find_format(path, options.get("format"), reading=True)
    if fmt is not None and fmt.name == "rep":
        return options | ({"kinds": kinds} if kinds is not None else {})
    options.pop("window", None)  # applied to the set once read (select_window)
    if "ranges" in options:
        raise fail("--ranges applies to Debrief files (.rep, .dsf), whose range field may be a "
                   f"placeholder, not to {path}")
    if fmt is None or fmt.name not in ("csv", "parquet"):
        return options
    options.pop("dim", None)  # tmakit's own files: the filter's --dim only
    given = [f"--{k.replace('_', '-')}" for k in options if k != "format"]
    if given:
        verb = "apply" if len(given) > 1 else "applies"
        raise fail(f"{', '.join(given)} {verb} to real logs (Debrief, wide CSV/Parquet with "
                   f"--mapping, GPX, NMEA), not to tmakit's {fmt.label} file {path}")
    return options


def parse_time(text: str | None, meas: Any, option: str) -> float | None:
    """Return a time option in seconds: seconds, an ISO-8601 clock time, or ``HH:MM[:SS]``."""
    if text is None:
        return None
    from ..io.logs import seconds_of_time_text
    from ..results.context import TIME_ORIGIN_KEY

    origin_ns = span = None
    if (origin := meas.metadata.get(TIME_ORIGIN_KEY)) is not None:
        import numpy as np

        from ..io.logs import parse_clock_times

        stamps, bad = parse_clock_times([origin])
        if not bad[0]:
            origin_ns = int(stamps[0])
            if len(meas):
                span = tuple(origin_ns + round(float(f(meas.time)) * 1e9) for f in (np.min, np.max))
    with failing():
        return seconds_of_time_text(text, option, origin_ns, span)  # type: ignore[arg-type]


def window_times(meas: Any, start: str | None, stop: str | None) -> tuple[float | None,
                                                                        float | None]:
    """Parse ``--from`` and ``--to`` (seconds, or None), refusing a window that ends first."""
    t_from, t_to = parse_time(start, meas, "--from"), parse_time(stop, meas, "--to")
    if t_from is not None and t_to is not None and t_from > t_to:
        from ..io.logs import reversed_window

        raise fail(reversed_window(str(start), str(stop), f"{t_from:g} s", f"{t_to:g} s"))
    return t_from, t_to


def select_window(meas: Any, start: str | None, stop: str | None) -> Any:
    """Return the rows with ``--from <= time <= --to`` (one leg), refusing an empty window."""
    t_from, t_to = window_times(meas, start, stop)
    if t_from is None and t_to is None:
        return meas
    keep = ((meas.time >= (t_from if t_from is not None else -float("inf")))
            & (meas.time <= (t_to if t_to is not None else float("inf"))))
    if int(keep.sum()) == 0:
        where = (f"--from {start} ({t_from:g} s): no measurement at or after it" if t_to is None
                 else f"--to {stop} ({t_to:g} s): no measurement at or before it"
                 if t_from is None else
                 f"--from/--to: no measurement between {t_from} and {t_to} s")
        raise fail(f"{where} (the file covers {meas.time.min():g} .. {meas.time.max():g} s)")
    return meas.take(keep)


def read_window(paths: list[Path], origin: Any, window: tuple[str | None, str | None],
                **options: Any) -> Any:
    """Read the files and keep ``--from``/``--to`` (a replay's reader applies it first)."""
    return select_window(measured(read_or_fail(paths, origin, window=window, **options), paths),
                         *window)


def measured(meas: Any, paths: list[Path]) -> Any:
    """Refuse a set without a row (a header alone) before any work is asked of it."""
    if len(meas) == 0:
        raise fail(f"{' + '.join(map(str, paths))}: no measurement (a header without rows): "
                   "nothing to estimate or track")
    return meas


def window_help(purpose: str, end: str) -> str:
    """Help of ``--from`` (``end`` "first") or ``--to`` ("last"), led by what the window is for."""
    return f"{purpose}: {end} time (seconds, a UTC clock time, or HH:MM[:SS] on the data's day)"


#: Suffixes of pictures (matplotlib's formats that tmakit promises).
PICTURE_SUFFIXES = (".png", ".pdf", ".svg")
#: Suffixes of tables and measurement files (CSV, Parquet).
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
#: Suffixes of the solution page (``--html``).
PAGE_SUFFIXES = (".html", ".htm")
#: Suffixes of an exported solution (``--export``: Debrief lines, GeoJSON, KML).
SOLUTION_SUFFIXES = (".rep", ".geojson", ".kml")

_FORMATS = {"picture": PICTURE_SUFFIXES, "table": TABLE_SUFFIXES, "json": None,
            "measurements": None, "page": PAGE_SUFFIXES, "solution": SOLUTION_SUFFIXES}


def check_output(path: Path | None, option: str, force: bool, kind: str = "table"
                 ) -> Path | None:
    """Resolve and check one output path before any computation."""
    if path is None:
        return None
    given, path = path, Path(path)
    suffixes = _FORMATS[kind]
    if kind == "picture" and path.suffix == "" and not path.is_dir():
        path = path.with_name(path.name + ".png")  # what matplotlib would write
    if path.is_dir():
        raise fail(f"{option} {path}: is a folder, not a file")
    if kind == "measurements":
        from ..io import find_format  # the registry: a new writable format is known here too
        from ..io.formats import registered_formats

        if find_format(path, reading=False) is None:
            known = sorted({x for f in registered_formats(False) for x in f.suffixes})
            raise fail(f"{option} {path}: unknown format {path.suffix or '(no suffix)'!r}; "
                       f"expected {', '.join(known)}")
    elif suffixes is not None and path.suffix.lower() not in suffixes:
        said = {"table": ".csv or .parquet", "picture": ".png, .pdf or .svg",
                "page": ".html", "solution": ".rep, .geojson or .kml"}[kind]
        raise fail(f"{option} {path}: unknown format {path.suffix or '(no suffix)'!r}; "
                   f"written as {said}")
    parent = path.parent
    if not parent.exists():
        raise fail(f"{option} {path}: the folder {parent} does not exist")
    if not parent.is_dir():
        raise fail(f"{option} {path}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise fail(f"{option} {path}: the folder {parent} cannot be written")
    if path.exists():
        for source in _command_inputs(given):
            if Path(source).is_file() and _same_file(Path(source), path):
                raise fail(f"{option} {path}: is the input file {source} of this command; it "
                           "is never written over, --force or not: write to another file")
        refuse_existing(path, force)
    return path


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


#: The arguments of the running command, by name (set by :func:`tmakit.cli.guard.guarded`).
_ARGUMENTS: dict[str, Any] = {}


def note_arguments(arguments: dict[str, Any]) -> None:
    """Remember the running command's arguments: the files they name are its inputs."""
    _ARGUMENTS.clear()
    _ARGUMENTS.update(arguments)


def _command_inputs(given: object) -> list[Path]:
    """Every file named by the running command's arguments other than the output ``given``."""
    named: list[Path] = []
    for values in _ARGUMENTS.values():
        for value in values if isinstance(values, list | tuple) else [values]:
            if value is given or not isinstance(value, str | Path) or not str(value):
                continue
            try:
                if Path(value).is_file():
                    named.append(Path(value))
            except (OSError, ValueError):
                continue
    return named


def check_outputs(outputs: Iterable[tuple[str, Path | None, str]], force: bool
                  ) -> list[Path | None]:
    """Check several outputs (:func:`check_output`) and refuse two options naming one file."""
    resolved: list[Path | None] = []
    seen: dict[Path, str] = {}
    for option, path, kind in outputs:
        p = check_output(path, option, force, kind)
        if p is not None:
            key = p.resolve()
            if key in seen:
                raise fail(f"{option} {p}: the same file as {seen[key]}")
            seen[key] = option
        resolved.append(p)
    return resolved


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


@contextlib.contextmanager
def claim_outputs(paths: Iterable[Path | None]) -> Iterator[None]:
    """Hold a long command's outputs for it alone (``.NAME.tma-lock``; a dead run's is taken)."""
    held: list[Path] = []
    try:
        for path in (p for p in paths if p is not None):
            lock = path.with_name(f".{path.name}.tma-lock")
            for _ in range(2):
                try:
                    fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
                except FileExistsError:
                    try:
                        pid = int(lock.read_text().strip() or "0")
                    except (OSError, ValueError):
                        pid = 0
                    if pid and _alive(pid):
                        raise fail(f"{path}: another tma run (process {pid}) is writing it; "
                                   f"write to another file, or wait (its lock: {lock})") from None
                    lock.unlink(missing_ok=True)  # the run that held it has ended
                    continue
                with os.fdopen(fd, "w") as f:
                    f.write(f"{os.getpid()}\n")
                held.append(lock)
                break
        yield
    finally:
        for lock in held:
            lock.unlink(missing_ok=True)


def write_picture(path: Path, force: bool, draw: Callable[[Path], Any]) -> None:
    """Draw a picture into a temporary file and move it into place (never a partial file)."""
    from ..io import atomic_write

    with failing(written=path, errors=()), atomic_write(path, force=force, keep_suffix=True) as tmp:
        draw(tmp)


def memory_limit() -> int:
    """Give the memory a command may plan to use (bytes): ``TMA_MAX_MEMORY_GB``, default 2."""
    try:
        gb = float(os.environ.get("TMA_MAX_MEMORY_GB", "2"))
    except ValueError:
        gb = 2.0
    return int(max(gb, 0.001) * 2**30)


def check_particles(particles: int | None) -> None:
    """Refuse a particle count whose working arrays (8 x 8 doubles each) would not fit memory."""
    if particles is None:
        return
    need = particles * 8 * 8 * 8
    if need > memory_limit():
        raise fail(f"--particles {particles:,}: about {need / 2**30:.1f} GiB of working memory, "
                   f"more than the limit of {memory_limit() / 2**30:.1f} GiB; raise it with "
                   "TMA_MAX_MEMORY_GB=N")
