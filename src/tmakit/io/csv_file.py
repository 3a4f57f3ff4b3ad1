"""The CSV measurement file: ``# key: value`` metadata lines, a header, one row per value.

A valid file is streamed into the set's arrays (:func:`stream_csv`); any other is read as a table
of cells for the checker (:func:`load_csv`), which names every problem: the same set bit for bit.
"""

from __future__ import annotations

import codecs
import csv
import ctypes
import functools
import io
import re
from array import array
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import rules
from ..data import REF_STATE_COLUMNS, MeasurementSet
from ..measurements.codes import KIND_NAMES, kind_flags
from ..rules import broken_rows
from .checker import (
    COLUMN_ORDER,
    FORMAT_LINE,
    GEO_COLUMNS,
    NUMERIC_COLUMNS,
    QUERY_ROWS,
    Problems,
    RawTable,
    SensorRecord,
    case_problem,
    check_columns,
    check_table,
    file_columns,
    geodetic_to_enu_in_place,
    kind_code_table,
    reference_problems,
    resolve_origin,
)
from .errors import MeasurementFileError
from .formats import Format, register_format
from .tables import write_table

__all__ = ["BLOCK_BYTES", "CSV", "SET_BYTES_PER_ROW", "csv_metadata_line", "load_csv",
           "read_csv", "stream_csv", "write_csv"]

#: The columns the reader uses; others are ignored (docs/file-format.md) and not even parsed,
#: so a header of 200,000 columns costs little.
READ_COLUMNS = frozenset(("sensor", "kind", "ref_sensor", "tonal", *NUMERIC_COLUMNS))
#: Bytes of the file searched for the ``# key: value`` preamble before the whole file.
_PREAMBLE_SCAN = 1 << 20

#: Bytes of CSV text parsed at a time (pyarrow reads about 32 blocks ahead: this bounds that
#: queue's memory; ``tests/test_stream_readahead.py``).
BLOCK_BYTES = 1 << 20
#: Bytes per row of a streamed set: time, value, sigma and their SI twins (8 each), the
#: sensor state (48), the sensor code (4) and the kind code (1); without range differences
#: ``time_ref`` and the reference state are all-NaN views that take no memory.
SET_BYTES_PER_ROW = 93
#: Column of the sensor state each numeric column is stored in (latitude, longitude and
#: altitude are held in the position's place until converted to ENU).
_STATE_COLUMN = {"sensor_x": 0, "sensor_y": 1, "sensor_z": 2, "sensor_vx": 3, "sensor_vy": 4,
                 "sensor_vz": 5, "sensor_lat": 0, "sensor_lon": 1, "sensor_alt": 2}
#: Columns of range differences (empty on other rows).
_REFERENCE = ("time_ref", *REF_STATE_COLUMNS)
_USES_REFERENCE, _BETWEEN_SENSORS = kind_flags("uses_reference"), kind_flags("between_sensors")
#: A line as ``io.StringIO(text, newline="")`` splits them: ended by "\r\n", "\r" or "\n".
_LINE = re.compile(r"[^\r\n]*(?:\r\n|\r|\n)|[^\r\n]+")


def split_metadata(text: str) -> tuple[dict[str, str], int, int]:
    """Split off the leading ``# key: value`` comment lines (and blank lines) of a CSV text."""
    metadata: dict[str, str] = {}
    consumed = pre_lines = 0
    for match in _LINE.finditer(text):  # (an io.StringIO would copy the whole text first)
        line = match.group()
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


def _text(data: bytes, complete: bool) -> str | None:
    """Decode UTF-8 without a BOM (None if not UTF-8; unless complete, a cut last character)."""
    try:
        return codecs.getincrementaldecoder("utf-8-sig")().decode(data, final=complete)
    except UnicodeDecodeError:
        return None


