"""The ``[planning]`` table of a scenario file: a steerable sensor, its limits and its planner.

The table's pydantic schema (Hurtado & Nehorai (2008) planning; ``docs/planning.md`` lists every
field with its unit), validated inside :class:`~tmakit.scenario.files.ScenarioSpec`;
:mod:`tmakit.planning.setup` builds the planner from it.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from ..core.units import REACH_M, SPEED_OF_LIGHT

#: Trackers a ``[planning]`` table may name (keys of :data:`tmakit.filters.FILTERS`).
PLANNING_TRACKERS = ("pf", "ekf", "ukf")
#: Most decisions of one run a duration may ask for (the per-step table holds a row each;
#: 1e11 ran out of memory).
MAX_DECISIONS = 1_000_000


def decisions_text(count: int) -> str:
    """Say a number of decisions: with thousands separators, or 1e+299 beyond 15 digits."""
    return f"{count:,}" if count < 10**15 else f"{count:.3g}"
#: The planners a ``[planning]`` table may name; ``"auto"`` is the mission planner for a
#: passive sensor (:func:`tmakit.planning.policies.passive`), else the horizon planner.
PLANNERS = ("auto", "mission", "horizon")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)  # NaN/inf: refused


class LimitsSpec(_Strict):
    """``[planning.limits]``: the platform's limits (each optional; default: none)."""

    min_speed: float | None = Field(default=None, ge=0)
    max_speed: float | None = Field(default=None, gt=0)
    max_turn_rate_deg_s: float | None = Field(default=None, ge=0)
    max_acceleration: float | None = Field(default=None, ge=0)
    max_climb_rate: float | None = Field(default=None, ge=0)
    min_altitude: float | None = None
    max_altitude: float | None = None


class ActionsSpec(_Strict):
    """``[planning.actions]``: the candidate actions of every decision (all combinations)."""

    heading_changes_deg: list[float] = Field(min_length=1)
    speed_factors: list[Annotated[float, Field(gt=0)]] = Field(default=[1.0], min_length=1)
    climb_rates: list[float] | None = Field(default=None, min_length=1)


class PlannedMeasurementSpec(_Strict):
    """``[[planning.measurements]]``: one row measured at the end of every step."""

    kind: str
    sigma: float = Field(gt=0, description="in the kind's file unit")


class PriorSpec(_Strict):
    """``[planning.prior]``: the tracker's and the bound's Gaussian prior about the truth."""

    # Within a state's reach (tmakit.rules): beyond, the variance overflowed (1e300 m/s).
    position_std: float = Field(gt=0, le=REACH_M)
    velocity_std: float = Field(gt=0, le=SPEED_OF_LIGHT)


Vertex = Annotated[list[float], Field(min_length=2, max_length=2)]
Polygon = Annotated[list[Vertex], Field(min_length=3)]


class RangeConstraintSpec(_Strict):
    """A ``min_range`` or ``max_range`` constraint to the estimated target."""

    type: Literal["min_range", "max_range"]
    distance: float = Field(gt=0)
    hard: bool = True
    weight: float | None = Field(default=None, ge=0)


class KeepOutSpec(_Strict):
    """Keep-out zones: ``polygons`` ([east, north] m) or ``polygons_geodetic`` ([lat, lon] deg)."""

    type: Literal["keep_out"]
    polygons: list[Polygon] | None = Field(default=None, min_length=1)
    polygons_geodetic: list[Polygon] | None = Field(default=None, min_length=1)
    hard: bool = True
    weight: float | None = Field(default=None, ge=0)


class AreaSpec(_Strict):
    """The operating area: ``polygon`` ([east, north] m) or ``polygon_geodetic`` ([lat, lon])."""

    type: Literal["operating_area"]
    polygon: Polygon | None = None
    polygon_geodetic: Polygon | None = None
    hard: bool = True
    weight: float | None = Field(default=None, ge=0)


ConstraintSpec = Annotated[RangeConstraintSpec | KeepOutSpec | AreaSpec,
                           Field(discriminator="type")]


class MissionSpec(_Strict):
    """``[planning.mission]``: the mission planner's legs and range hypotheses."""

    leg_duration: float | None = Field(default=None, gt=0)
    hypotheses: int = Field(default=3, ge=1, le=9)


class PlanningSpec(_Strict):
    """The ``[planning]`` table, validated (``docs/planning.md`` lists every field)."""

    sensor: str
    planner: Literal["auto", "mission", "horizon"] = "auto"
    mission: MissionSpec = MissionSpec()
    platform: str | None = None
    limits: LimitsSpec = LimitsSpec()
    actions: ActionsSpec | None = None
    interval: float | None = Field(default=None, gt=0)
    measurements: list[PlannedMeasurementSpec] | None = Field(default=None, min_length=1)
    criterion: Literal["trace", "logdet"] = "trace"
    weights: list[float] | list[list[float]] | None = None
    gamma: Literal["mean", "cloud"] = "mean"
    horizon: int = Field(default=1, ge=1, le=4)
    constraints: list[ConstraintSpec] = []
    tracker: Literal["pf", "ekf", "ukf"] = "pf"
    particles: int = Field(default=2000, ge=2)
    q: float = Field(default=0.0, ge=0, description="m/s^2")
    prior: PriorSpec
    duration: float = Field(gt=0)
    runs: int = Field(default=10, ge=1)
    start_time: float | None = None
