"""Which columns a measurement file has, against what its rows need."""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass

from ..data import REF_STATE_COLUMNS
from ..measurements import KINDS
from .contract import GEO_COLUMNS, reference_kinds, reference_kinds_text
from .problems import Problems

__all__ = ["Layout", "check_columns"]


@dataclass(frozen=True)
class Layout:
    """How a file gives the sensor state."""

    geodetic: bool  # Positions as ``sensor_lat``/``sensor_lon`` (degrees) instead of ENU metres
    has_velocity: bool  # The file has both ``sensor_vx`` and ``sensor_vy``
    has_ref: bool  # The file has ``ref_sensor_*`` columns


def check_columns(columns: Collection[str], kinds: list[str], problems: Problems) -> Layout:
    """Record missing or conflicting columns, given the kinds present in the file."""
    has = set(columns).__contains__
    for c in ("time", "sensor", "kind", "value", "sigma"):
        if not has(c):
            problems.missing(c)
    geodetic = _check_position(has, problems)
    has_velocity = _check_velocity(has, kinds, problems)
    if any(k in kinds for k in reference_kinds()) and not has("time_ref"):
        problems.missing("time_ref", f"; needed by the {reference_kinds_text()} rows")
    ref = [c for c in REF_STATE_COLUMNS if has(c)]
    if ref:
        for c in ("ref_sensor_x", "ref_sensor_y"):
            if not has(c):
                problems.missing(c, f" ({', '.join(ref)} {'is' if len(ref) == 1 else 'are'}"
                                    " given)")
    return Layout(geodetic, has_velocity, bool(ref))


def _check_position(has: Callable[[str], bool], problems: Problems) -> bool:
    """ENU or geodetic positions, not both; True for geodetic."""
    enu = [c for c in ("sensor_x", "sensor_y", "sensor_z") if has(c)]
    geo = [c for c in GEO_COLUMNS if has(c)]
    geodetic = bool(geo) and not enu
    if enu and geo:
        problems.file.append(
            f"columns {', '.join(enu)} and {', '.join(geo)} both give the sensor position: "
            "give either sensor_x, sensor_y (and sensor_z) in ENU metres or sensor_lat, "
            "sensor_lon (and sensor_alt), not both")
    elif geodetic:
        for c in ("sensor_lat", "sensor_lon"):
            if not has(c):
                problems.missing(c, " (the file gives positions as latitude/longitude)")
    else:
        for c in ("sensor_x", "sensor_y"):
            if not has(c):
                problems.missing(c, "; or give sensor_lat and sensor_lon (degrees) instead")
    return geodetic


def _check_velocity(has: Callable[[str], bool], kinds: list[str], problems: Problems) -> bool:
    """Velocity columns needed by the kinds, or given in pairs; True if both are given."""
    velocity_kinds = [k for k in kinds if KINDS[k].uses_velocity]
    has_vx, has_vy = has("sensor_vx"), has("sensor_vy")
    if velocity_kinds:
        for c in ("sensor_vx", "sensor_vy"):
            if not has(c):
                problems.missing(c, f"; needed by the kind{'s' if len(velocity_kinds) > 1 else ''}"
                                    f" {', '.join(velocity_kinds)} in this file")
    elif has_vx != has_vy:
        given, absent = (("sensor_vx", "sensor_vy") if has_vx else ("sensor_vy", "sensor_vx"))
        problems.missing(absent, f" ({given} is given)")
    return bool(has_vx and has_vy)