def _preamble(data: bytes, complete: bool) -> tuple[dict[str, str], int, int] | None:
    """Split the ``# key: value`` lines off the start of a file: metadata, header byte, lines."""
    text = _text(data, complete)
    if text is None:
        return None
    metadata, consumed, lines = split_metadata(text)
    if consumed >= len(text) and not complete:
        return None
    bom = 3 if data.startswith(codecs.BOM_UTF8) else 0
    return metadata, bom + len(text[:consumed].encode("utf-8")), lines


def _record_lines(path: Path, body: bytes, pre_lines: int
                  ) -> tuple[list[str], list[str], NDArray[np.int64]]:
    """Read the header names (stripped, and as written) and the line of each data record."""
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
    return (_checked_header(path, header, header_line, problems), header,
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
    problems += [f"line {header_line}: column {i + 1} of the header has no name" + (
                 " (pandas writes its index there: to_csv(..., index=False) leaves it out)"
                 if i == 0 else "") for i, name in enumerate(names) if not name]
    problems += record_problems
    if problems:
        raise MeasurementFileError(path, problems)
    return names


def _give_back() -> None:
    """Return the memory of dropped blocks to the system (pyarrow's pool and the C library's)."""
    import pyarrow as pa

    pa.default_memory_pool().release_unused()
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim() -> Any:
    """Find the C library's ``malloc_trim(pad)`` (glibc); None where there is none."""
    try:
        return ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError):
        return None


def _with_nan(col: Any) -> NDArray[np.float64]:
    """Return a pyarrow float64 array as numpy, NaN where null (a view when it has none)."""
    values = _numbers(col, np.float64)
    if not col.null_count:
        return values
    bits = np.frombuffer(col.buffers()[0], dtype=np.uint8)
    valid = np.unpackbits(bits, bitorder="little")[col.offset:col.offset + len(col)]
    return np.where(valid.view(bool), values, np.nan)


def _numbers(col: Any, dtype: type) -> NDArray[Any]:
    """View a pyarrow array of fixed-width numbers without nulls as numpy (read-only)."""
    return np.frombuffer(col.buffers()[1], dtype=dtype, count=len(col),
                         offset=col.offset * np.dtype(dtype).itemsize)


class _Fallback(Exception):
    """The file is not for the stream: the full checker reads it."""


def _stream_header(path: Path, start: int) -> list[str] | None:
    """Return the header names as written (from byte ``start``), None if not streamable."""
    with open(path, "rb") as f:
        f.seek(start)
        text = io.TextIOWrapper(f, encoding="utf-8", newline="")
        try:
            names = next(csv.reader(text), None)
        except (UnicodeDecodeError, csv.Error):
            return None
    if not names or any("\n" in n or "\r" in n for n in names):
        return None
    try:
        stripped = _checked_header(path, names, 0, [])  # no column twice, none unnamed
    except MeasurementFileError:
        return None
    problems = Problems(RawTable(None, {}, None))
    check_columns(stripped, [], problems)  # (the kinds' own needs are checked once read)
    if (problems.file or case_problem(stripped) or "ref_sensor" in stripped
            or "carrier" in stripped  # the checker's
            or (any(c in stripped for c in REF_STATE_COLUMNS) and "time_ref" not in stripped)):
        return None
    return names


