"""Maximum likelihood for a manoeuvring target: the estimator's stable public path.

Piecewise curvilinear motion, Hörst & Oispuu (2010); the path is kept for ``tk.estimate`` and
for users.

The estimator itself is the package :mod:`tmakit.batch.manoeuvre` (the method is described
there): its search (:mod:`~tmakit.batch.manoeuvre.search`), order and acceleration selection
(:mod:`~tmakit.batch.manoeuvre.selection`) and result (:mod:`~tmakit.batch.manoeuvre.report`).
Motion names are read by :func:`tmakit.motion.motion_from_name` only.
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
