"""The CSV measurement file: ``# key: value`` metadata lines, a header, one row per value.

Reading parses numbers as float64 when every cell is a finite number, else keeps every cell
as text (the checker turns them into numbers and names the line of each problem); writing
uses pandas' shortest round-trip floats, so files round-trip exactly.
"""

from __future__ import annotations

import codecs
import csv
import io
from array import array
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet
from .checker import check_table
from .columns import file_columns
from .contract import COLUMN_ORDER, FORMAT_LINE, NUMERIC_COLUMNS
from .csv_stream import split_metadata, stream_csv
from .errors import MeasurementFileError
from .formats import Format, register_format
from .problems import RawTable
from .tables import write_table

#: The columns the reader uses; others are ignored (docs/file-format.md) and not even parsed,
#: so a header of 200,000 columns costs little.
READ_COLUMNS = frozenset(("sensor", "kind", *NUMERIC_COLUMNS))

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

#: Characters of the file searched for the ``# key: value`` preamble before the whole text.
_PREAMBLE_SCAN = 1 << 20

__all__ = ["CSV", "csv_metadata_line", "load_csv", "read_csv", "write_csv"]


def _record_lines(path: Path, body: bytes, pre_lines: int) -> tuple[list[str], NDArray[np.int64]]:
    """Read the header names and the line of each data record.

    The csv module knows quoted fields that span lines; the body is decoded line by line
    (never held as one str).  A body without quotes, carriage returns or NUL bytes (what
    tmakit writes) has one record per line: it is split with NumPy instead
    (:func:`_plain_records`, the same names, lines and problems).  A missing or bad header
    and unreadable or ragged records are refused (:class:`MeasurementFileError`).
    """
    plain = _plain_records(body, pre_lines)
    if plain is not None:
        header, header_line, lines, problems = plain
        return _checked_header(path, header, header_line, problems), lines
    reader = csv.reader(io.TextIOWrapper(io.BytesIO(body), encoding="utf-8", newline=""))
    first: list[str] | None = next(reader, None)
    if first is None:
        raise MeasurementFileError(path, [
            "the file has no header line; expected the columns "
            f"{', '.join(COLUMN_ORDER[:5])}, ..."])
    header, header_line = first, pre_lines + reader.line_num
    problems = []
    line_numbers = array("q")  # 8 bytes per row (a list of ints takes 36)
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
        line_numbers.append(pre_lines + start + 1)
        if len(record) != len(header):
            problems.append(
                f"row {len(line_numbers)} (line {line_numbers[-1]}): expected {len(header)} "
                f"fields (one per header column), found {len(record)}")
    return (_checked_header(path, header, header_line, problems),
            np.frombuffer(line_numbers, dtype=np.int64))


def _checked_header(path: Path, header: list[str], header_line: int,
                    record_problems: list[str]) -> list[str]:
    """Return the stripped header names; refuse duplicates, unnamed columns, bad records."""
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
    problems += record_problems
    if problems:
        raise MeasurementFileError(path, problems)
    return names


#: Bytes of the body scanned at a time by :func:`_plain_records` (bounds its temporaries).
_SCAN_BYTES = 1 << 22


def _plain_records(body: bytes, pre_lines: int
                   ) -> tuple[list[str], int, NDArray[np.int64], list[str]] | None:
    """Split a body without quotes, carriage returns or NUL bytes into its records, in NumPy.

    Each line is then one record of ``commas + 1`` fields and an empty line is skipped, as
    the csv module reads it.  Returns the header fields, the header's line, each record's
    line and the ragged-record problems; None when the body needs the csv module (quotes,
    carriage returns, NUL, an empty first line, a line longer than the csv module's field limit).
    """
    if not body or b'"' in body or b"\r" in body or b"\0" in body:
        return None
    arr = np.frombuffer(body, dtype=np.uint8)
    n = arr.size
    ends = np.concatenate([np.flatnonzero(arr[lo:lo + _SCAN_BYTES] == 10) + lo
                           for lo in range(0, n, _SCAN_BYTES)])
    if ends.size == 0 or ends[-1] != n - 1:
        ends = np.append(ends, n)  # the last line has no line end
    starts = np.concatenate([[0], ends[:-1] + 1])
    length = ends - starts
    if length[0] == 0 or length.max() > csv.field_size_limit():
        return None
    commas = np.empty(starts.size, dtype=np.int64)
    cuts = np.unique(np.searchsorted(starts, np.arange(0, n, _SCAN_BYTES)))
    cuts = cuts[cuts < starts.size].tolist()
    for i0, i1 in zip(cuts, [*cuts[1:], starts.size], strict=True):
        lo, hi = int(starts[i0]), int(ends[i1 - 1]) + 1  # whole lines, line ends included
        seg = (arr[lo:hi] == 44).view(np.uint8)  # the commas
        commas[i0:i1] = np.add.reduceat(seg, starts[i0:i1] - lo, dtype=np.int64)
    header = body[:int(ends[0])].decode("utf-8").split(",")
    kept = np.flatnonzero(length[1:] > 0) + 1  # a blank line is skipped, as pandas does
    lines = pre_lines + kept + 1
    fields = commas[kept] + 1
    problems = [f"row {r + 1} (line {lines[r]}): expected {len(header)} fields (one per header "
                f"column), found {fields[r]}"
                for r in np.flatnonzero(fields != len(header)).tolist()]
    return header, pre_lines + 1, lines.astype(np.int64), problems


