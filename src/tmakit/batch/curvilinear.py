"""Maximum likelihood for a manoeuvring target (Hörst & Oispuu (2010)): the stable public path.

The estimator itself is the package :mod:`tmakit.batch.manoeuvre`.
"""

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
