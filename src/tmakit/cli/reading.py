"""How ``tma`` reads measurement files: one or several, real logs' options, ``--kinds``.

:func:`read_or_fail` reads (errors as ``error: ...``, notes printed); the other functions
decide which reader options apply to which format, read ``--kinds`` and keep the rows of those
kinds.  No numerical library at import time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .common import err, fail

__all__ = ["log_options", "only_kinds", "parse_kinds", "read_or_fail"]


def read_or_fail(path: Path | list[Path], origin: tuple[float, float, float] | None = None,
                 notes: bool = True, **options: Any) -> Any:
    """Read a measurement file (or several read as one), errors as ``error: ...``."""
    from ..io.errors import reader_notes
    from ..io.measurement_files import MeasurementFileError, read_measurements

    paths = [path] if isinstance(path, Path) else list(path)
    for p in paths:
        if not p.exists():
            raise fail(f"{p}: no such file")
        if p.is_dir():
            raise fail(f"{p}: is a folder, not a measurement file")
    options = {k: v for k, v in options.items() if v is not None}
    kinds = parse_kinds(options.pop("kinds", None))
    options = log_options(paths, options, kinds)
    if "bearing_sigma" in options:  # --bearing-sigma is in degrees
        options["bearing_sigma_deg"] = options.pop("bearing_sigma")
    try:
        meas = read_measurements(paths[0] if len(paths) == 1 else paths, origin=origin,
                                 **options)
    except OSError as e:
        raise fail(f"{e.filename or paths[0]}: cannot be read ({e.strerror or e})") from None
    except (MeasurementFileError, ValueError) as e:
        from ..io.positions import ORIGIN_HINT

        raise fail(str(e).replace(ORIGIN_HINT, "--origin LAT,LON,ALT")) from None
    for note in reader_notes(meas.metadata, pop=True):
        if notes:
            err.print(note, highlight=False, markup=False, soft_wrap=True)
    if origin is not None and "origin_lat" not in meas.metadata:
        err.print(f"warning: --origin is for files with sensor_lat/sensor_lon; {paths[0].name} "
                  "gives ENU positions, so it is not used", highlight=False)
    return only_kinds(meas, kinds, paths)


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
    try:
        fmt = find_format(path, options.get("format"), reading=True)
    except ValueError as e:
        raise fail(f"--format: {e}") from None
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
