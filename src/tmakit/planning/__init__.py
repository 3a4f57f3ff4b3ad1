"""Adaptive sensor path planning by the predicted posterior CRB.

Hurtado & Nehorai (2008): at each decision, choose the action of a steerable platform that minimises
a criterion of the predicted Bayesian information (eqs. 10-13), under the platform's kinematic
limits and tactical constraints.  See ``docs/planning.md``.
"""

from .belief import Belief
from .constraints import KeepOutZones, MaximumRange, MinimumRange, OperatingArea, Violation
from .criteria import CustomCriterion, LogDet, WeightedTrace, criterion_from_name
from .measurement_plan import SensorPlan
from .mission import MissionPlan, MissionPlanner
from .planner import Continuation, Planner, Recommendation, recommend

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
    "SensorPlan",
    "Violation",
    "WeightedTrace",
    "criterion_from_name",
    "recommend",
]