def _read_frame(body: bytes, names: list[str], as_text: bool) -> pd.DataFrame:
    """Read the columns the reader uses: numbers as float64 when every cell is a finite number.

    A text cell costs about 60 bytes, a float64 8; so unless ``as_text``, numeric columns are
    parsed as float64 (pandas reads round-trip text exactly), and only if a cell is not a
    finite number (an empty cell, ``nan``, a word) is the table read as text.
    """
    import pandas as pd

    used = [n for n in names if n in READ_COLUMNS]
    options: dict[str, Any] = {"na_filter": False, "keep_default_na": False,
                               "index_col": False, "skip_blank_lines": True,
                               "usecols": lambda c: c.strip() in READ_COLUMNS}
    numeric = {c for c in used if c in NUMERIC_COLUMNS}
    if not as_text and len(set(used)) == len(used) and numeric:
        dtypes = {c: (np.float64 if c.strip() in numeric else str)
                  for c in _raw_header(body) if c.strip() in READ_COLUMNS}
        try:
            frame = pd.read_csv(io.BytesIO(body), dtype=dtypes,
                                **options)
        except (pd.errors.ParserError, ValueError, TypeError):
            frame = None
        cols = [] if frame is None else [c for c in frame.columns if c.strip() in numeric]
        if frame is not None and all(frame[c].dtype == np.float64 for c in cols) and all(
                np.isfinite(frame[c].to_numpy()).all() for c in cols):
            return frame
        del frame
    return pd.read_csv(io.BytesIO(body), dtype=str, **options)


def _raw_header(body: bytes) -> list[str]:
    """Return the header names as written (not stripped), as pandas will see them."""
    first = io.TextIOWrapper(io.BytesIO(body), encoding="utf-8", newline="")
    return next(csv.reader(first), [])


def load_csv(path: Path, as_text: bool = False) -> RawTable:
    """Read a CSV measurement file as a raw table of cells, with the line of each row.

    Numeric columns are read as float64 when all their cells are finite numbers (exactly
    as Python's ``float`` reads them), else (or if ``as_text``) every cell is kept as text.
    Memory: the file's bytes once, plus about 8 bytes per numeric column and row, 8 bytes
    per row for the line numbers and 8 per text column and row (repeated sensor ids and
    kinds are shared).

    Parameters
    ----------
    path : pathlib.Path
        The file (UTF-8, with or without a byte-order mark).
    as_text : bool
        Keep every cell as text (as written), for messages that quote cells.

    Returns
    -------
    RawTable
        Cells, metadata from the leading ``# key: value`` lines, line numbers.

    Raises
    ------
    MeasurementFileError
        If the file is not UTF-8 text, has no header, or a record cannot be read.
    """
    import pandas as pd

    with open(path, "rb") as f:
        data = f.read()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasurementFileError(path, [f"not a UTF-8 text file ({e})"]) from None
    metadata, consumed, pre_lines = split_metadata(text[:_PREAMBLE_SCAN]
                                                    if len(text) > _PREAMBLE_SCAN else text)
    if consumed == _PREAMBLE_SCAN:  # a preamble longer than the scan: read it all
        metadata, consumed, pre_lines = split_metadata(text)
    start = len(text[:consumed].encode("utf-8")) + (3 if data.startswith(codecs.BOM_UTF8)
                                                     else 0)
    del text
    body = data[start:] if start else data
    del data
    names, lines = _record_lines(path, body, pre_lines)
    try:
        frame = _read_frame(body, names, as_text)
    except (pd.errors.ParserError, ValueError) as e:
        raise MeasurementFileError(path, [f"cannot read the CSV table ({e})"]) from None
    frame.columns = [n for n in names if n in READ_COLUMNS]  # others are ignored: not read
    frame = frame.reset_index(drop=True)
    line_numbers = lines if len(lines) == len(frame) else None
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


def read_csv(path: Path, *, origin: tuple[float, float, float] | None = None,
             **options: Any) -> MeasurementSet:
    """Read and check a CSV measurement file (the :data:`CSV` format's reader).

    The file is read with numbers as float64 (:func:`load_csv`); if the checker finds a
    problem, it is read again with every cell as text and checked again, so each message
    quotes the cells as written.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    origin : (lat, lon, alt), optional
        ENU origin (degrees, degrees, metres), as for :func:`~.checker.check_table`.
    **options
        None are taken; any is refused with a ``TypeError`` naming it.

    Returns
    -------
    MeasurementSet
        The rows in file order.

    Raises
    ------
    MeasurementFileError
        With every problem found (row, line and column of each).
    TypeError
        When given reader options (tmakit's own CSV files take none).
    """
    if options:
        raise TypeError(f"CSV files take no options {', '.join(sorted(options))}")
    streamed = stream_csv(path, _PREAMBLE_SCAN, origin)  # a valid file, bounded memory
    if streamed is not None:
        return streamed
    try:
        return check_table(path, load_csv(path), origin)
    except MeasurementFileError:
        pass  # read again as text, so the messages quote the cells as written
    return check_table(path, load_csv(path, as_text=True), origin)


#: The CSV format: ``.csv``.
CSV = register_format(Format("csv", "CSV", (".csv",), read_csv, write_csv))
