"""Receding-horizon search over ``H`` decision steps: a beam over the action tree.

A node is scored by the criterion of its predicted information (Hurtado & Nehorai (2008),
eq. 12) at its depth, or at the mission end with a :class:`Continuation`; ``beam`` keeps the best
nodes of each depth (``A^H`` sequences otherwise: 3375 for the paper's 15 actions at ``H = 3``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

from ..bounds.pcrb_recursion import predict_information
from ..core.arrays import Array
from ..sensors.platform import Actions, PlatformKinematics, PlatformState, Step
from .belief import Belief
from .candidates import step_information
from .constraints import Violation
from .criteria import Criterion
from .measurement_plan import SensorPlan


class Planner(Protocol):
    """What the search needs of a planner (:class:`tmakit.planning.Planner` is one)."""

    @property
    def kinematics(self) -> PlatformKinematics:  # noqa: D102
        ...

    @property
    def actions(self) -> Actions:  # noqa: D102
        ...

    @property
    def interval(self) -> float:  # noqa: D102
        ...

    @property
    def plan(self) -> SensorPlan:  # noqa: D102
        ...

    @property
    def criterion(self) -> Criterion:  # noqa: D102
        ...

    @property
    def horizon(self) -> int:  # noqa: D102
        ...

    def expand(self, platform: PlatformState, information: Array, belief: Belief,  # noqa: D102
               depth: int, gamma: Literal["mean", "cloud"]
               ) -> tuple[Step, Array, list[Violation]]:
        ...


ContinuationMode = Literal["straight", "hold", "coast"]
CONTINUATION_MODES: tuple[str, ...] = ("straight", "hold", "coast")


def penalties(violations: Sequence[Violation], size: int) -> tuple[Array, Array]:
    """Return the cost factor and the total hard violation (m) per candidate."""
    factor = np.ones(size)
    bad = np.zeros(size)
    for v in violations:
        if v.hard:
            bad = bad + v.amount * v.violated
        else:
            factor = factor * v.penalty_factor()
    return factor, bad


@dataclass(frozen=True)
class Continuation:
    """The default path beyond the horizon, to score a node at the mission end.

    Parameters
    ----------
    end_time : float
        The mission end, s: nodes are scored by the criterion of ``J`` there.
    mode : {"straight", "hold", "coast"}, optional
        ``"straight"``: hold heading and speed; ``"hold"``: keep the node's last turn rate
        (circles); ``"coast"``: predict ``J`` to ``end_time`` without measurements.
    samples : int, optional
        Most measurement instants used for the continuation.

    Raises
    ------
    ValueError
        On an unknown mode or ``samples < 1``.
    """

    end_time: float
    mode: ContinuationMode = "straight"
    samples: int = 20

    def __post_init__(self) -> None:
        """Check the settings."""
        if self.mode not in CONTINUATION_MODES:
            raise ValueError(f"continuation mode must be one of {', '.join(CONTINUATION_MODES)}"
                             f"; got {self.mode!r}")
        if int(self.samples) != self.samples or self.samples < 1:
            raise ValueError(f"continuation samples must be a whole number >= 1; got "
                             f"{self.samples!r}")

    def thinned_plan(self, plan: SensorPlan, interval: float, remaining: float
                     ) -> SensorPlan | None:
        """Return the plan of the continuation's measurements over ``remaining`` s.

        Parameters
        ----------
        plan : SensorPlan
            What is measured per decision step of ``interval`` s.
        interval, remaining : float
            The decision interval and the time left to :attr:`end_time`, s.

        Returns
        -------
        SensorPlan or None
            Times in ``(0, remaining]``; None when nothing is measured.
        """
        steps = int(np.floor(remaining / interval + 1e-9))
        if self.mode == "coast" or steps < 1:
            return None
        per_step = plan.measurement_times(interval)
        times = (interval * np.arange(steps)[:, None] + per_step[None, :]).ravel()
        weight = 1.0
        if times.size > self.samples:
            weight = times.size / self.samples
            times = remaining * np.arange(1, self.samples + 1) / self.samples
        cov = None if plan.covariance is None else plan.covariance / weight
        return SensorPlan(plan.kinds, plan.sigmas / np.sqrt(weight), plan.dim,
                          times=tuple(times), covariance=cov, options=plan.options,
                          nuisance=plan.nuisance)

    def information(self, planner: Planner, ends: PlatformState, turn_rate: Array,
                    information: Array, belief: Belief) -> Array:
        """Return ``J`` at :attr:`end_time` of every node continued by the default path.

        Parameters
        ----------
        planner : Planner
            Supplies the kinematics, the plan and the interval.
        ends : PlatformState
            The nodes' platform states (batch shape ``B``), all at one time.
        turn_rate : ndarray, shape B
            The nodes' last turn rate, rad/s (used by ``"hold"``).
        information : ndarray, shape (*B, n, n)
            ``J`` at the nodes.
        belief : Belief
            The decision's belief (its cloud is predicted to the nodes' time).

        Returns
        -------
        ndarray, shape (*B, n, n)
        """
        remaining = self.end_time - ends.time
        if remaining <= 1e-9:
            return information
        f = belief.posterior.dynamics.transition(ends.time - belief.time)
        cloud = (belief.states @ f.T, belief.weights)
        thin = self.thinned_plan(planner.plan, planner.interval, remaining)
        if thin is None:
            f_inv, g = belief.posterior.step_factors(remaining)
            return predict_information(information, f_inv, g)
        turn = turn_rate * remaining if self.mode == "hold" else np.zeros(ends.shape)
        path = planner.kinematics.step(ends, Actions(turn), remaining)
        sensor = path.sensor_states(ends.time + thin.measurement_times(remaining))
        return step_information(belief, information, thin, sensor, remaining, "mean", cloud)


@dataclass(frozen=True, eq=False)
class SearchResult:
    """What :func:`search` found.

    Attributes
    ----------
    cost : ndarray, shape (A,)
        Best leaf cost over the sequences that start with each first action (``inf`` where
        the beam dropped every one of them).
    bad : ndarray, shape (A,)
        Total hard violation (m) of that leaf (``inf`` where dropped).
    sequence : ndarray of int, shape (H,)
        The best sequence's action indices.
    nodes : int
        Nodes whose information was computed (the work done).
    """

    cost: Array
    bad: Array
    sequence: Array
    nodes: int


def _score(planner: Planner, continuation: Continuation | None, ends: PlatformState,
           turn_rate: Array, info: Array, factor: Array, belief: Belief) -> Array:
    if continuation is not None:
        info = continuation.information(planner, ends, turn_rate, info, belief)
    return planner.criterion(info) * factor


def search(planner: Planner, ends: PlatformState, turn_rate: Array, information: Array,
           belief: Belief, factor: Array, bad: Array, beam: int | None = None,
           continuation: Continuation | None = None) -> SearchResult:
    """Search the action tree of ``planner.horizon`` steps from the first step's candidates.

    References
    ----------
    Hurtado & Nehorai (2008), eq. 12 (the criterion; the paper's horizon is one step).
    """
    if beam is not None and (int(beam) != beam or beam < 1):
        raise ValueError(f"beam must be a whole number >= 1 or None; got {beam!r}")
    a = len(planner.actions)
    first = np.arange(a)
    paths = first[:, None]
    nodes = a
    for depth in range(1, planner.horizon):
        if beam is not None and paths.shape[0] > beam:
            score = _score(planner, continuation, ends, turn_rate, information, factor,
                           belief)
            keep = np.lexsort((score, bad))[:int(beam)]
            ends, turn_rate, information = ends[keep], turn_rate[keep], information[keep]
            factor, bad, paths = factor[keep], bad[keep], paths[keep]
            if continuation is not None:
                nodes += keep.size
        steps, info, viol = planner.expand(ends, information, belief, depth, "mean")
        f_new, bad_new = penalties(viol, steps.turn_rate.size)
        m = paths.shape[0]
        factor = (factor[:, None] * f_new.reshape(m, a)).ravel()
        bad = (bad[:, None] + bad_new.reshape(m, a)).ravel()
        paths = np.concatenate([np.repeat(paths, a, axis=0),
                                np.tile(np.arange(a), m)[:, None]], axis=1)
        ends, turn_rate = _flat(steps.end), steps.turn_rate.ravel()
        information = info.reshape(m * a, *info.shape[-2:])
        nodes += m * a
    leaf = _score(planner, continuation, ends, turn_rate, information, factor, belief)
    cost = np.full(a, np.inf)
    worst = np.full(a, np.inf)
    order = np.lexsort((leaf, bad))
    firsts, at = np.unique(paths[order, 0], return_index=True)   # best leaf per first action
    cost[firsts], worst[firsts] = leaf[order[at]], bad[order[at]]
    return SearchResult(cost, worst, paths[order[0]], nodes)


def _flat(state: PlatformState) -> PlatformState:
    """Flatten a batch of platform states to one axis."""
    return PlatformState(state.position.reshape(-1, 3), state.heading.ravel(),
                         state.speed.ravel(), state.climb_rate.ravel(), state.time)
