"""Stream a large, valid CSV measurement file into a set, block by block, in bounded memory.

The common case of a big file is a valid one, with ENU or latitude/longitude sensor
positions, with or without range differences.  :func:`stream_csv` reads such a file with
pyarrow's streaming CSV reader, :data:`BLOCK_BYTES` of text at a time, converting each block's
columns straight into the set's own arrays (float64 numbers; the kind and the sensor as small
integer codes with one table of names), so the file's text, an Arrow table of the whole file
or a text cell per row are never held.  The set is then checked by the one set of rules
(:mod:`tmakit.rules`: duplicate rows and far times too), as the reader does.

Latitude, longitude and altitude are held in the place of the ENU position while reading;
after the last block the surface rule is decided over every row's altitude and the positions
are converted to ENU in place, :data:`_ENU_ROWS` rows at a time, about the origin the full
reader takes (the ``origin`` argument, else the ``origin_*`` metadata), so the set and its
metadata (origin, ``dim_rule``) are those the full reader builds.

Range differences: ``time_ref`` and the ``ref_sensor_*`` cells are checked per block, and the
sensor states at ``time_ref`` found after the stream (:mod:`.stream_refs`).

Whatever the stream does not take (a problem in any cell, a missing column, a lat/lon file
without a known origin, a ragged or quoted-newline record, a long preamble) makes
:func:`stream_csv` return ``None``: the full checker (:func:`tmakit.io.checker.check_table`)
then reads the file and reports every problem by row, line and column.

Memory of a streamed read: the set's 93 bytes per row (:data:`SET_BYTES_PER_ROW`; 56 more
with range differences: ``time_ref`` and the reference state), plus up to 5 % spare rows
while reading, the blocks of text pyarrow reads ahead (its reader's input thread queues up to
about 32 blocks: ``32 * BLOCK_BYTES``, whatever the file's size) and one block's parsed columns,
and after reading the rules' transient arrays (about 30 bytes per row); the sensor states at
``time_ref`` are looked up a block of rows at a time (:mod:`.sensor_record`), adding only
their own 48 bytes per row.
"""

from __future__ import annotations

import codecs
import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS, MeasurementSet
from ..measurements import KINDS
from ..measurements.codes import KIND_CODES, KIND_NAMES
from ..rules import GEO_RANGES, geo_within
from .arrow_blocks import give_back, numbers, with_nan
from .contract import GEO_COLUMNS, NUMERIC_COLUMNS
from .positions import resolve_origin
from .problems import Problems, RawTable
from .stream_refs import block_is_valid, reference_states

__all__ = ["BLOCK_BYTES", "SET_BYTES_PER_ROW", "preamble", "split_metadata", "stream_csv"]

#: Bytes of CSV text parsed at a time.  pyarrow's streaming reader reads up to about 32
#: blocks ahead on its input thread (not an option of the reader): with 4 MiB blocks that
#: queue held 72 MB of a 60 MB file at once (all of it); 1 MiB blocks bound it at about
#: 37 MB (``tests/test_stream_readahead.py``).
BLOCK_BYTES = 1 << 20
#: Blocks between two returns of freed memory to the system
#: (:func:`~.arrow_blocks.give_back`): every 4 MiB of text (each return walks the heap: after
#: every 1 MiB block the read took 15 % longer).
_GIVE_BACK_EVERY = 4
#: Bytes per row of a streamed set: time, value, sigma and their SI twins (8 each), the
#: sensor state (48), the sensor code (4) and the kind code (1); without range differences
#: ``time_ref`` and the reference state are all-NaN views that take no memory.
SET_BYTES_PER_ROW = 93
#: Columns a streamed file must have, and those of its positions (ENU or geodetic).
_REQUIRED = ("time", "sensor", "kind", "value", "sigma")
_ENU_REQUIRED = ("sensor_x", "sensor_y")
_ENU_COLUMNS = ("sensor_x", "sensor_y", "sensor_z")
_GEO_REQUIRED = ("sensor_lat", "sensor_lon")
_REF_REQUIRED = ("time_ref", "ref_sensor_x", "ref_sensor_y")
#: Column of the sensor state each numeric column is stored in (latitude, longitude and
#: altitude are held in the position's place until :func:`_to_enu` converts them).
_STATE_COLUMN = {"sensor_x": 0, "sensor_y": 1, "sensor_z": 2, "sensor_vx": 3, "sensor_vy": 4,
                 "sensor_vz": 5, "sensor_lat": 0, "sensor_lon": 1, "sensor_alt": 2}
