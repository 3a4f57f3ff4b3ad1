"""The stable public path of :mod:`tmakit.batch.manoeuvre` (Hörst & Oispuu (2010))."""

from .manoeuvre import (
    ACCELERATIONS,
    CRITERIA,
    ManoeuvreEstimate,
    ManoeuvreSettings,
    OrderFit,
    OrderSelection,
    estimate_for,
    estimate_manoeuvres,
    may_hold,
    select_order,
)

__all__ = ["ACCELERATIONS", "CRITERIA", "ManoeuvreEstimate", "ManoeuvreSettings", "OrderFit",
           "OrderSelection", "estimate_for", "estimate_manoeuvres", "may_hold", "select_order"]