class _Columns:
    """The set's arrays, filled block by block (grown in place when the estimate is short)."""

    def __init__(self, rows: int) -> None:
        self.n = 0
        self.num = {c: np.zeros(rows) for c in ("time", "value", "sigma")}
        self.state = np.zeros((rows, 6))
        self.sensor = np.zeros(rows, dtype=np.int32)
        self.kind = np.zeros(rows, dtype=np.int8)
        self.sensor_names: dict[str, int] = {}
        # range differences: allocated at the first cell given (NaN for empty cells)
        self.time_ref: NDArray[np.float64] | None = None
        self.ref: NDArray[np.float64] | None = None
        self.ref_columns: list[int] = []
        self.has_time_ref = False

    def resize(self, size: int) -> None:
        """Give every per-row array ``size`` rows, in place."""
        for a in (*self.num.values(), self.sensor, self.kind, self.time_ref):
            if a is not None:
                a.resize(size, refcheck=False)
        for b in (self.state, self.ref):
            if b is not None:
                b.resize((size, 6), refcheck=False)

    def reserve(self, rows: int) -> None:
        """Make room for ``rows`` more rows (grown by a quarter at least)."""
        if self.n + rows > self.kind.shape[0]:
            self.resize(max(self.n + rows, int(self.kind.shape[0] * 1.25)))

    def put_reference(self, name: str, values: NDArray[np.float64]) -> None:
        """Store a block of ``time_ref`` or a ``ref_sensor_*`` column (NaN for empty)."""
        lo, hi = self.n, self.n + values.shape[0]
        if name == "time_ref":
            self.has_time_ref = True
            if self.time_ref is None and np.isnan(values).all():
                return
            if self.time_ref is None:  # the first one given: the rows before had none
                self.time_ref = np.full(self.kind.shape[0], np.nan)
            self.time_ref[lo:hi] = values
            return
        i = REF_STATE_COLUMNS.index(name)
        if i not in self.ref_columns:
            self.ref_columns.append(i)
        if self.ref is None and np.isnan(values).all():
            return
        if self.ref is None:
            self.ref = np.full((self.kind.shape[0], 6), np.nan)
        self.ref[lo:hi, i] = values

    def block_is_valid(self, k: int) -> bool:
        """Check the range-difference cells of the block of ``k`` rows just stored."""
        lo, hi = self.n, self.n + k
        kind = self.kind[lo:hi]
        is_rd = _USES_REFERENCE[kind]
        if self.time_ref is None and self.ref is None and not is_rd.any():
            return True  # each rule of these cells reads a range difference or a given cell
        between = _BETWEEN_SENSORS[kind]
        if not self.ref_columns and between.any():  # tdoa, fdoa: no reference state
            return False
        nan = np.broadcast_to(np.float64(np.nan), (k,))  # (no cell given yet)
        time_ref = (None if not self.has_time_ref else
                    nan if self.time_ref is None else self.time_ref[lo:hi])
        ref = {REF_STATE_COLUMNS[i]: nan if self.ref is None else self.ref[lo:hi, i]
               for i in self.ref_columns}
        return not any(np.any(bad) for _, bad, _ in reference_problems(
            self.num["time"][lo:hi], time_ref, lambda row: KIND_NAMES[kind[row]], is_rd,
            between, ref))

    def put_number(self, name: str, values: NDArray[np.float64]) -> None:
        """Store a block of a numeric column (geodetic cells checked now: the set holds ENU)."""
        if name in GEO_COLUMNS and any(rows.shape[0] for _, rows in broken_rows({name: values})):
            raise _Fallback
        lo, hi = self.n, self.n + values.shape[0]
        if name in self.num:
            self.num[name][lo:hi] = values
        else:
            self.state[lo:hi, _STATE_COLUMN[name]] = values

    def put_kind(self, indices: NDArray[np.integer], names: list[str]) -> None:
        """Store a block of kind codes from its dictionary (known kinds only)."""
        table = kind_code_table(names)
        if np.any(table < 0):
            raise _Fallback
        _store_codes(self.kind[self.n:self.n + indices.shape[0]], table, indices)

    def put_sensor(self, indices: NDArray[np.integer], names: list[str]) -> None:
        """Store a block of sensor codes, new ids numbered in order of first appearance."""
        table = np.array([self.sensor_names.get(name, -1) for name in names], dtype=np.int32)
        if np.any(table < 0):  # a sensor no earlier block named
            present, first = np.unique(indices, return_index=True)
            for i in present[np.argsort(first, kind="stable")].tolist():
                name = names[i]
                if not name.strip():
                    raise _Fallback
                table[i] = self.sensor_names.setdefault(name, len(self.sensor_names))
        _store_codes(self.sensor[self.n:self.n + indices.shape[0]], table, indices)


