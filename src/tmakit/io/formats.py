"""The registry of measurement-file formats: each format's name, suffixes, reader, writer."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..data import MeasurementSet

__all__ = ["Format", "Reader", "Writer", "find_format", "register_format", "registered_formats",
           "suffix_text", "unregister_format"]

#: ``read(path, *, origin=None, **options) -> MeasurementSet``; raises
#: :class:`~tmakit.io.MeasurementFileError` for a file that breaks the format.
Reader = Callable[..., MeasurementSet]
#: ``write(ms, path, force) -> None``: writes ``path`` atomically, refusing an existing file
#: unless ``force``.
Writer = Callable[[MeasurementSet, Path, bool], None]


@dataclass(frozen=True)
class Format:
    """One measurement-file format.

    Parameters
    ----------
    name : str
        Registry key, as given to ``format=`` ("csv", "parquet").
    label : str
        Name for messages ("CSV", "Parquet").
    suffixes : tuple of str
        File suffixes, lower case with the dot (".csv").
    read : Reader, optional
        The reader; None for a format that is only written.
    write : Writer, optional
        The writer; None for a format that is only read (a navigation log).
    several : bool, optional
        The reader takes a sequence of files and reads them as one (Debrief replays: a
        sensor file and the own ship's track file).
    options : tuple of str, optional
        The keyword options the reader takes besides ``origin``; any other is refused by
        :func:`tmakit.io.read_measurements`, naming it and these.
    """

    name: str
    label: str
    suffixes: tuple[str, ...]
    read: Reader | None = None
    write: Writer | None = None
    several: bool = False
    options: tuple[str, ...] = ()


_FORMATS: dict[str, Format] = {}


def register_format(fmt: Format, replace: bool = False) -> Format:
    """Add a format to the registry (formats are tried in the order they were registered).

    Parameters
    ----------
    fmt : Format
        The format.
    replace : bool, optional
        Replace a format of the same name (default: refuse).

    Returns
    -------
    Format
        ``fmt``.

    Raises
    ------
    ValueError
        If the name is taken (and not ``replace``) or a suffix belongs to another format.
    """
    if fmt.name in _FORMATS and not replace:
        raise ValueError(f"a measurement file format named {fmt.name!r} is registered already")
    for other in _FORMATS.values():
        shared = set(other.suffixes) & set(fmt.suffixes)
        if other.name != fmt.name and shared:
            raise ValueError(f"suffix {', '.join(sorted(shared))} belongs to the format "
                             f"{other.name!r} already")
    _FORMATS[fmt.name] = fmt
    return fmt


def unregister_format(name: str) -> Format:
    """Remove a format from the registry.

    Parameters
    ----------
    name : str
        The format's name.

    Returns
    -------
    Format
        The removed format.

    Raises
    ------
    KeyError
        If no format has that name.
    """
    return _FORMATS.pop(name)


def registered_formats(reading: bool | None = None) -> tuple[Format, ...]:
    """Return the registered formats, in registration order.

    Parameters
    ----------
    reading : bool, optional
        True: only formats with a reader; False: only those with a writer; None: all.

    Returns
    -------
    tuple of Format
        The formats.
    """
    every = tuple(_FORMATS.values())
    if reading is None:
        return every
    return tuple(f for f in every if (f.read if reading else f.write) is not None)


def find_format(path: str | os.PathLike[str], name: str | None = None,
                reading: bool | None = None) -> Format | None:
    """Find the format called ``name``, else the one whose suffixes hold ``path``'s suffix.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    name : str, optional
        A format name; wins over the suffix.
    reading : bool, optional
        As in :func:`registered_formats`.

    Returns
    -------
    Format or None
        None if no (readable / writable) format matches.

    Raises
    ------
    ValueError
        If ``name`` is given but names no registered format.
    """
    candidates = registered_formats(reading)
    if name is not None:
        if name not in _FORMATS:
            raise ValueError(f"unknown measurement file format {name!r}; expected one of "
                             f"{', '.join(_FORMATS)}")
        return next((f for f in candidates if f.name == name), None)
    suffix = Path(path).suffix.lower()
    return next((f for f in candidates if suffix in f.suffixes), None)


def suffix_text(candidates: tuple[Format, ...]) -> str:
    """Name the suffixes and labels of formats for messages."""
    candidates = tuple(f for f in candidates if f.suffixes)  # "wide": read by name only
    suffixes = [s for f in candidates for s in f.suffixes]
    labels = [f.label for f in candidates]
    named = labels[0] if len(labels) == 1 else (
        f"{', '.join(labels[:-1])} or {labels[-1]}" if labels else "none")
    return f"{', '.join(suffixes)} ({named})"
