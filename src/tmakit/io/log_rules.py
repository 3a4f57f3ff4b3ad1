"""The rules of a measurement file on a log's values, named by their place in the log."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .epoch_times import LATEST_NS, PLAUSIBLE_YEARS
from .logs import Fixes

if TYPE_CHECKING:  # pragma: no cover
    from ..data import MeasurementSet

__all__ = ["checked_rows", "fix_problems"]

#: Problems listed per rule (as the wide-log reader lists its cells).
_LISTED = 25
#: What each column of a set is, in the words of a log's problem.
_SET_COLUMNS = {"time": "time", "value": "value", "sigma": "sigma", "time_ref": "time_ref",
                "sensor_x": "sensor east position", "sensor_y": "sensor north position",
                "sensor_z": "sensor height", "sensor_vx": "sensor east velocity",
                "sensor_vy": "sensor north velocity", "sensor_vz": "sensor up velocity"}
_ROW = re.compile(r"^row (\d+), column '(\w+)': ")


def fix_problems(fixes: Fixes, where: Callable[[int, str], str]) -> list[str]:
    """Check a track's fixes by the rules of a measurement file (:mod:`tmakit.rules`)."""
    from .. import rules
    from ..measurements import KINDS

    checks: list[tuple[NDArray[np.float64], str, str, Callable]] = [
        (fixes.lat, "latitude", rules.LATITUDE, lambda v: rules.geo_within(v, "sensor_lat")),
        (fixes.lon, "longitude", rules.LONGITUDE, lambda v: rules.geo_within(v, "sensor_lon")),
        (fixes.alt, "altitude", rules.POSITION, lambda v: rules.state_within_reach(v, 2))]
    if fixes.velocity is not None:
        checks += [(fixes.velocity[:, j], "velocity", rules.VELOCITY,
                    lambda v: rules.state_within_reach(v, 3)) for j in range(3)]
    found: list[str] = []
    for values, name, expected, ok in checks:
        values = np.asarray(values, float)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.isfinite(values) & ok(values)))
        found += [f"{where(int(k), name)}: expected {expected}, found {float(values[k])!r}"
                  for k in bad[:_LISTED]]
    if fixes.heading is not None:
        h = np.asarray(fixes.heading, float)
        bad = np.flatnonzero(~np.isnan(h) & ~KINDS["bearing"].check_values(h))
        found += [f"{where(int(k), 'heading')}: expected {KINDS['bearing'].describe_values()}"
                  f", found {float(h[k])!r}" for k in bad[:_LISTED]]
    t = np.asarray(fixes.time_ns, np.int64)
    bad = np.flatnonzero((t < 0) | (t >= LATEST_NS))
    found += [f"{where(int(k), 'time')}: expected a date between {PLAUSIBLE_YEARS[0]} and "
              f"{PLAUSIBLE_YEARS[1]}" for k in bad[:_LISTED]]
    return found


def checked_rows(path: object, meas: MeasurementSet, where: Sequence[str]
                 ) -> tuple[MeasurementSet, NDArray[np.intp], int]:
    """Check a log's rows by the rules of a measurement file, and merge repeated rows."""
    from .. import rules
    from .errors import MeasurementFileError

    rank_of_code = np.zeros(len(meas.sensor_names), dtype=np.intp)
    for rank, name in enumerate(meas.sensors):
        rank_of_code[meas.sensor_names.index(name)] = rank
    order = np.lexsort((meas.time, rank_of_code[meas.sensor_code]))
    ordered = meas.take(order)
    found = [_readdressed(p, where, order) for p in rules.column_problems(
        ordered.time, ordered.sensor_code, ordered.kind_code, ordered.value, ordered.sigma,
        ordered.sensor_state, ordered.time_ref, order=False)]
    far, expected = rules.far_times(ordered.time)
    found += [f"{where[order[k]]}: time: expected {expected}, found {ordered.time[k]:.10g} s"
              for k in np.flatnonzero(far)[:_LISTED]]
    drop = []
    for row, first in rules.duplicate_rows(ordered.time, ordered.stream_code(),
                                          ordered.kind_code, ordered.time_ref):
        if (ordered.value[row] == ordered.value[first]
                and ordered.sigma[row] == ordered.sigma[first]):
            drop.append(row)
        elif len(found) < 3 * _LISTED:
            found.append(f"{where[order[row]]}: a second {ordered.kind[row]} of sensor "
                         f"'{ordered.sensor[row]}' at the time of {where[order[first]]} "
                         f"({float(ordered.value[row])!r} against "
                         f"{float(ordered.value[first])!r}): two values at one time cannot "
                         "both be measurements (a time rounded to the second? give its "
                         "fractions)")
    if found:
        raise MeasurementFileError(path, found)  # type: ignore[arg-type]
    keep = np.setdiff1d(np.arange(len(ordered)), np.array(drop, dtype=np.intp))
    return ordered.take(keep), order[keep], len(drop)


def _readdressed(problem: str, where: Sequence[str], order: NDArray[np.intp]) -> str:
    """Name a rules problem (``row N, column 'c': ...``) by the row's place in its log."""
    m = _ROW.match(problem)
    if m is None:
        return problem
    row, column = int(m.group(1)) - 1, m.group(2)
    if column == "value":  # the place names the cell
        return f"{where[order[row]]}: {problem[m.end():]}"
    return f"{where[order[row]]}, {_SET_COLUMNS.get(column, column)}: {problem[m.end():]}"