def _store_codes(out: NDArray[np.integer], table: NDArray[np.integer],
                 indices: NDArray[np.integer]) -> None:
    """Store ``table[indices]`` in ``out`` (a dictionary of one word: its code in every row)."""
    if table.shape[0] == 1:
        out[:] = table[0]
    else:
        np.take(table, indices, out=out)


def _read_blocks(path: Path, start: int, names: list[str]) -> _Columns:
    """Parse the file's records block by block into :class:`_Columns`."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    text_type = pa.dictionary(pa.int32(), pa.string())
    read, parse, convert = _parse_options(
        names, lambda c: text_type if c in ("sensor", "kind") else pa.float64(), stream=True)
    cols: _Columns | None = None
    # the C library's allocator: the blocks are given back with the rules' arrays (_give_back)
    pool = pa.system_memory_pool()
    with pa.OSFile(str(path), memory_pool=pool) as f:
        f.seek(start)
        reader = pcsv.open_csv(f, read_options=read, parse_options=parse,
                               convert_options=convert, memory_pool=pool)
        for batch in reader:
            k = batch.num_rows
            if cols is None:  # the rows per byte of the first block, 5 % spare
                left = max(1, path.stat().st_size - start)
                cols = _Columns(max(k, int(1.05 * k * left / min(left, BLOCK_BYTES))))
            cols.reserve(k)
            for name, col in zip(batch.schema.names, batch.columns, strict=True):
                _put(cols, name.strip(), col)
            if not cols.block_is_valid(k):
                raise _Fallback
            cols.n += k
            del batch
    _give_back()  # (the freed blocks are reused while reading: no trim between them)
    if cols is None or cols.n == 0:
        raise _Fallback
    cols.resize(cols.n)  # the spare rows dropped
    return cols


def _put(cols: _Columns, name: str, col: Any) -> None:
    """Store one block of one column."""
    if name in _REFERENCE:  # empty cells are NaN
        values = _with_nan(col)
        if np.count_nonzero(np.isnan(values)) != col.null_count:  # a cell "nan"
            raise _Fallback
        cols.put_reference(name, values)
        return
    if col.null_count:
        raise _Fallback
    if name in ("sensor", "kind"):
        indices = _numbers(col.indices, np.int32)
        put: Callable[[NDArray[np.integer], list[str]], None] = (
            cols.put_sensor if name == "sensor" else cols.put_kind)
        put(indices, col.dictionary.to_pylist())
    else:
        cols.put_number(name, _numbers(col, np.float64))


def _build(cols: _Columns, metadata: dict[str, str],
           ref: NDArray[np.float64] | None = None) -> MeasurementSet:
    """Make the checked set of the streamed columns (as :meth:`MeasurementSet.take` builds)."""
    n = cols.n
    out = object.__new__(MeasurementSet)
    out.time, out.sensor_state = cols.num["time"], cols.state
    out.kind_code, out.sensor_code = cols.kind, cols.sensor
    out.sensor_names = tuple(cols.sensor_names)
    nan = np.float64(np.nan)  # without range differences: views of one NaN
    out.time_ref = (np.broadcast_to(nan, (n,)) if ref is None or cols.time_ref is None
                    else cols.time_ref)
    out.ref_sensor_state = np.broadcast_to(nan, (n, 6)) if ref is None else ref
    out.metadata = dict(metadata)
    out._kind = out._sensor = out._kinds = None
    out._sensors = out.sensor_names
    out._set_file_values(cols.num["value"], cols.num["sigma"])
    rules.check_set(out)
    return out


def stream_csv(path: Path, scan: int = 1 << 20,
               origin: tuple[float, float, float] | None = None) -> MeasurementSet | None:
    """Read a valid CSV measurement file in bounded memory."""
    with open(path, "rb") as f:
        first = min(scan, 1 << 16)
        head = f.read(first)  # a preamble is a few lines: 64 KiB first
        found = _preamble(head, complete=len(head) < first)
        unread = len(head) == first < scan  # bytes of the scan not decoded yet
        if found is None and unread:
            head += f.read(scan - len(head))
            found, unread = _preamble(head, complete=len(head) < scan), False
    if found is None:
        return None
    metadata, start, _ = found
    names = _stream_header(path, start)
    if names is None:
        return None
    stripped = {n.strip() for n in names}
    if unread and not READ_COLUMNS.issuperset(stripped):  # cells the stream does not read:
        with open(path, "rb") as f:  # decoded in the scan, as the full checker decodes them
            head = f.read(scan)
        if _text(head, complete=len(head) < scan) is None:
            return None
    if "tonal" in stripped:  # (tonals: the full reader)
        return None
    enu_origin: tuple[float, float, float] | None = None
    if "sensor_lat" in stripped:  # the ENU origin as the full reader picks it
        problems = Problems(RawTable(None, metadata, None))
        enu_origin, origin_metadata = resolve_origin(origin, metadata, problems)
        if enu_origin is None or problems.file:
            return None
        metadata = {**metadata, **origin_metadata}
    try:
        cols = _read_blocks(path, start, names)
        present = np.bincount(cols.kind, minlength=len(KIND_NAMES)) > 0
        problems = Problems(RawTable(None, {}, None))  # the columns the kinds read
        check_columns(stripped, [k for k, p in zip(KIND_NAMES, present, strict=True) if p],
                      problems)
        if problems.file:
            return None
        if enu_origin is not None:
            if "sensor_alt" not in stripped:  # as the full reader: the origin's altitude
                cols.state[:, 2] = enu_origin[2]
            rule = geodetic_to_enu_in_place(cols.state, enu_origin,
                                            metadata.get("dim", "").strip() == "3")
            if rule:
                metadata["dim_rule"] = rule
        meas = _build(cols, metadata, _reference_states(cols, "sensor_vx" in stripped))
    except (_Fallback, ValueError):  # pyarrow's ArrowInvalid is a ValueError
        return None
    # the rules' arrays came from the C library's heap and stay resident until given back
    _give_back()
    return meas


def _reference_states(cols: _Columns, has_velocity: bool) -> NDArray[np.float64] | None:
    """Each row's sensor state at ``time_ref`` ``(n, 6)``, NaN on other kinds; None without any."""
    if cols.time_ref is None:
        return None
    time, time_ref, kind, sensor, n = (cols.num["time"], cols.time_ref, cols.kind, cols.sensor,
                                       cols.n)
    names = len(cols.sensor_names)
    ref = np.full((n, 6), np.nan) if cols.ref is None else cols.ref
    absent = [i for i in range(2, len(REF_STATE_COLUMNS)) if i not in cols.ref_columns]
    counts = np.zeros(names, dtype=np.int64)
    for lo in range(0, n, QUERY_ROWS):  # block by block: no temporary of every row
        block = ref[lo:lo + QUERY_ROWS]
        given = ~np.isnan(block[:, 0])
        for i in absent:
            block[given, i] = 0.0
        counts += np.bincount(sensor[lo:lo + QUERY_ROWS][_need(kind, ref, lo)], minlength=names)
    for code in np.flatnonzero(counts).tolist():
        mine = None if names == 1 else np.flatnonzero(sensor == code)
        record = SensorRecord(time, cols.state, mine, has_velocity)
        for lo in range(0, n, QUERY_ROWS):
            need = _need(kind, ref, lo)
            if names > 1:
                need &= sensor[lo:lo + QUERY_ROWS] == code
            if np.any(record.fill(lo + np.flatnonzero(need), time_ref, ref)):
                raise _Fallback
    return ref


