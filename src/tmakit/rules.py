"""The one set of rules a measurement set obeys, wherever it comes from.

The file reader (:mod:`tmakit.io`), the :class:`~tmakit.data.MeasurementSet` constructor, the
scenario simulator and the writers all refuse what these rules refuse, with the same words:
each cell rule is a ``(column, expected, test)`` triple here, and the metadata keys the
library reads (``truth``, ``nuisance``, ``ref_time``, ``origin_*``, ``seed``, ``motion``) are
checked by :func:`metadata_problems`.  The reader reports a failing cell by file row, line and
column; the constructor by row and column (:func:`column_problems`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .measurements import KINDS

__all__ = ["FINITE", "LATITUDE", "LONGITUDE", "SIGMA_POSITIVE", "check_set",
           "column_problems", "metadata_problems", "raise_problems"]

#: What a numeric cell must be.
FINITE = "a finite number"
#: What a noise standard deviation must be.
SIGMA_POSITIVE = "a noise standard deviation > 0 (in the unit of value)"
#: What a latitude must be (deg).
LATITUDE = "a latitude within [-90, 90] deg"
#: What a longitude must be (deg).
LONGITUDE = "a longitude within [-180, 360] deg"

_SHOWN = 10  # problems listed in a constructor's message


def _where(rows: NDArray[np.intp], column: str, expected: str,
           found: NDArray[np.float64]) -> list[str]:
    return [f"row {int(r) + 1}, column '{column}': expected {expected}, found {float(found[k])!r}"
            for k, r in enumerate(rows[:_SHOWN])]


def column_problems(time: NDArray[np.float64], sensor_code: NDArray[np.integer],
                    kind: NDArray[np.integer], value: NDArray[np.float64],
                    sigma: NDArray[np.float64], sensor_state: NDArray[np.float64],
                    time_ref: NDArray[np.float64], order: bool = True, ranges: bool = True
                    ) -> list[str]:
    """Check the columns of a measurement set against the rules of the file format.

    Every check is vectorised: linear in the rows, with boolean masks (1 byte per row) as
    its only full-size temporaries, plus one sort of the sensor codes for the time order
    when there are several sensors.

    Parameters
    ----------
    time : ndarray, shape (n,)
        Times (s).
    sensor_code : ndarray of int, shape (n,)
        Sensor of each row (codes).
    kind : ndarray of int, shape (n,)
        Kind of each row: an index into :data:`tmakit.measurements.KINDS`.
    value, sigma : ndarray, shape (n,)
        Values and standard deviations in file units (deg, m, Hz, dBm, ...).
    sensor_state : ndarray, shape (n, 6)
        Sensor ENU states (m, m/s).
    time_ref : ndarray, shape (n,)
        Reference times (s) of range differences; NaN elsewhere.
    order : bool, optional
        Check that time does not decrease within a sensor (default).
    ranges : bool, optional
        Check each kind's value range (default).

    Returns
    -------
    list of str
        One message per failing cell (at most ten per rule), ``row N, column 'c': expected
        ..., found ...``; empty when the set obeys every rule.
    """
    found: list[str] = []
    cols = {"time": time, "value": value, "sigma": sigma}
    for name, col in cols.items():
        bad = np.flatnonzero(~np.isfinite(col))
        found += _where(bad, name, FINITE, col[bad])
    for j, name in enumerate(("sensor_x", "sensor_y", "sensor_z", "sensor_vx", "sensor_vy",
                              "sensor_vz")):
        bad = np.flatnonzero(~np.isfinite(sensor_state[:, j]))
        found += _where(bad, name, FINITE, sensor_state[bad, j])
    bad = np.flatnonzero(np.isfinite(sigma) & ~(sigma > 0))
    found += _where(bad, "sigma", SIGMA_POSITIVE, sigma[bad])
    for code, cls in enumerate(KINDS.values()):
        if cls.value_range is None or not ranges:
            continue
        # masks only (1 byte per row), no index or value copies of the kind's rows
        bad = np.flatnonzero((kind == code) & np.isfinite(value) & ~cls.check_values(value))
        found += _where(bad, "value", str(cls.describe_values()), value[bad])
    bad = np.flatnonzero(np.isinf(time_ref))
    found += _where(bad, "time_ref", FINITE, time_ref[bad])
    if order:
        found += _order_problems(time, sensor_code)
    return found


def _order_problems(time: NDArray[np.float64], sensor_code: NDArray[np.integer]
                    ) -> list[str]:
    """List the times that decrease within a sensor (file order kept).

    One sensor costs a comparison pass; several, one stable sort of the sensor codes.
    """
    n = time.shape[0]
    if n < 2:
        return []
    if int(sensor_code.min()) == int(sensor_code.max()):  # one sensor: no sort, no copies
        back = np.flatnonzero(time[1:] < time[:-1])
        pairs = [(int(i), int(i) + 1) for i in back[:_SHOWN]]
    else:  # by sensor, file order within
        order = np.argsort(sensor_code, kind="stable")
        t, s = time[order], sensor_code[order]
        back = np.flatnonzero((s[1:] == s[:-1]) & (t[1:] < t[:-1]))
        pairs = [(int(order[i]), int(order[i + 1])) for i in back[:_SHOWN]]
    return [f"row {row + 1}, column 'time': expected a time >= {float(time[prev])!r} s, the "
            f"time of the previous row of its sensor (row {prev + 1}), found "
            f"{float(time[row])!r}" for prev, row in pairs]


def _json_numbers(text: str, key: str) -> str | None:
    try:
        values = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        return f"metadata '{key}': expected a JSON object of numbers by name, found {text!r:.80}"
    if not isinstance(values, dict) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in values.values()):
        return (f"metadata '{key}': expected a JSON object of finite numbers by name, found "
                f"{text!r:.80}")
    return None


def _number(text: str, key: str, low: float = -math.inf, high: float = math.inf,
            unit: str = "") -> str | None:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and low <= v <= high):
        limits = "" if math.isinf(low) else f" within [{low:g}, {high:g}]"
        return f"metadata '{key}': expected a finite number{limits}{unit}, found {text!r:.80}"
    return None


def metadata_problems(metadata: Mapping[str, str]) -> list[str]:
    """Check the metadata keys the library reads; other keys are free text.

    Parameters
    ----------
    metadata : mapping of str to str
        The set's (or file's) metadata.

    Returns
    -------
    list of str
        One message per bad key (``truth`` and ``nuisance``: a JSON object of finite
        numbers; ``ref_time``: finite (s); ``origin_lat`` in [-90, 90] deg, ``origin_lon`` in
        [-180, 360] deg, ``origin_alt`` finite (m); ``seed`` a whole number >= 0;
        ``motion`` a motion name).
    """
    json_found, motion_found = _parsed_problems(tuple(metadata.get(key) for key in _PARSED))
    found = list(json_found)
    checks = {"ref_time": (-math.inf, math.inf, " (s)"), "origin_lat": (-90, 90, " deg"),
              "origin_lon": (-180, 360, " deg"), "origin_alt": (-math.inf, math.inf, " (m)")}
    for key, (low, high, unit) in checks.items():
        if key in metadata and metadata[key] != "":
            found.append(_number(metadata[key], key, low, high, unit))
    seed = metadata.get("seed", "")
    if seed and seed != "None" and not (seed.isdigit() and seed.isascii()):
        found.append(f"metadata 'seed': expected a whole number >= 0, found {seed!r:.80}")
    found += motion_found
    return [f for f in found if f]


_PARSED = ("truth", "nuisance", "motion")  # the keys whose check parses text (JSON, a name)


@lru_cache(maxsize=256)
def _parsed_problems(texts: tuple[str | None, ...]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Check the metadata of :data:`_PARSED` (None: absent), once per distinct text.

    Many sets carry the same truth and motion (a Monte Carlo study's runs).  Returns the
    problems of ``truth`` and ``nuisance``, and those of ``motion``.
    """
    truth, nuisance, motion = texts
    json_found = tuple(p for key, text in (("truth", truth), ("nuisance", nuisance))
                       if text is not None and (p := _json_numbers(text, key)))
    if motion is None:
        return json_found, ()
    from .motion import motion_from_name

    try:
        motion_from_name(motion, 0.0)
    except ValueError as e:
        return json_found, (f"metadata 'motion': {e}",)
    return json_found, ()


