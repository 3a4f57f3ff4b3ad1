"""What steers the sensor in the closed loop: a fixed action, a given path, the mission planner.

:class:`~tmakit.planning.Planner` (Hurtado & Nehorai (2008)), :class:`FixedPolicy` (one action
every decision), :class:`TrackPolicy` (a given sensor track, flown step by step) and
:class:`MissionPolicy` (the :class:`~tmakit.planning.MissionPlanner` re-planned every leg over
range hypotheses drawn from the tracker).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..sensors.platform import Actions, PlatformKinematics, PlatformState, Step
from ..sensors.tracks import SensorTrack
from .belief import Belief
from .candidates import step_information
from .constraints import Constraint
from .measurement_plan import SensorPlan
from .mission import MissionPlan, MissionPlanner
from .planner import position_bound, step_violations

__all__ = ["RANGE_KINDS", "Choice", "FixedChoice", "FixedPolicy", "MissionPolicy", "Policy",
           "TrackPolicy", "for_run", "passive", "range_hypotheses"]

#: Kinds that measure range: a sensor without them is passive.
RANGE_KINDS = ("range",)


def passive(plan: SensorPlan) -> bool:
    """Tell whether a sensor plan measures no range (its range comes from the path's geometry)."""
    return not any(k in RANGE_KINDS for k in plan.kinds)


class Choice(Protocol):
    """What a policy returns (:class:`~tmakit.planning.Recommendation` and :class:`FixedChoice`)."""

    @property
    def index(self) -> int:  # noqa: D102
        ...

    @property
    def step(self) -> Step:  # noqa: D102
        ...

    @property
    def bound(self) -> Array:  # noqa: D102
        ...

    @property
    def violations(self) -> Mapping[str, Array]:  # noqa: D102
        ...


class Policy(Protocol):
    """What chooses the next step."""

    def recommend(self, platform: PlatformState, belief: Belief) -> Choice:
        """Choose the next action from ``platform`` given ``belief``."""


def for_run(policy: Policy) -> Policy:
    """Return the policy to use for one run: a fresh copy of a policy with state, else itself."""
    fresh = getattr(policy, "for_run", None)
    return fresh() if callable(fresh) else policy


@dataclass(frozen=True)
class FixedChoice:
    """The choice of a policy with one candidate (fields as a planner's recommendation)."""

    index: int  # Always 0
    step: Step  # The flown step
    #: The policy's predicted position RMS bound (m): after the step, or at the mission end for
    #: :class:`MissionPolicy`; shape (1,)
    bound: Array
    #: Per constraint, the amount (m) of the flown step, shape (1,); empty without constraints
    violations: Mapping[str, Array] = field(default_factory=dict)


def _bound_after(belief: Belief, plan: SensorPlan, step: Step, interval: float) -> Array:
    """Predict the position bound after one flown step (eq. 10, Xi at the mean), shape (1,)."""
    times = step.start.time + plan.measurement_times(interval)
    info = step_information(belief, belief.posterior.information, plan,
                            step.sensor_states(times)[None], interval, "mean")
    return position_bound(info)


@dataclass(frozen=True)
class FixedPolicy:
    """Fly one action at every decision (the straight fixed path: heading change 0)."""

    kinematics: PlatformKinematics  # The platform's limits
    plan: SensorPlan  # The measurements, for the predicted bound of the step
    interval: float = 0.5  # Decision interval (s)
    #: One action (default: straight on, speed unchanged)
    action: Actions = field(default_factory=lambda: Actions([0.0]))

    def recommend(self, platform: PlatformState, belief: Belief) -> FixedChoice:
        """Fly :attr:`action`; the bound is the mean-state prediction of eq. 10."""
        step = self.kinematics.step(platform, self.action[:1], self.interval)[0]
        return FixedChoice(0, step, _bound_after(belief, self.plan, step, self.interval))


@dataclass(frozen=True, eq=False)
class TrackPolicy:
    """Fly a given sensor track: the scenario's fixed pattern, step by step.

    Each step ends where the track is one interval later, joined by the constant turn between the
    headings (exact for a zig-zag's legs).
    """

    #: The path (for example ``scenario.sensors["observer"]``); it must cover the run
    track: SensorTrack
    plan: SensorPlan  # The measurements, for the predicted bound of the step
    interval: float  # Decision interval (s)
    #: Checked along each step against the estimated target and reported (never acted on: the path
    #: is fixed)
    constraints: Sequence[Constraint] = ()

    def recommend(self, platform: PlatformState, belief: Belief) -> FixedChoice:
        """Fly the track for one interval."""
        t = platform.time + self.interval
        s = self.track.states(np.array([t]))[0]
        end = PlatformState.from_velocity(s[:3], s[3:], t)
        turn = float(np.angle(np.exp(1j * (end.heading - platform.heading)))) / self.interval
        no = np.zeros((), dtype=bool)
        step = Step(platform, end, np.asarray(turn),
                    np.asarray((end.speed - platform.speed) / self.interval),
                    np.asarray(end.climb_rate), float(self.interval), no, no, no, no)
        found = step_violations(self.constraints, step, belief, self.interval)
        return FixedChoice(0, step, _bound_after(belief, self.plan, step, self.interval),
                           {v.name: v.amount for v in found})


def range_hypotheses(belief: Belief, position: ArrayLike, quantiles: ArrayLike) -> Belief:
    """Return the members of the belief's cloud at weighted quantiles of range, equally weighted."""
    rel = belief.states[:, :2] - np.asarray(position, dtype=float)[:2]
    order = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")
    cum = np.cumsum(belief.weights[order])
    at = np.minimum(np.searchsorted(cum, np.asarray(quantiles, dtype=float)), order.size - 1)
    return Belief(belief.posterior, belief.states[order[at]])


@dataclass(frozen=True, eq=False)
class MissionPolicy:
    """The mission planner in the closed loop: re-plan the rest of the mission at every leg.

    Parameters
    ----------
    planner : MissionPlanner
        Its ``step`` must be the loop's decision interval.
    quantiles : tuple of float, optional
        The range quantiles of the hypotheses.
    pattern : SensorTrack, optional
        An operator's path: its heading at the middle of every leg left is one more start.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13; the ranges: ``benchmarks/planning_passive_mc.py``.
    """

    planner: MissionPlanner
    quantiles: tuple[float, ...] = (1 / 6, 1 / 2, 5 / 6)
    pattern: SensorTrack | None = None

    def __post_init__(self) -> None:
        """Check the quantiles."""
        q = tuple(float(v) for v in self.quantiles)
        if not q or not all(0.0 < v < 1.0 for v in q):
            raise ValueError(f"quantiles must be values in (0, 1); got {self.quantiles!r}")
        object.__setattr__(self, "quantiles", q)

    def for_run(self) -> _MissionRun:
        """Return the policy's state for one run (the loop calls it)."""
        return _MissionRun(self)

    def recommend(self, platform: PlatformState, belief: Belief) -> FixedChoice:
        """Refuse: a mission policy keeps state, use ``for_run().recommend``."""
        raise TypeError("a MissionPolicy keeps the plan between decisions: call "
                        "for_run() once per run and recommend() on what it returns")


@dataclass(eq=False)
class _MissionRun:
    """One run of a :class:`MissionPolicy`: the plan, the legs flown, the sub-steps left."""

    policy: MissionPolicy
    start: tuple[PlatformState, Belief] | None = None
    plan: MissionPlan | None = None
    flown: list[float] = field(default_factory=list)
    queue: list[Actions] = field(default_factory=list)

    def recommend(self, platform: PlatformState, belief: Belief) -> FixedChoice:
        mp = self.policy.planner
        if self.start is None:
            self.start = (platform, belief)
        if not self.queue:
            self._replan(platform, belief)
        step = mp.kinematics.step(platform, self.queue.pop(0), mp.step)
        found = step_violations(mp.constraints, step, belief, mp.step)
        assert self.plan is not None
        return FixedChoice(0, step[0], np.array([self.plan.bound]),
                           {v.name: v.amount for v in found})

    def _replan(self, platform: PlatformState, belief: Belief) -> None:
        mp = self.policy.planner
        info: Any = None
        if mp.hypotheses:
            belief = range_hypotheses(belief, platform.position, self.policy.quantiles)
            info = self._flown_information(belief)
        pattern = None
        if self.policy.pattern is not None:
            starts, counts = mp.legs(belief.time)
            middle = starts + 0.5 * counts * mp.step
            s = self.policy.pattern.states(middle)
            pattern = np.arctan2(s[:, 3], s[:, 4])
        self.plan = mp.recommend(platform, belief, previous=self.plan, pattern=pattern,
                                 information=info)
        self.flown.append(float(self.plan.headings[0]))
        acts = mp.first_leg(platform, self.plan)
        self.queue = [acts[i:i + 1] for i in range(acts.shape[0])]

    def _flown_information(self, hyp: Belief) -> Array | None:
        """``J`` along the legs flown so far at each hypothesis, from the prior (K, n, n)."""
        if not self.flown:
            return None
        assert self.start is not None
        platform0, belief0 = self.start
        past = replace(self.policy.planner, end_time=hyp.time, constraints=())
        dyn = hyp.posterior.dynamics
        back = hyp.states @ dyn.transition(belief0.time - hyp.time).T
        return past.evaluate(platform0, Belief(belief0.posterior, back),
                             np.array(self.flown)[None])[0]
