"""The parts of a mission plan: the plan, candidate rollouts, batches of platform states.

Split from :mod:`tmakit.planning.mission` (which re-exports :class:`MissionPlan`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.arrays import Array
from ..sensors.platform import Actions, PlatformState
from .constraints import Violation
from .criteria import Criterion
from .horizon import penalties


@dataclass(frozen=True, eq=False)
class MissionPlan:
    """A planned remaining path.

    Attributes
    ----------
    headings : ndarray, shape (L,)
        Commanded heading of each leg, rad (clockwise from North).
    speeds : ndarray, shape (L,)
        Commanded speed of each leg, m/s.
    leg_starts : ndarray, shape (L,)
        Start time of each leg, s.
    cost : float
        The criterion of the predicted final information.
    bound : float
        Predicted final position RMS bound, m.
    information : ndarray, shape (n, n)
        Predicted Bayesian information at the mission end, SI (shape (K, n, n), one per
        target hypothesis, when planned with hypotheses; ``bound`` is then their RMS).
    actions : Actions, shape (K,)
        The sub-step actions that fly the path (``kinematics.fly(platform, actions, step)``).
    evaluations : int
        Candidate paths (each from some leg to the end) scored by the search.
    violations : dict of str to float
        Per constraint, the largest predicted violation along the path (m, 0 where kept).
    feasible : bool
        False when no path the search tried kept every hard constraint (the least violating
        was chosen).
    """

    headings: Array
    speeds: Array
    leg_starts: Array
    cost: float
    bound: float
    information: Array
    actions: Actions
    evaluations: int
    violations: dict[str, float] = field(default_factory=dict)
    feasible: bool = True


@dataclass(frozen=True, eq=False)
class Rollout:
    """Candidate paths (C,) flown from one leg to the mission end.

    Attributes
    ----------
    information : ndarray, shape (C, n, n) or (C, K, n, n)
        ``J`` at the end (per target hypothesis when 4-D), SI.
    leg_states : list of PlatformState
        Batch (C,) at the start of each leg flown.
    leg_info : list of ndarray
        ``J`` (as ``information``) at the start of each leg flown, SI.
    actions : list of Actions
        Batch (C,) per sub-step.
    end : PlatformState
        Batch (C,) at the end.
    violations : list of Violation
        Per constraint, the largest along each path (C,), m.
    hard : ndarray, shape (C,)
        Hard violations summed over the sub-steps, m.
    weights : ndarray, shape (K,), optional
        Weights of the hypotheses, when ``information`` has them.
    """

    information: Array
    leg_states: list[PlatformState]
    leg_info: list[Array]
    actions: list[Actions]
    end: PlatformState
    violations: list[Violation]
    hard: Array
    weights: Array | None = None

    def ranked_cost(self, criterion: Criterion) -> tuple[Array, Array]:
        """Return the cost with penalties and the summed hard violation per path.

        With hypotheses, the cost of a path is the weighted mean of the criterion over them.

        Parameters
        ----------
        criterion : Criterion
            Cost of one ``J``.

        Returns
        -------
        cost : ndarray, shape (C,)
            The criterion times the penalty factors.
        hard : ndarray, shape (C,)
            Summed hard violation, m.
        """
        factor, _ = penalties(self.violations, self.information.shape[0])
        return path_cost(criterion, self.information, self.weights) * factor, self.hard


def path_cost(criterion: Criterion, information: Array, weights: Array | None) -> Array:
    """Return the criterion of each path's information (C,).

    Parameters
    ----------
    criterion : Criterion
        Cost of one ``J``.
    information : ndarray, shape (C, n, n) or (C, K, n, n)
        ``J`` of each path, or of each path under each of ``K`` target hypotheses, SI.
    weights : ndarray, shape (K,), optional
        The hypotheses' weights (sum 1); required with ``K``.

    Returns
    -------
    ndarray, shape (C,)
        The criterion, or its weighted mean over the hypotheses (the expected bound).
    """
    cost = criterion(information)
    return cost if weights is None else cost @ weights


def repeat_state(platform: PlatformState, c: int) -> PlatformState:
    """Return ``c`` copies of one platform state.

    Parameters
    ----------
    platform : PlatformState
        Batch shape ``()``.
    c : int
        Copies.

    Returns
    -------
    PlatformState
        Batch shape (c,).
    """
    return PlatformState(np.repeat(platform.position[None, :], c, 0),
                         np.full(c, float(platform.heading)), np.full(c, float(platform.speed)),
                         np.full(c, float(platform.climb_rate)), platform.time)


def repeat_batch(state: PlatformState, g: int) -> PlatformState:
    """Return each of a batch of states repeated ``g`` times.

    Parameters
    ----------
    state : PlatformState
        Batch shape (M,).
    g : int
        Repeats of each.

    Returns
    -------
    PlatformState
        Batch shape (M g,), each state's copies together.
    """
    return PlatformState(np.repeat(state.position, g, 0), np.repeat(state.heading, g),
                         np.repeat(state.speed, g), np.repeat(state.climb_rate, g), state.time)