#: Rows converted from latitude/longitude to ENU at a time (bounds the conversion's arrays).
_ENU_ROWS = 1 << 16
#: Columns of range differences (empty on other rows).
_REFERENCE = ("time_ref", *REF_STATE_COLUMNS)


class _Fallback(Exception):
    """The file is not for the stream: the full checker reads it."""


def _header(path: Path, start: int) -> list[str] | None:
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
    stripped = [n.strip() for n in names]
    if "" in stripped or len(set(stripped)) != len(stripped):
        return None
    has = set(stripped).__contains__
    geodetic = any(has(c) for c in GEO_COLUMNS)
    position = (_GEO_REQUIRED, _ENU_COLUMNS) if geodetic else (_ENU_REQUIRED, GEO_COLUMNS)
    refs = any(has(c) for c in REF_STATE_COLUMNS)
    if not all(has(c) for c in (*_REQUIRED, *position[0], *(_REF_REQUIRED if refs else ()))
               ) or any(has(c) for c in position[1]) or has("sensor_vx") != has("sensor_vy"):
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

    def _arrays(self) -> list[NDArray[Any]]:
        """List the per-row arrays (the 1-D ones)."""
        return [*self.num.values(), self.sensor, self.kind,
                *(() if self.time_ref is None else (self.time_ref,))]

    def reserve(self, rows: int) -> None:
        """Make room for ``rows`` more rows (grown by a quarter at least)."""
        need = self.n + rows
        if need <= self.kind.shape[0]:
            return
        size = max(need, int(self.kind.shape[0] * 1.25))
        for a in self._arrays():
            a.resize(size, refcheck=False)
        for b in (self.state, self.ref):
            if b is not None:
                b.resize((size, 6), refcheck=False)

    def trim(self) -> None:
        """Drop the spare rows."""
        for a in self._arrays():
            a.resize(self.n, refcheck=False)
        for b in (self.state, self.ref):
            if b is not None:
                b.resize((self.n, 6), refcheck=False)

    def put_reference(self, name: str, values: NDArray[np.float64]) -> None:
        """Store a block of ``time_ref`` or a ``ref_sensor_*`` column (NaN for empty)."""
        lo, hi = self.n, self.n + values.shape[0]
        if name == "time_ref":
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
        return block_is_valid(self.num["time"][lo:hi], self.kind[lo:hi],
                              None if self.time_ref is None else self.time_ref[lo:hi],
                              None if self.ref is None else self.ref[lo:hi], self.ref_columns)

    def put_number(self, name: str, values: NDArray[np.float64]) -> None:
        """Store a block of a numeric column (finite numbers only)."""
        if not np.isfinite(values).all():
            raise _Fallback
        if name in GEO_RANGES and not geo_within(values, name).all():
            raise _Fallback
        lo, hi = self.n, self.n + values.shape[0]
        if name in self.num:
            self.num[name][lo:hi] = values
        else:
            self.state[lo:hi, _STATE_COLUMN[name]] = values

    def put_kind(self, indices: NDArray[np.integer], names: list[str]) -> None:
        """Store a block of kind codes from its dictionary (known kinds only)."""
        table = np.array([KIND_CODES.get(k, -1) for k in names], dtype=np.int8)
        if np.any(table < 0):
            raise _Fallback
        self.kind[self.n:self.n + indices.shape[0]] = table[indices]

    def put_sensor(self, indices: NDArray[np.integer], names: list[str]) -> None:
        """Store a block of sensor codes, new ids numbered in order of first appearance."""
        present, first = np.unique(indices, return_index=True)
        table = np.zeros(len(names), dtype=np.int32)
        for i in present[np.argsort(first, kind="stable")].tolist():
            name = names[i]
            if not name.strip():
                raise _Fallback
            table[i] = self.sensor_names.setdefault(name, len(self.sensor_names))
        self.sensor[self.n:self.n + indices.shape[0]] = table[indices]