def raise_problems(found: list[str], what: str = "measurement set") -> None:
    """Raise one ``ValueError`` listing ``found`` (nothing when it is empty).

    Parameters
    ----------
    found : list of str
        Problems (:func:`column_problems`, :func:`metadata_problems`).
    what : str
        What was checked, for the first line.

    Raises
    ------
    ValueError
        When ``found`` is not empty.
    """
    if found:
        more = f"\n  ... and {len(found) - 3 * _SHOWN} more" if len(found) > 3 * _SHOWN else ""
        raise ValueError(f"invalid {what}: " + "\n  ".join(found[:3 * _SHOWN]) + more)


def check_set(meas: Any, order: bool = True, ranges: bool = True) -> None:
    """Refuse a measurement set that breaks a rule (columns and metadata).

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The set (its file-unit values are checked, as in a file).
    order, ranges : bool, optional
        Check the time order within each sensor and each kind's value range (default).

    Raises
    ------
    ValueError
        Listing every problem (row, column, what was expected and found).
    """
    if not ranges and _si_cells_plainly_valid(meas):  # no cell rule can fail: skip them
        found = _order_problems(meas.time, meas.sensor_code) if order else []
    else:  # the rules on the file-unit cells, whose values the messages quote
        found = column_problems(meas.time, meas.sensor_code, meas.kind_code, meas.value,
                                meas.sigma, meas.sensor_state, meas.time_ref, order, ranges)
    raise_problems(found + metadata_problems(meas.metadata))


_PLAIN = 1e300  # SI magnitudes whose file-unit twins are finite (and non-zero) numbers


def _si_cells_plainly_valid(meas: Any) -> bool:
    """Tell whether every cell rule but the value ranges and the order surely holds.

    From the SI columns, without making the file-unit ones (a set built in SI has none yet):
    finite times and sensor states, values within +-1e300 and sigmas within (1e-300, 1e300)
    (so their file-unit twins, scaled by factors near 1 to 60, are finite and positive), no
    infinite reference time.  False sends the set to :func:`column_problems`, which names
    each failing cell.
    """
    v, s = meas.value_si, meas.sigma_si
    with np.errstate(invalid="ignore"):
        return bool(np.isfinite(meas.time).all() and np.isfinite(meas.sensor_state).all()
                    and (np.abs(v) < _PLAIN).all() and (s > 1.0 / _PLAIN).all()
                    and (s < _PLAIN).all() and not np.isinf(meas.time_ref).any())