def _need(kind: NDArray[np.int8], ref: NDArray[np.float64], lo: int) -> NDArray[np.bool_]:
    """Flag the range differences without ``ref_sensor_*`` cells of a block from row ``lo``."""
    hi = lo + QUERY_ROWS
    return (_USES_REFERENCE[kind[lo:hi]] & ~_BETWEEN_SENSORS[kind[lo:hi]] & np.isnan(ref[lo:hi, 0]))


def _parse_options(names: list[str], types: Callable[[str], Any], *,
                   stream: bool) -> tuple[Any, Any, Any]:
    """Make pyarrow's read, parse and convert options for the columns the reader uses."""
    import pyarrow.csv as pcsv

    used = [n for n in names if n.strip() in READ_COLUMNS]
    convert = pcsv.ConvertOptions(column_types={n: types(n.strip()) for n in used},
                                  include_columns=used, null_values=[""] if stream else [],
                                  strings_can_be_null=False, quoted_strings_can_be_null=False)
    read = pcsv.ReadOptions(block_size=BLOCK_BYTES, use_threads=not stream)
    return read, pcsv.ParseOptions(newlines_in_values=not stream), convert


def _read_table(body: bytes, names: list[str], as_text: bool) -> Any:
    """Read the columns the reader uses as a pandas frame of cells."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    def read(types: Callable[[str], Any]) -> Any:
        options = _parse_options(names, types, stream=False)
        return pcsv.read_csv(pa.BufferReader(body), read_options=options[0],
                             parse_options=options[1], convert_options=options[2])

    numeric = [n for n in names if n.strip() in NUMERIC_COLUMNS]
    if not as_text and numeric:
        try:
            table = read(lambda c: pa.float64() if c in NUMERIC_COLUMNS else pa.string())
        except pa.ArrowInvalid:
            table = None
        if table is not None and all(
                np.isfinite(_numbers(chunk, np.float64)).all()
                for n in numeric for chunk in table.column(n).chunks):
            return table.to_pandas(split_blocks=True, self_destruct=True)
        del table
    # each column freed as it is converted: the Arrow table and the frame are not both held
    return read(lambda c: pa.string()).to_pandas(split_blocks=True, self_destruct=True)


def load_csv(path: Path, as_text: bool = False) -> RawTable:
    """Read a CSV measurement file as a raw table of cells, with the line of each row."""
    import pyarrow as pa

    with open(path, "rb") as f:
        data = f.read()
    try:
        data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasurementFileError(path, [f"not a UTF-8 text file ({e})"]) from None
    found = (_preamble(data[:_PREAMBLE_SCAN], complete=len(data) <= _PREAMBLE_SCAN)
             or _preamble(data, complete=True))
    assert found is not None  # UTF-8 and complete: always split
    metadata, start, pre_lines = found
    body = data[start:] if start else data
    del data
    end = len(body)
    while end and body[end - 1:end].isspace():  # (the trailing blanks only: no copy of a
        end -= 1                                  # file that ends as files do)
    if body[end:] not in (b"", b"\n", b"\r\n"):  # trailing lines of spaces are blank lines,
        body = body[:end] + b"\n"                 # as empty ones are (not one-field records)
    names, raw_names, lines = _record_lines(path, body, pre_lines)
    if (cased := case_problem(names)) is not None:
        raise MeasurementFileError(path, [cased])
    try:
        frame = _read_table(body, raw_names, as_text)
    except (pa.ArrowException, ValueError) as e:
        raise MeasurementFileError(path, [f"cannot read the CSV table ({e})"]) from None
    kept = [n for n in names if n in READ_COLUMNS]  # others are ignored: not read
    if not kept:  # pyarrow reads every column when it is asked for none
        frame = frame.iloc[:, :0]
    frame.columns = kept
    line_numbers = lines if len(lines) == len(frame) else None
    return RawTable(frame, metadata, line_numbers)


def csv_metadata_line(path: Path, key: str, value: str) -> str:
    """One metadata line ``# key: value`` (without its line end)."""
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
    """Write a set as a CSV measurement file, atomically (the :data:`CSV` format's writer)."""
    preamble = [FORMAT_LINE, *(csv_metadata_line(path, k, v) for k, v in ms.metadata.items())]
    write_table(path, file_columns(ms), format="csv", force=force, csv_preamble=preamble)


def read_csv(path: Path, *, origin: tuple[float, float, float] | None = None
             ) -> MeasurementSet:
    """Read and check a CSV measurement file (the :data:`CSV` format's reader)."""
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