def _read_blocks(path: Path, start: int, names: list[str]) -> _Columns:
    """Parse the file's records block by block into :class:`_Columns`."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    used = [n for n in names if n.strip() in ("sensor", "kind", *NUMERIC_COLUMNS)]
    text_type = pa.dictionary(pa.int32(), pa.string())
    types = {n: (text_type if n.strip() in ("sensor", "kind") else pa.float64()) for n in used}
    convert = pcsv.ConvertOptions(column_types=types, include_columns=used, null_values=[""],
                                  strings_can_be_null=False, quoted_strings_can_be_null=False)
    cols: _Columns | None = None
    # The C library's allocator: the text and parsed blocks are then given back with the
    # rules' arrays (:func:`~.arrow_blocks.give_back`), where pyarrow's own pool kept about 10 MB.
    pool = pa.system_memory_pool()
    with pa.OSFile(str(path), memory_pool=pool) as f:
        f.seek(start)
        # one thread: no blocks parsed ahead of the consumer, so the peak does not depend
        # on the machine's load
        reader = pcsv.open_csv(f, read_options=pcsv.ReadOptions(
            block_size=BLOCK_BYTES, use_threads=False), convert_options=convert,
            memory_pool=pool)
        for blocks, batch in enumerate(reader):
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
            if blocks % _GIVE_BACK_EVERY == 0:
                give_back()
    give_back()
    if cols is None or cols.n == 0:
        raise _Fallback
    cols.trim()
    return cols


def _put(cols: _Columns, name: str, col: Any) -> None:
    """Store one block of one column."""
    if name in _REFERENCE:  # empty cells are NaN
        values = with_nan(col)
        if np.count_nonzero(np.isnan(values)) != col.null_count:  # a cell "nan"
            raise _Fallback
        cols.put_reference(name, values)
        return
    if col.null_count:
        raise _Fallback
    if name in ("sensor", "kind"):
        indices = numbers(col.indices, np.int32)
        put: Callable[[NDArray[np.integer], list[str]], None] = (
            cols.put_sensor if name == "sensor" else cols.put_kind)
        put(indices, col.dictionary.to_pylist())
    else:
        cols.put_number(name, numbers(col, np.float64))


def _build(cols: _Columns, metadata: dict[str, str],
           ref: NDArray[np.float64] | None = None) -> MeasurementSet:
    """Make the checked set of the streamed columns (as :meth:`MeasurementSet.take` builds).

    ``ref``: the sensor states at ``time_ref`` of a file with range differences.  Raises
    ``ValueError`` (a rule of :mod:`tmakit.rules`) like the constructor.
    """
    from .. import rules

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


def split_metadata(text: str) -> tuple[dict[str, str], int, int]:
    """Split off the leading ``# key: value`` comment lines (and blank lines) of a CSV text.

    Parameters
    ----------
    text : str
        The start of the file's text.

    Returns
    -------
    metadata : dict of str to str
        The ``key: value`` pairs.
    chars, lines : int
        The characters and the lines the comment and blank lines take.
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


def preamble(path: Path, scan: int) -> tuple[dict[str, str], int] | None:
    """Read the leading ``# key: value`` lines from the first ``scan`` bytes of a file.

    Parameters
    ----------
    path : pathlib.Path
        The file (UTF-8, with or without a byte-order mark).
    scan : int
        Bytes read at most.

    Returns
    -------
    (dict of str to str, int) or None
        The metadata and the byte offset of the header line; None when the preamble is not
        within the first ``scan`` bytes or they are not UTF-8.
    """
    with open(path, "rb") as f:
        data = f.read(scan)
    try:
        text = codecs.getincrementaldecoder("utf-8-sig")().decode(data, final=False)
    except UnicodeDecodeError:
        return None
    metadata, consumed, _ = split_metadata(text)
    if consumed >= len(text) and len(data) == scan:
        return None
    bom = 3 if data.startswith(codecs.BOM_UTF8) else 0
    return metadata, bom + len(text[:consumed].encode("utf-8"))


