"""Maximum likelihood for a manoeuvring target, manoeuvres unknown in number and times.

Piecewise curvilinear motion (Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9).  For each order M the
change-over times are profiled over a grid, the best minima refined with every parameter free
(:mod:`.search`); the order is chosen by BIC (Schwarz 1978) or sequential likelihood-ratio
tests, and unneeded accelerations are held at zero (:mod:`.selection`).  docs/estimation.md
describes the search and its tests.  Modules: :mod:`.settings`, :mod:`.grid`, :mod:`.search`,
:mod:`.selection`, :mod:`.report`, :mod:`.estimator` (entry points), :mod:`.method`
(:class:`ManoeuvreEstimator`).

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-5, 8-9.  Schwarz, G. (1978). Estimating the dimension of a
model (BIC).
"""

from .estimator import estimate_for, estimate_manoeuvres
from .method import ManoeuvreEstimator
from .report import ManoeuvreEstimate
from .search import ManoeuvreSearch
from .selection import OrderSelection, may_hold, select_order, sparsify
from .settings import ACCELERATIONS, CRITERIA, ManoeuvreSettings, OrderFit

__all__ = ["ACCELERATIONS", "CRITERIA", "ManoeuvreEstimate", "ManoeuvreEstimator",
           "ManoeuvreSearch",
           "ManoeuvreSettings", "OrderFit", "OrderSelection", "estimate_for",
           "estimate_manoeuvres", "may_hold", "select_order", "sparsify"]
