"""Adaptive sensor path planning by the predicted posterior CRB.

Hurtado & Nehorai (2008): at each decision, choose the action of a steerable platform that
minimises a criterion of the predicted Bayesian information (eqs. 10-13), under the platform's
kinematic limits and tactical constraints.  See ``docs/planning.md``.

* :class:`Planner`, :class:`Recommendation` — one decision (any horizon).
* :class:`Continuation` (:mod:`~tmakit.planning.horizon`) — score a horizon's sequences at the
  mission end; ``Planner(horizon=H, beam=B)`` searches the tree with a beam.
* :class:`MissionPlanner`, :class:`MissionPlan` (:mod:`~tmakit.planning.mission`) — the rest
  of the mission as legs, optimised for the final bound, re-planned each leg.
* :func:`recommend` — one decision from a user's own tracker and platform.
* :class:`Belief` — the bound so far and the tracker's target cloud.
* :class:`SensorPlan` — what the sensor measures in each step.
* Criteria: :class:`WeightedTrace` (eq. 12), :class:`LogDet`, :class:`CustomCriterion`.
* Constraints: :class:`MinimumRange`, :class:`MaximumRange`, :class:`KeepOutZones`,
  :class:`OperatingArea`.
"""

from .belief import Belief, cubature_points
from .candidates import expected_information, step_information
from .constraints import KeepOutZones, MaximumRange, MinimumRange, OperatingArea, Violation
from .criteria import CustomCriterion, LogDet, WeightedTrace, criterion_from_name
from .horizon import Continuation, SearchResult
from .measurement_plan import SensorPlan
from .mission import MissionPlan, MissionPlanner
from .planner import Planner, Recommendation, position_bound
from .recommend import recommend

__all__ = [
    "Belief",
    "Continuation",
    "CustomCriterion",
    "KeepOutZones",
    "LogDet",
    "MaximumRange",
    "MinimumRange",
    "MissionPlan",
    "MissionPlanner",
    "OperatingArea",
    "Planner",
    "Recommendation",
    "SearchResult",
    "SensorPlan",
    "Violation",
    "WeightedTrace",
    "criterion_from_name",
    "cubature_points",
    "expected_information",
    "position_bound",
    "recommend",
    "step_information",
]
