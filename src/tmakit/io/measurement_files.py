"""Measurement files read and written by their registered format (:mod:`tmakit.io.formats`)."""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path

from ..core.keywords import NOT_GIVEN, NotGiven, renamed_keyword
from ..data import MeasurementSet
from . import csv_file, debrief, parquet_file, wide_log  # noqa: F401  (register formats)
from .checker import COLUMN_ORDER, COLUMN_PURPOSE, FORMAT_LINE, PARQUET_METADATA_PREFIX
from .errors import MAX_LISTED_PROBLEMS, MeasurementFileError, refuse_unreadable
from .formats import Format, find_format, registered_formats, suffix_text

__all__ = [
    "COLUMN_ORDER",
    "COLUMN_PURPOSE",
    "FORMAT_LINE",
    "MAX_LISTED_PROBLEMS",
    "PARQUET_METADATA_PREFIX",
    "MeasurementFileError",
    "read_measurements",
    "write_measurements",
]


def read_measurements(path: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
                      origin: tuple[float, float, float] | None = None, *,
                      format: str | None = None, mapping: object = None,
                      measurements: str | os.PathLike[str] | None = None,
                      track: str | os.PathLike[str] | None = None, ownship: str | None = None,
                      contact: str | None = None,
                      bearing_sigma_deg: float | Mapping[str, float] | None = None,
                      range_sigma: float | None = None, frequency_sigma: float | None = None,
                      dim: int | None = None, ranges: str | None = None,
                      kinds: Collection[str] | None = None,
                      window: Sequence[str | None] | None = None,
                      bearing_sigma: float | NotGiven | None = NOT_GIVEN) -> MeasurementSet:
    """Read a measurement file into a MeasurementSet, by its format.

    Every cell is checked against the contract of ``docs/file-format.md``; all problems are reported
    together in one :class:`MeasurementFileError` naming row, line and column.

    Parameters
    ----------
    path : str or os.PathLike, or a sequence of them
        The file (``.csv``, ``.parquet`` or ``.pq``, or any registered format's suffix), or several
        files of a format whose reader reads them as one (Debrief replays).
    origin : (lat, lon, alt), optional
        ENU origin (degrees, degrees, metres) for files that give ``sensor_lat`` and ``sensor_lon``;
        it wins over ``origin_*`` metadata in the file and is recorded in the returned set's
        metadata.
    format : str, optional
        A registered format name ("csv", "parquet"); by default from the suffix of ``path``.
    mapping : LogMapping or str or os.PathLike, optional
        Wide logs, GPX and NMEA: the column mapping, or its TOML file
        (:func:`tmakit.io.wide_log.read_wide_log`).
    measurements : str or os.PathLike, optional
        GPX and NMEA own tracks: the wide log of measurements joined to the track.
    track : str or os.PathLike, optional
        Wide logs: a GPX or NMEA own track instead of the mapping's.
    ownship, contact : str, optional
        Debrief replays: the own ship's track name and the contact
        (:func:`tmakit.io.debrief.read_replay`).
    bearing_sigma_deg, range_sigma, frequency_sigma : float, optional
        Debrief replays: the noise of lines that state none (deg, m, Hz; as
        ``tma --bearing-sigma``); ``bearing_sigma_deg`` may map sensor names to their own
        (``{"HM": 0.5, "TA": 2.0}``: a hull and a towed array; the others 1 deg).
    dim : int, optional
        Real logs: 2 or 3, instead of the surface rule.
    ranges : {"use", "ignore"}, optional
        Debrief replays: fit every range, or none (default: placeholder ranges left out).
    kinds : collection of str, optional
        Debrief replays: keep only these kinds.
    window : (from, to), optional
        Debrief replays: keep only the cuts in this time window, before any other check.
    bearing_sigma : float, optional
        Deprecated: ``bearing_sigma_deg`` (the unit in the name; a warning).

    Returns
    -------
    MeasurementSet
        The rows, values in file units with their SI twins.

    Raises
    ------
    MeasurementFileError
        If the suffix names no readable format, or the file breaks the contract.
    FileNotFoundError
        If the file does not exist.
    ValueError
        If ``format`` names no registered format, or ``window`` ends before it starts or
        holds no cut.
    """
    bearing_sigma_deg = renamed_keyword("read_measurements", "bearing_sigma", bearing_sigma,
                                        "bearing_sigma_deg", bearing_sigma_deg, None)
    given = {k: v for k, v in (
        ("mapping", mapping), ("measurements", measurements), ("track", track),
        ("ownship", ownship), ("contact", contact), ("bearing_sigma", bearing_sigma_deg),
        ("range_sigma", range_sigma), ("frequency_sigma", frequency_sigma), ("dim", dim),
        ("ranges", ranges), ("kinds", kinds), ("window", window)) if v is not None}
    paths = [Path(path)] if isinstance(path, str | os.PathLike) else [Path(p) for p in path]
    if not paths:
        raise ValueError("read_measurements: no file given")
    return _read(paths, origin, format, given)


