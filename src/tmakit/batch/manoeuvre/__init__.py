"""Maximum likelihood for a manoeuvring target, manoeuvres unknown in number and times.

Piecewise curvilinear motion (Hörst & Oispuu (2010), §2, eqs. 1-5, 8).

:func:`~.estimator.estimate_manoeuvres` (``meas, max_manoeuvres=2``) fits the models with
``M = 0, 1, ..., max_manoeuvres`` manoeuvres, no initial guess needed, and chooses ``M`` by a
stated criterion.

**The fit for one order M** (the ML estimate is the weighted least-squares fit, Hörst & Oispuu
(2010), eq. 8; any nuisance parameters — carrier, power constant — are eliminated exactly as in
:mod:`tmakit.batch.varpro`, and every fit is a run of the shared solver
:func:`tmakit.batch.solver.levenberg_marquardt`):

1. ``M = 0`` starts from tmakit's no-guess constant-velocity fit
   (:func:`tmakit.batch.ml.estimate` with ``cv2d``), whose position, speed and course at the
   first measurement time start a curvilinear fit with zero accelerations.
2. ``M >= 1``: the change-over times are found by **profile likelihood over a grid**.  Every
   ordered tuple ``t_1 < ... < t_M`` of grid times (``grid_step`` apart, at least
   ``min_segment`` from the ends of the data and from each other) gets a fit of all other
   parameters with the change-over times held; the fits run in one batch.  Each is
   warm-started from the order ``M - 1`` profile fit at the tuple with one time removed (the
   best of the ``M`` such tuples), the removed segment split in two with equal accelerations,
   so the start reproduces that fit exactly and the held fit can only improve on it.
3. The best ``refine`` local minima of the profile are **refined with every parameter free**
   (Levenberg–Marquardt, change-over times included; they stay inside the data span and in
   order), together with the order ``M - 1`` fit with its longest segment split in two (the
   same trajectory, so chi2 never grows with the order).  The lowest cost wins.  A finer
   profile of each change-over time around it (4 s steps within one grid step) then catches
   the neighbouring dips of a likelihood that has a corner at every measurement time
   (:meth:`~.search.ManoeuvreSearch.polish`, :meth:`~.search.ManoeuvreSearch.settle`).

The likelihood is continuous in the change-over times (position and velocity are continuous
through a change-over; only the acceleration jumps).  Bearings alone make it once
differentiable too, but a predicted azimuth rate depends on the velocity at its sample, whose
derivative with respect to ``t_m`` jumps as ``t_m`` crosses the sample: the likelihood has a
corner at every measurement time and is bumpy on that scale near its minimum.  The grid only
has to land in the right basin (its 40 s spacing is 2-4 times the change-over times' CRB in the
Hörst & Oispuu (2010) scenario, 10-19 s); the refinement, the finer profile and the corner test
do the rest.  The search is tested against fits started at the truth in
``benchmarks/montecarlo_hoerst2010.py``.

**The order.**  The models are nested (``M`` manoeuvres contain ``M - 1`` as equal neighbouring
accelerations), each manoeuvre adds three unknowns ``a_t, a_n, t_m``.  Two criteria:

* ``"bic"`` (default): minimise ``chi2_M + k_M ln N`` (Schwarz's Bayesian information
  criterion; ``k_M`` unknowns, ``N`` independent measurements) — a manoeuvre must lower chi2
  by ``3 ln N`` (22.5 for the 1802 measurements of that scenario).
* ``"lrt"``: sequential likelihood-ratio tests: ``M + 1`` replaces ``M`` while
  ``chi2_M - chi2_{M+1}`` exceeds the ``1 - alpha`` quantile of chi-square with 3 degrees of
  freedom.  The reference distribution is approximate: under ``M`` the extra change-over time
  is not identified (Davies' problem), and the supremum over it makes the statistic larger than
  chi-square(3), so the test is liberal (it finds spurious manoeuvres more often than
  ``alpha``).  BIC's threshold is well above that supremum for realistic data sizes.

**The accelerations** (``accelerations="select"``, the default).  Each segment's ``a_t`` and
``a_n`` are unknowns of Hörst & Oispuu's model, but most legs are straight or turn at constant
speed.  After each order's fit, the components the data do not need are held at zero by backward
elimination with the same criterion — one unknown fewer must not raise chi2 by ``ln N`` (BIC)
or by the chi-square(1) quantile (likelihood-ratio test); two holds are kept together when they
raise chi2 by less than twice that — and the change-over times are then profiled again
(:func:`~.selection.sparsify`).  It matters: with every acceleration free, a turn
that ends earlier and continues as a gentle turn competes with the true one, and in the Hörst &
Oispuu scenario the ML change-over times missed their CRB (RMSE 1.6x and 2.2x it); with the
components selected they are at 0.72x and 0.52x it, and within 1.11x of the bound of the
selected model in the runs that select the truth's zeros (``docs/estimation.md``).
``"all"`` fits every component (Hörst & Oispuu as written).  Held components are listed in the
result (``held``), with value and std 0; the covariance is the inverse information of the
fitted ones.

Every order's chi2, number of unknowns, BIC, likelihood-ratio statistic and p-value are
reported, with the chosen ``M``.  The covariance of the chosen fit is the inverse Fisher
information at the estimate (Hörst & Oispuu (2010), eq. 9, computed with
:func:`tmakit.results.bound.bound_from_information`), so each
change-over time comes with its standard deviation, and so does the position at any time
(the delta method, :meth:`tmakit.results.bound.Bound.derived`).

**The modules, by job.**  :mod:`.settings` (what the estimator is told, what it keeps of an
order), :mod:`.grid` and :mod:`.search` (the change-over-time search), :mod:`.selection` (the
order and the accelerations), :mod:`.report` (the result), :mod:`.estimator` (the entry
points, also at their historical path :mod:`tmakit.batch.curvilinear`), :mod:`.method` (the
estimator as an object, :class:`ManoeuvreEstimator`).

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
