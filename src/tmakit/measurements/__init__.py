"""Measurement kinds: one file per kind, each with ``predict`` and an analytic ``jacobian``."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from .altitude import Altitude
from .azimuth_rate import AzimuthRate
from .base import Jacobian, MeasurementModel, ValueRange
from .bearing import Bearing
from .elevation import Elevation
from .fdoa import Fdoa
from .frequency import Frequency
from .power import Power
from .range import Range
from .range_difference import RangeDifference, interval_count, range_difference_covariance
from .range_rate import RangeRate
from .tdoa import Tdoa, shared_reference_covariance

KINDS: dict[str, type[MeasurementModel]] = {
    cls.kind: cls
    for cls in (Bearing, Elevation, AzimuthRate, Range, RangeRate, Frequency, Power,
                RangeDifference, Tdoa, Fdoa, Altitude)
}
"""Every measurement kind by its file name: a new kind is one file (a
:class:`MeasurementModel` subclass with its hooks) plus its entry here."""

__all__ = [
    "KINDS",
    "Altitude",
    "AzimuthRate",
    "Bearing",
    "Elevation",
    "Fdoa",
    "Frequency",
    "Jacobian",
    "MeasurementModel",
    "Power",
    "Range",
    "RangeDifference",
    "RangeRate",
    "Tdoa",
    "ValueRange",
    "interval_count",
    "model_for",
    "range_difference_covariance",
    "shared_reference_covariance",
]


def model_for(kind: str, options: Mapping[str, object] | None = None) -> MeasurementModel:
    """Build the measurement model of a kind (SI inside).

    Parameters
    ----------
    kind : str
        A key of :data:`KINDS`.
    options : mapping, optional
        The kind's options (``{"drift": True}``); one it does not take is a ``TypeError``.

    Returns
    -------
    MeasurementModel

    Raises
    ------
    ValueError
        If ``kind`` is not a known measurement kind.
    """
    try:
        cls = KINDS[kind]
    except KeyError:
        raise ValueError(f"unknown measurement kind {kind!r}; expected one of "
                         f"{', '.join(KINDS)}") from None
    return cls(**dict(options or {}))


def options_with_metadata(kinds: Iterable[str], options: Mapping[str, Mapping[str, object]]
                          | None, metadata: Mapping[str, str]
                          ) -> dict[str, dict[str, object]]:
    """Merge the per-kind options a set's metadata states under the options given (these win)."""
    out = {k: dict(v) for k, v in dict(options or {}).items()}
    for kind in kinds:
        stated = KINDS[kind].options_from_metadata(metadata) if kind in KINDS else {}
        if stated:
            out[kind] = {**stated, **out.get(kind, {})}
    return out
