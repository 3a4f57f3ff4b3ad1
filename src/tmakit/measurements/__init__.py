"""Measurement kinds: one file per kind, each with ``predict`` and an analytic ``jacobian``."""

from __future__ import annotations

from collections.abc import Mapping

from .azimuth_rate import AzimuthRate
from .base import Jacobian, MeasurementModel, ValueRange
from .bearing import Bearing
from .elevation import Elevation
from .frequency import Frequency
from .power import Power
from .range import Range
from .range_difference import RangeDifference, interval_count, range_difference_covariance
from .range_rate import RangeRate

KINDS: dict[str, type[MeasurementModel]] = {
    cls.kind: cls
    for cls in (Bearing, Elevation, AzimuthRate, Range, RangeRate, Frequency, Power,
                RangeDifference)
}
"""Every measurement kind by its file name: a new kind is one file (a
:class:`MeasurementModel` subclass with its hooks) plus its entry here."""

__all__ = [
    "KINDS",
    "AzimuthRate",
    "Bearing",
    "Elevation",
    "Frequency",
    "Jacobian",
    "MeasurementModel",
    "Power",
    "Range",
    "RangeDifference",
    "RangeRate",
    "ValueRange",
    "interval_count",
    "model_for",
    "range_difference_covariance",
]


def model_for(kind: str, options: Mapping[str, object] | None = None) -> MeasurementModel:
    """Build the measurement model of a kind.

    Parameters
    ----------
    kind : str
        A key of :data:`KINDS` ("bearing", "frequency", ...).
    options : mapping, optional
        The kind's options, as in the per-kind ``options=`` of the estimators
        (``{"drift": True}`` for a frequency, ``{"exponent": None}`` for a power); an
        option the kind does not take is a ``TypeError`` naming it.

    Returns
    -------
    MeasurementModel
        The model, working in SI units.

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
