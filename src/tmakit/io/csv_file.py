"""The CSV measurement file: ``# key: value`` metadata lines, a header, one row per value.

Reading keeps every cell as text (the checker turns them into numbers and names the line of
each problem); writing uses pandas' shortest round-trip floats, so files round-trip exactly.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..data import MeasurementSet
from .checker import table_reader
from .columns import file_columns
from .contract import COLUMN_ORDER, FORMAT_LINE, NUMERIC_COLUMNS
from .errors import MeasurementFileError
from .formats import Format, register_format
from .problems import RawTable
from .tables import write_table

#: The columns the reader uses; others are ignored (docs/file-format.md) and not even parsed,
#: so a header of 200,000 columns costs little.
READ_COLUMNS = frozenset(("sensor", "kind", *NUMERIC_COLUMNS))

__all__ = ["CSV", "csv_metadata_line", "load_csv", "read_csv", "write_csv"]


def _split_metadata(text: str) -> tuple[dict[str, str], int, int]:
    """Split off the leading '# key: value' comment lines (and blank lines) of a CSV text.

    Returns the metadata, and the characters and the lines the comment lines take.
    """
    metadata: dict[str, str] = {}
    consumed = pre_lines = 0
    for line in io.StringIO(text, newline=""):
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            break
        consumed += len(line)
        pre_lines += 1
        if stripped.startswith("#"):
            key, sep, value = stripped[1:].partition(":")
            if sep and key.strip():
                metadata[key.strip()] = value.strip()
    return metadata, consumed, pre_lines


def _record_lines(path: Path, body: str, pre_lines: int) -> tuple[list[str], list[int]]:
    """Read the header names and the line of each data record.

    The csv module knows quoted fields that span lines.  A missing or bad header and
    unreadable or ragged records are refused (:class:`MeasurementFileError`).
    """
    reader = csv.reader(io.StringIO(body, newline=""))
    header = next(reader, None)
    if header is None:
        raise MeasurementFileError(path, [
            "the file has no header line; expected the columns "
            f"{', '.join(COLUMN_ORDER[:5])}, ..."])
    header_line = pre_lines + reader.line_num
    names = [h.strip() for h in header]
    seen: set[str] = set()  # linear in the columns (a list search would be quadratic)
    problems = []
    for name in names:
        if name in seen:
            problems.append(f"line {header_line}: column {name!r} appears more than once in "
                            "the header")
        seen.add(name)
    problems += [f"line {header_line}: column {i + 1} of the header has no name"
                 for i, name in enumerate(names) if not name]
    lines: list[int] = []
    while True:
        start = reader.line_num
        try:
            record = next(reader)
        except StopIteration:
            break
        except csv.Error as e:
            problems.append(f"line {pre_lines + start + 1}: cannot read the CSV record ({e})")
            break
        if not record:
            continue  # a blank line, skipped by pandas too
        lines.append(pre_lines + start + 1)
        if len(record) != len(header):
            problems.append(
                f"row {len(lines)} (line {lines[-1]}): expected {len(header)} fields (one per "
                f"header column), found {len(record)}")
    if problems:
        raise MeasurementFileError(path, problems)
    return names, lines


def load_csv(path: Path) -> RawTable:
    """Read a CSV measurement file as a raw table of text cells, with the line of each row.

    Parameters
    ----------
    path : pathlib.Path
        The file (UTF-8, with or without a byte-order mark).

    Returns
    -------
    RawTable
        Text cells, metadata from the leading ``# key: value`` lines, line numbers.

    Raises
    ------
    MeasurementFileError
        If the file is not UTF-8 text, has no header, or a record cannot be read.
    """
    import pandas as pd

    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise MeasurementFileError(path, [f"not a UTF-8 text file ({e})"]) from None
    metadata, consumed, pre_lines = _split_metadata(text)
    body = text[consumed:]
    names, lines = _record_lines(path, body, pre_lines)
    try:
        frame = pd.read_csv(io.StringIO(body), dtype=str, na_filter=False,
                            keep_default_na=False, index_col=False, skip_blank_lines=True,
                            usecols=lambda c: c.strip() in READ_COLUMNS)
    except (pd.errors.ParserError, ValueError) as e:
        raise MeasurementFileError(path, [f"cannot read the CSV table ({e})"]) from None
    frame.columns = [n for n in names if n in READ_COLUMNS]  # others are ignored: not read
    frame = frame.reset_index(drop=True)
    line_numbers = np.asarray(lines, dtype=np.int64) if len(lines) == len(frame) else None
    return RawTable(frame, metadata, line_numbers)


def csv_metadata_line(path: Path, key: str, value: str) -> str:
    """One metadata line ``# key: value`` (without its line end).

    Parameters
    ----------
    path : pathlib.Path
        The file being written (named in the error).
    key, value : str
        The metadata entry.

    Returns
    -------
    str
        The line.

    Raises
    ------
    ValueError
        If the key or value cannot be written on one comment line and read back equal.
    """
    if not key or key != key.strip() or any(ch in key for ch in ":\r\n"):
        raise ValueError(f"{path}: metadata key {key!r} cannot be written to a CSV comment "
                         "line (keys are non-empty, without ':', line breaks or surrounding "
                         "spaces)")
    if "\n" in value or "\r" in value:
        raise ValueError(f"{path}: metadata value of {key!r} contains a line break; CSV "
                         "metadata lines hold one line each")
    if value != value.strip():
        raise ValueError(f"{path}: metadata value of {key!r} has leading or trailing spaces, "
                         "which a CSV comment line does not keep")
    return f"# {key}: {value}" if value else f"# {key}:"


def write_csv(ms: MeasurementSet, path: Path, force: bool) -> None:
    """Write a set as a CSV measurement file, atomically (the :data:`CSV` format's writer).

    Parameters
    ----------
    ms : MeasurementSet
        The set (values in file units).
    path : pathlib.Path
        The file.
    force : bool
        Overwrite an existing file.

    Raises
    ------
    ValueError
        If a metadata entry cannot be written on a comment line.
    FileExistsError
        If ``path`` exists and not ``force``.
    """
    preamble = [FORMAT_LINE, *(csv_metadata_line(path, k, v) for k, v in ms.metadata.items())]
    write_table(path, file_columns(ms), format="csv", force=force, csv_preamble=preamble)


#: Read and check a CSV measurement file (the :data:`CSV` format's reader).
read_csv = table_reader(load_csv, "CSV")
#: The CSV format: ``.csv``.
CSV = register_format(Format("csv", "CSV", (".csv",), read_csv, write_csv))