def _read(paths: list[Path], origin: tuple[float, float, float] | None, format: str | None,
          options: dict[str, object]) -> MeasurementSet:
    """Read one file by its format, or several as one where their format's reader takes them."""
    formats = {p: find_format(p, format, reading=True) for p in paths}
    fmt = formats[paths[0]]
    if len(paths) > 1 and (len({f.name if f else None for f in formats.values()}) != 1
                           or fmt is None or fmt.read is None or not fmt.several):
        listed = ", ".join(f"{p.name} ({f.label if f else 'unknown'})" for p, f in formats.items())
        raise MeasurementFileError(Path(" + ".join(map(str, paths))), [
            f"several files are read as one only for Debrief replays (.rep, .dsf); got {listed}"])
    if fmt is None or fmt.read is None:
        shown = f"'{paths[0].suffix}'" if paths[0].suffix else "no suffix"
        raise MeasurementFileError(paths[0], [
            f"unsupported file type ({shown}): measurement files end in "
            f"{suffix_text(registered_formats(reading=True))}"])
    for p in paths:
        if not p.exists():
            raise FileNotFoundError(f"{p}: no such file")
    if len(paths) == 1:  # a FIFO, a device, NUL bytes in a text format: at once (an NMEA
        # log's reader sniffs its own bytes: binary messages may lie between its sentences)
        refuse_unreadable(paths[0], binary=fmt.name in ("parquet", "nmea")
                          or paths[0].suffix.lower() in (".parquet", ".pq"))
    _refuse_foreign_options(fmt, options)
    return fmt.read(paths[0] if len(paths) == 1 else paths, origin=origin, **options)


class ForeignOptionError(TypeError):
    """A reader given options it does not take (``foreign``; it takes ``taken``)."""

    def __init__(self, label: str, foreign: list[str], taken: list[str]) -> None:
        self.label, self.foreign, self.taken = label, foreign, taken
        super().__init__(f"{label} files take no option {', '.join(foreign)} "
                         f"(they take {', '.join(taken) or 'none'})")


def _refuse_foreign_options(fmt: Format, options: dict[str, object]) -> None:
    """Refuse options the format's reader does not take, naming them and the ones it does."""
    foreign = sorted(set(options) - set(fmt.options))
    if foreign:
        shown = {"bearing_sigma": "bearing_sigma_deg"}
        raise ForeignOptionError(fmt.label, [shown.get(n, n) for n in foreign],
                                 [shown.get(n, n) for n in fmt.options])


def write_measurements(ms: MeasurementSet, path: str | os.PathLike[str],
                       force: bool = False, *, format: str | None = None) -> Path:
    """Write a MeasurementSet atomically in a registered format (by the suffix of ``path``).

    Parameters
    ----------
    ms : MeasurementSet
        The set.
    path : str or os.PathLike
        The file (``.csv``, ``.parquet`` or ``.pq``).
    force : bool, optional
        Overwrite an existing file (default: ``FileExistsError``).
    format : str, optional
        A registered format name; by default from the suffix of ``path``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If the suffix (or ``format``) names no writable format, or the metadata cannot be written in
        the format.
    FileExistsError
        If ``path`` exists and not ``force``.
    """
    path = Path(path)
    fmt = find_format(path, format, reading=False)
    if fmt is None or fmt.write is None:
        raise ValueError(
            f"{path}: cannot write measurements to a '{path.suffix}' file; the name must end "
            f"in {suffix_text(registered_formats(reading=False))}")
    fmt.write(ms, path, force)
    return path
