"""Clock times of a log's cells: ISO-8601 text or epoch numbers in a stated unit."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["EPOCH_UNITS", "LATEST_NS", "PLAUSIBLE_YEARS", "clock_time_problem",
           "parse_clock_times"]

#: Nanoseconds per unit of an epoch time column (a mapping's ``time_unit``).
EPOCH_UNITS = {"s": 1_000_000_000, "ms": 1_000_000, "us": 1_000, "ns": 1}
_UNIT_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
#: Clock times are refused outside these years (UTC): an epoch number in another unit than
#: the one stated lands far outside them (milliseconds read as seconds: year 58000).
PLAUSIBLE_YEARS = (1970, 2200)
#: The end of the plausible years, ns since 1970 (UTC).
LATEST_NS = int((np.datetime64(f"{PLAUSIBLE_YEARS[1]}-01-01", "ns")
                  - np.datetime64("1970-01-01", "ns")).astype(np.int64))


def parse_clock_times(values: Sequence[object], unit: str = "s"
                      ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Read clock times: ISO-8601 text (UTC unless it names a zone) or epoch numbers."""
    import pandas as pd

    per = EPOCH_UNITS[unit]
    series = pd.Series(list(values), dtype=object)
    numbers = pd.to_numeric(series, errors="coerce")
    out = np.zeros(len(series), dtype=np.int64)
    bad = np.zeros(len(series), dtype=bool)
    as_float = numbers.to_numpy(float, na_value=np.nan)
    is_number = np.isfinite(as_float)
    if is_number.any():
        with np.errstate(invalid="ignore", over="ignore"):
            inside = is_number & (as_float >= 0) & (as_float * per < LATEST_NS)
        if pd.api.types.is_integer_dtype(numbers.dtype):  # exact, whatever the unit
            out[inside] = numbers.to_numpy(np.int64)[inside] * per
        else:
            v = as_float[inside]
            whole = np.floor(v)
            out[inside] = (whole.astype(np.int64) * per
                           + np.round((v - whole) * per).astype(np.int64))
        bad |= is_number & ~inside
    text = ~is_number
    if text.any():
        stamps = pd.to_datetime(series[text].astype(str).str.strip(), utc=True, errors="coerce",
                                format="ISO8601")
        ns = stamps.dt.tz_convert("UTC").dt.tz_localize(None).astype("datetime64[ns]")
        values_ns = ns.to_numpy().astype(np.int64)
        ok = stamps.notna().to_numpy() & (values_ns >= 0) & (values_ns < LATEST_NS)
        out[np.flatnonzero(text)[ok]] = values_ns[ok]
        bad[np.flatnonzero(text)[~ok]] = True
    return out, bad


def clock_time_problem(cell: object, unit: str = "s") -> str:
    """Say what a clock time cell should have been, and what it seems to be."""
    low, high = PLAUSIBLE_YEARS
    expected = (f"expected an ISO-8601 time or epoch {_UNIT_NAMES[unit]} (since 1970-01-01 "
                f"UTC) between {low} and {high}")
    try:
        v = float(str(cell))
    except ValueError:
        return f"{expected}, found {cell!r}"
    if not np.isfinite(v):
        return f"{expected}, found {cell!r}"
    fits = [u for u, per in EPOCH_UNITS.items()
            if LATEST_NS / 1e3 <= v * per < LATEST_NS]  # a date after 1970 + 0.23 years
    hint = (f" (as epoch {_UNIT_NAMES[fits[0]]} it is a date: give time_unit = "
            f"\"{fits[0]}\" in the mapping)" if fits and fits[0] != unit else "")
    return f"{expected}, found {cell!r}{hint}"
