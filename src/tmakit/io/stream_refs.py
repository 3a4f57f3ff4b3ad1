"""Range differences in a streamed CSV file: ``time_ref`` and the sensor state at it.

The rules of the full checker (:mod:`.check_cells`) on each block of
:mod:`tmakit.io.csv_stream`, and the reference states of the whole set after the stream (from
the ``ref_sensor_*`` cells, else the sensor's own rows, as :func:`.positions.ref_sensor_state`
does).  Where the full checker would find a
problem, each function says so (False, None or True): the file then goes to the full checker,
which names it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..data import REF_STATE_COLUMNS
from ..measurements import KINDS
from ..measurements.codes import KIND_NAMES
from .sensor_record import QUERY_ROWS, SensorRecord

__all__ = ["block_is_valid", "reference_states"]

#: Whether each kind code uses a reference sample (range differences).
USES_REFERENCE = np.array([KINDS[k].uses_reference for k in KIND_NAMES], dtype=bool)
#: Whether each kind code is a difference between sensors at one time (tdoa, fdoa).
BETWEEN_SENSORS = np.array([KINDS[k].between_sensors for k in KIND_NAMES], dtype=bool)


def block_is_valid(time: NDArray[np.float64], kind: NDArray[np.int8],
                   time_ref: NDArray[np.float64] | None, ref: NDArray[np.float64] | None,
                   ref_columns: list[int]) -> bool:
    """Check one block's ``time_ref`` and ``ref_sensor_*`` cells as the full checker does.

    Parameters
    ----------
    time : numpy.ndarray
        The block's times (s).
    kind : numpy.ndarray of int8
        The block's kind codes.
    time_ref : numpy.ndarray or None
        The block's ``time_ref`` (s, NaN for an empty cell); None when every cell so far was
        empty.
    ref : numpy.ndarray, shape (k, 6), or None
        The block's ``ref_sensor_*`` cells (m, m/s, NaN for empty); None when all were empty.
    ref_columns : list of int
        The reference-state columns the file has.

    Returns
    -------
    bool
        True when a ``time_ref`` is on exactly the range-difference rows, finite and before
        ``time``, and each row gives all or none of the file's ``ref_sensor_*`` cells, on a
        range-difference row only.
    """
    is_rd = USES_REFERENCE[kind]
    between = BETWEEN_SENSORS[kind]
    earlier = is_rd & ~between
    if time_ref is None:
        ok = not is_rd.any()
    else:
        with np.errstate(invalid="ignore"):
            ok = bool(np.array_equal(np.isnan(time_ref), ~is_rd)
                      and not np.isinf(time_ref).any()
                      and np.all(time_ref[earlier] < time[earlier])
                      and np.all(time_ref[between] == time[between]))
    if ok and ref is not None:
        cells = ref[:, ref_columns]
        given = ~np.isnan(cells)
        row_given = given.any(axis=1)
        ok = not (np.isinf(cells).any() or (row_given & ~is_rd).any()
                  or (row_given & ~given.all(axis=1)).any() or (between & ~row_given).any())
    elif ok:
        ok = not between.any()
    return ok


def reference_states(time: NDArray[np.float64], time_ref: NDArray[np.float64],
                     kind: NDArray[np.int8], sensor: NDArray[np.int32], names: list[str],
                     state: NDArray[np.float64], ref: NDArray[np.float64] | None,
                     ref_columns: list[int], has_velocity: bool) -> NDArray[np.float64] | None:
    """Each row's sensor state at ``time_ref`` ``(n, 6)``, NaN on rows of other kinds.

    Parameters
    ----------
    time, time_ref : numpy.ndarray
        Each row's times (s).
    kind : numpy.ndarray of int8
        Kind codes.
    sensor : numpy.ndarray of int32
        Sensor codes; ``names`` their ids.
    names : list of str
        The sensor ids, by code.
    state : numpy.ndarray, shape (n, 6)
        Each row's sensor state (ENU m, m/s).
    ref : numpy.ndarray, shape (n, 6), or None
        The ``ref_sensor_*`` cells (NaN where empty), filled in place; None when none given.
    ref_columns : list of int
        The reference-state columns the file has (absent velocities and ``ref_sensor_z``
        are 0 where a row gives the others).
    has_velocity : bool
        The file gives sensor velocities (else the interpolated ones are 0).

    Returns
    -------
    numpy.ndarray or None
        The states; None when a ``time_ref`` has no known sensor position.
    """
    n = time.shape[0]
    if ref is None:
        ref = np.full((n, 6), np.nan)
    absent = [i for i in range(2, len(REF_STATE_COLUMNS)) if i not in ref_columns]
    counts = np.zeros(len(names), dtype=np.int64)
    for lo in range(0, n, QUERY_ROWS):  # block by block: no temporary of every row
        block = ref[lo:lo + QUERY_ROWS]
        given = ~np.isnan(block[:, 0])
        for i in absent:
            block[given, i] = 0.0
        counts += np.bincount(sensor[lo:lo + QUERY_ROWS][_need(kind, ref, lo)],
                              minlength=len(names))
    for code in np.flatnonzero(counts).tolist():
        mine = None if len(names) == 1 else np.flatnonzero(sensor == code)
        record = SensorRecord(time, state, mine, has_velocity)
        for lo in range(0, n, QUERY_ROWS):
            need = _need(kind, ref, lo)
            if len(names) > 1:
                need &= sensor[lo:lo + QUERY_ROWS] == code
            if np.any(record.fill(lo + np.flatnonzero(need), time_ref, ref)):
                return None
    return ref


def _need(kind: NDArray[np.int8], ref: NDArray[np.float64], lo: int) -> NDArray[np.bool_]:
    """Flag the range differences without ``ref_sensor_*`` cells of a block from row ``lo``."""
    hi = lo + QUERY_ROWS
    return (USES_REFERENCE[kind[lo:hi]] & ~BETWEEN_SENSORS[kind[lo:hi]]
            & np.isnan(ref[lo:hi, 0]))
