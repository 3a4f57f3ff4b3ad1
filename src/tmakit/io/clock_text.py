"""A time typed by a user: seconds, an ISO-8601 UTC clock time, or a clock time of the day.

``1200.5`` is seconds since the set's ``time_origin``; ``2016-11-05T19:30:00Z`` an instant (UTC
unless a zone is named); ``19:30[:15[.5]]`` that UTC clock time on the day of the data, only
where the data lie within one UTC day.  Used by ``--from``, ``--to``, ``--at`` and the readers'
time windows.
"""

from __future__ import annotations

import datetime as dt
import math
import re

__all__ = ["seconds_of_time_text"]

_NS = 1_000_000_000
_CLOCK = re.compile(r"(\d{1,2}):(\d{2})(?::(\d{2}(?:\.\d+)?))?")


def _iso(ns: int) -> str:
    secs, frac = divmod(int(ns), _NS)
    text = dt.datetime.fromtimestamp(secs, dt.UTC).strftime("%Y-%m-%dT%H:%M:%S")
    return text + (f".{frac:09d}".rstrip("0") if frac else "") + "Z"


def _clock_seconds(text: str, match: re.Match[str], option: str) -> float:
    hours, minutes = int(match[1]), int(match[2])
    seconds = float(match[3]) if match[3] else 0.0
    if hours > 23 or minutes > 59 or seconds >= 60:
        raise ValueError(f"{option} {text!r}: expected a clock time HH:MM or HH:MM:SS (UTC), "
                         "hours 0-23, minutes and seconds 0-59")
    return hours * 3600.0 + minutes * 60.0 + seconds


def seconds_of_time_text(text: str, option: str, origin_ns: int | None,
                         span_ns: tuple[int, int] | None) -> float:
    """Read a time option as seconds since the set's time origin."""
    try:
        seconds = float(text)
    except ValueError:
        pass
    else:
        if not math.isfinite(seconds):
            raise ValueError(f"{option} {text!r}: expected a finite time (s)")
        return seconds
    clock = _CLOCK.fullmatch(text.strip())
    when = None
    if clock is None:
        try:
            when = dt.datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(f"{option} {text!r}: expected seconds, an ISO-8601 clock time (e.g. "
                             "2024-05-01T12:30:00Z) or a clock time of the data's day (e.g. "
                             "12:30 or 12:30:15, UTC)") from None
    if origin_ns is None:
        raise ValueError(f"{option} {text!r}: a clock time needs the file's time origin "
                         "(time_origin), which this file does not give; give seconds")
    if clock is not None:
        of_day = _clock_seconds(text, clock, option)
        if span_ns is None:
            raise ValueError(f"{option} {text!r}: a clock time without a date needs the data's "
                             "day; give the date, e.g. 2024-05-01T12:30:00Z")
        first_day, last_day = (int(t) // (86400 * _NS) for t in span_ns)
        if first_day != last_day:
            raise ValueError(
                f"{option} {text!r}: the data span more than one UTC day ({_iso(span_ns[0])} "
                f"to {_iso(span_ns[1])}), so a clock time without a date is ambiguous; give "
                f"the date, e.g. {_iso(first_day * 86400 * _NS)[:10]}T{text.strip()}Z")
        return (first_day * 86400 * _NS - origin_ns) / _NS + of_day
    assert when is not None
    when = when if when.tzinfo else when.replace(tzinfo=dt.UTC)
    whole = dt.datetime.fromtimestamp(origin_ns // _NS, dt.UTC)
    return (when - whole).total_seconds() - (origin_ns % _NS) / _NS
