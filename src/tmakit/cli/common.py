"""What every ``tma`` command shares.

The consoles, the error exit, the refusal to overwrite, parsing of ``--origin`` and ``name=value``
options, reading and writing measurement files, and the typer option aliases of the commands that
fit or bound a motion model.  Nothing numerical is imported here at module level (``tma --help``
stays light).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console

out = Console()
err = Console(stderr=True)


def print_wide(renderable: object) -> None:
    """Print a table at the terminal's width, or 160 columns when output is not a terminal."""
    (out if out.is_terminal else Console(width=160)).print(renderable)


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on standard error and return the exit (status 2) to raise."""
    err.print(f"[bold red]error:[/] {message}", highlight=False, markup=True, soft_wrap=True)
    return typer.Exit(2)


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
        raise fail(f"--origin {text!r}: expected LAT,LON,ALT in degrees, degrees, "
                   "metres") from None
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
        name, eq, value = part.partition("=")
        try:
            if not eq or not name.strip():
                raise ValueError
            number = float(value)
            if not math.isfinite(number) or name.strip() in values:
                raise fail(f"{option} {text!r}: {name.strip()} is given twice" if
                           name.strip() in values else
                           f"{option} {text!r}: {name.strip()}={value.strip()} is not a "
                           "finite number")
            values[name.strip()] = number
        except ValueError:
            raise fail(f"{option} {text!r}: expected name=value pairs separated by commas, "
                       f"e.g. x=3200,y=3200,vx=-21.65,vy=-12.5 (problem at {part!r})"
                       ) from None
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

    try:
        write_measurements(meas, path, force=force)
    except FileExistsError:
        raise fail(f"{path} already exists; use --force to overwrite it") from None
    except ValueError as e:
        raise fail(str(e)) from None


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

    if ref_time is not None and not math.isfinite(ref_time):
        raise fail(f"--ref-time {ref_time}: expected a finite time (s)")
    source = "--ref-time"
    if name is None:
        if meas is not None and "motion" in meas.metadata:
            name = meas.metadata["motion"]
            if ref_time is None and (ref_time := file_ref_time(meas)) is not None:
                source = "the file's ref_time"
        else:
            raise fail("--motion is needed (cv2d, cv3d, static2d, static3d)")
    try:
        chosen = ref_time is not None
        if ref_time is None:  # inside the data: the fit does not depend on the time origin
            ref_time = 0.0 if meas is None else default_ref_time(meas.time)
        model = motion_from_name(name, ref_time)
    except ValueError as e:
        raise fail(str(e)) from None
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
    import os

    try:
        return max(0, int(os.environ.get("TMA_MAX_MANOEUVRES", "5")))
    except ValueError:
        return 5


def model_options(drift: bool, free_exponent: bool, propagation_speed: float | None = None
                  ) -> dict[str, dict[str, object]]:
    """Return the model options of ``--drift``, ``--free-exponent`` and ``--propagation-speed``."""
    if propagation_speed is not None and not propagation_speed > 0:
        raise fail(f"--propagation-speed {propagation_speed:g}: expected a speed > 0 (m/s)")
    speed = {} if propagation_speed is None else {"propagation_speed": propagation_speed}
    return {"frequency": {"drift": drift, **speed},
            "power": {"exponent": None if free_exponent else 2.0}}


def is_measurement_file(text: str) -> bool:
    """Whether a command argument names a measurement file (``.csv``, ``.parquet``, ``.pq``)."""
    from ..io import find_format  # the registry, so that a new format is recognised here too

    return find_format(text, reading=True) is not None


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
BearingSigmaOption = Annotated[float | None, typer.Option(
    help="Debrief: bearing noise std (deg); default a ;SENSOR3: line's accuracy, else 1")]
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


def reader_options(format: str | None, ownship: str | None, contact: str | None,
                   mapping: Path | None, bearing_sigma: float | None,
                   range_sigma: float | None = None,
                   frequency_sigma: float | None = None, *, kinds: str | None = None,
                   ranges: str | None = None) -> dict[str, Any]:
    """Collect the reader options of a command (None when not given)."""
    if ranges is not None and ranges not in ("use", "ignore"):
        raise fail(f"--ranges {ranges!r}: expected use or ignore")
    return {"format": format, "ownship": ownship, "contact": contact, "mapping": mapping,
            "bearing_sigma": bearing_sigma, "range_sigma": range_sigma,
            "frequency_sigma": frequency_sigma, "kinds": kinds, "ranges": ranges}
