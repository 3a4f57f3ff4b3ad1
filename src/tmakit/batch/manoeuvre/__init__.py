"""Maximum likelihood for a manoeuvring target, manoeuvres unknown in number and times.

Piecewise curvilinear motion (Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9).  For each order M the
change-over times are profiled over a grid, the best minima refined with every parameter free
(:mod:`.search`); the order is chosen by BIC (Schwarz 1978) or sequential likelihood-ratio
tests, and unneeded accelerations are held at zero (:mod:`.selection`); :mod:`.report` is the
result, :mod:`.estimator` the entry points.  docs/estimation.md describes the search and its
tests.

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9.  Schwarz, G. (1978). Estimating the dimension of a
model (BIC).
"""

from .estimator import ManoeuvreEstimator, estimate_for, estimate_manoeuvres
from .report import ManoeuvreEstimate
from .search import ACCELERATIONS, CRITERIA, ManoeuvreSettings, OrderFit
from .selection import OrderSelection, may_hold, select_order

__all__ = ["ACCELERATIONS", "CRITERIA", "ManoeuvreEstimate", "ManoeuvreEstimator",
           "ManoeuvreSettings", "OrderFit", "OrderSelection", "estimate_for",
           "estimate_manoeuvres", "may_hold", "select_order"]