def stream_csv(path: Path, scan: int = 1 << 20,
               origin: tuple[float, float, float] | None = None) -> MeasurementSet | None:
    """Read a valid CSV measurement file in bounded memory.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    scan : int, optional
        Bytes searched for the ``# key: value`` preamble.
    origin : (lat, lon, alt), optional
        ENU origin (degrees, degrees, metres) for a file with ``sensor_lat`` and
        ``sensor_lon``; wins over its ``origin_*`` metadata, as for
        :func:`~.checker.check_table`.

    Returns
    -------
    MeasurementSet or None
        The checked set, equal to what the full checker builds (:meth:`MeasurementSet.equals`);
        None when the file is not of that kind or breaks a rule (the full checker then
        reads it and names each problem).
    """
    found = preamble(path, scan)
    if found is None:
        return None
    metadata, start = found
    names = _header(path, start)
    if names is None:
        return None
    stripped = {n.strip() for n in names}
    enu_origin: tuple[float, float, float] | None = None
    if "sensor_lat" in stripped:
        enu_origin, origin_metadata = _origin(origin, metadata)
        if enu_origin is None:
            return None
        metadata = {**metadata, **origin_metadata}
    try:
        cols = _read_blocks(path, start, names)
        present = np.bincount(cols.kind, minlength=len(KIND_NAMES)) > 0
        if "sensor_vx" not in stripped and any(
                KINDS[k].uses_velocity for k, p in zip(KIND_NAMES, present, strict=True) if p):
            return None
        if enu_origin is not None:
            if "sensor_alt" not in stripped:  # as the full reader: the origin's altitude
                cols.state[:, 2] = enu_origin[2]
            rule = _to_enu(cols.state, enu_origin, metadata.get("dim", "").strip() == "3")
            if rule:
                metadata["dim_rule"] = rule
        meas = _build(cols, metadata, _reference_states(cols, "sensor_vx" in stripped))
    except (_Fallback, ValueError):  # pyarrow's ArrowInvalid is a ValueError
        return None
    # The rules' and the duplicate check's arrays came from the C library's heap (its mmap
    # threshold grows as large blocks are freed) and stay resident when freed below live
    # arrays: 47 MiB of a 1e6-row file with range differences, until given back here.
    give_back()
    return meas


def _reference_states(cols: _Columns, has_velocity: bool) -> NDArray[np.float64] | None:
    """Find the sensor states at ``time_ref`` of range differences; None without any."""
    if cols.time_ref is None:
        return None
    ref = reference_states(cols.num["time"], cols.time_ref, cols.kind, cols.sensor,
                           list(cols.sensor_names), cols.state, cols.ref, cols.ref_columns,
                           has_velocity)
    if ref is None:
        raise _Fallback
    return ref


def _origin(origin: tuple[float, float, float] | None, metadata: dict[str, str]
            ) -> tuple[tuple[float, float, float] | None, dict[str, str]]:
    """Pick the ENU origin as the full reader does (:func:`.positions.resolve_origin`).

    The argument, else the file's ``origin_lat``, ``origin_lon`` (and ``origin_alt``, 0 m
    when absent) metadata; ``(None, {})`` when there is none or it is unreadable.
    """
    problems = Problems(RawTable(None, metadata, None))
    found, origin_metadata = resolve_origin(origin, metadata, problems)
    return (None, {}) if problems.file else (found, origin_metadata)


def _to_enu(state: NDArray[np.float64], origin: tuple[float, float, float],
            dim3: bool) -> str:
    """Convert latitude, longitude, altitude in ``state[:, :3]`` to ENU in place.

    As the full reader does (:func:`.positions.sensor_state`): the surface rule of
    :func:`tmakit.io.logs.surface_dim` over every row's altitude decides 2-D (altitude the
    origin's, up 0) or 3-D, unless ``dim3`` (metadata ``dim: 3``).  Converted
    :data:`_ENU_ROWS` rows at a time, so the conversion's arrays stay small.

    Returns
    -------
    str
        The surface rule's text when it flattened the positions, else ``""``.
    """
    from ..core.geodesy import geodetic_to_enu
    from .logs import surface_dim

    n, alt0 = state.shape[0], origin[2]
    worst, spread = alt0, -1.0  # the altitude farthest from the origin's
    for lo in range(0, n, _ENU_ROWS):
        off = np.abs(state[lo:lo + _ENU_ROWS, 2] - alt0)
        i = int(np.argmax(off))
        if off[i] > spread:
            worst, spread = float(state[lo + i, 2]), float(off[i])
    dim, rule = surface_dim(np.array([worst]), alt0, 3 if dim3 else None)
    for lo in range(0, n, _ENU_ROWS):
        block = state[lo:lo + _ENU_ROWS]
        alt = np.full(block.shape[0], alt0) if dim == 2 else block[:, 2]
        with np.errstate(invalid="ignore"):
            e, nn, u = geodetic_to_enu(block[:, 0], block[:, 1], alt, origin)
        block[:, 0], block[:, 1], block[:, 2] = e, nn, (0.0 * u if dim == 2 else u)
    return rule if dim == 2 else ""
