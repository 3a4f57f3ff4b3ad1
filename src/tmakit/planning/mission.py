"""Mission-level planning: the sensor's remaining path as legs, optimised for the final bound.

A passive sensor's information comes from the geometry of the whole path, so the path is planned
as legs to the mission end, the Bayesian information carried along every candidate at once by the
recursion of Hurtado & Nehorai (2008), eq. 10, and scored by the criterion of the final ``J``.
"""


from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.frames import wrap_angle
from ..sensors.platform import Actions, PlatformKinematics, PlatformState
from .belief import Belief
from .candidates import GammaForm, check_gamma, step_information
from .constraints import Constraint, Violation
from .criteria import Criterion, WeightedTrace
from .measurement_plan import SensorPlan
from .planner import penalties, position_bound, step_violations


@dataclass(frozen=True, eq=False)
class MissionPlan:
    """A planned remaining path.

    Attributes
    ----------
    headings, speeds, leg_starts : ndarray, shape (L,)
        Commanded heading (rad, clockwise from North) and speed (m/s) and start time (s) of
        each leg.
    cost : float
        The criterion of the predicted final information.
    bound : float
        Predicted final position RMS bound, m (the RMS over the hypotheses, if any).
    information : ndarray, shape (n, n) or (K, n, n)
        Predicted Bayesian information at the mission end, SI (one per target hypothesis).
    actions : Actions
        The sub-step actions that fly the path.
    evaluations : int
        Candidate paths scored by the search.
    violations : dict of str to float
        Per constraint, the largest predicted violation along the path, m.
    feasible : bool
        False when no path tried kept every hard constraint (the least violating was chosen).
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
    """Candidate paths (C,) flown from one leg to the mission end."""

    #: ``J`` at the end (per target hypothesis when 4-D), SI; shape (C, n, n) or (C, K, n, n)
    information: Array
    leg_states: list[PlatformState]  # Batch (C,) at the start of each leg flown
    leg_info: list[Array]  # ``J`` (as ``information``) at the start of each leg flown, SI
    actions: list[Actions]  # Batch (C,) per sub-step
    end: PlatformState  # Batch (C,) at the end
    violations: list[Violation]  # Per constraint, the largest along each path (C,), m
    hard: Array  # Hard violations summed over the sub-steps, m; shape (C,)
    #: Weights of the hypotheses, when ``information`` has them; shape (K,)
    weights: Array | None = None

    def ranked_cost(self, criterion: Criterion) -> tuple[Array, Array]:
        """Return the cost with penalties and the summed hard violation per path."""
        factor, _ = penalties(self.violations, self.information.shape[0])
        cost = criterion(self.information)
        return (cost if self.weights is None else cost @ self.weights) * factor, self.hard


def repeat_batch(state: PlatformState, g: int) -> PlatformState:
    """Return each of a batch of states (or one state) repeated ``g`` times."""
    return PlatformState(np.repeat(state.position.reshape(-1, 3), g, 0),
                         np.repeat(state.heading, g), np.repeat(state.speed, g),
                         np.repeat(state.climb_rate, g), state.time)


_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class MissionPlanner:
    """Plan the remaining path as legs to minimise a criterion of the final information.

    Parameters
    ----------
    kinematics : PlatformKinematics
        The platform's limits.
    plan : SensorPlan
        What the sensor measures in each sub-step.
    step : float
        Sub-step, s: legs are flown and measured in sub-steps of this length.
    leg_duration : float
        Length of a leg, s (a whole number of sub-steps).
    end_time : float
        The mission end, s.
    criterion : Criterion, optional
        Cost of the final ``J`` (default :class:`WeightedTrace`, m^2).
    headings : int, optional
        Size of the heading grid of the first sweeps.
    speeds : sequence of float, optional
        Allowed leg speeds, m/s (default: hold the current speed).
    sweeps : int, optional
        Most sweeps over the legs per grid.
    refine : int, optional
        Rounds of finer offsets after the coarse grid (each halves the spacing).
    gamma : {"mean", "cloud"}, optional
        How ``Gamma`` is formed.
    constraints : sequence of Constraint, optional
        Tactical constraints along the path.
    hypotheses : bool, optional
        Take each member of the belief's cloud as a hypothesis of the target and score a path
        by the weighted mean over them of the criterion of its own ``J`` (the expected bound).

    Raises
    ------
    ValueError
        On a non-positive step, a leg that is not a whole number of steps, a grid below 4 headings,
        or bad speeds.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13 (the recursion and the criterion; the paper plans
    one step, this plans the rest of the mission).
    """

    kinematics: PlatformKinematics
    plan: SensorPlan
    step: float
    leg_duration: float
    end_time: float
    criterion: Criterion = field(default_factory=WeightedTrace)
    headings: int = 24
    speeds: Sequence[float] | None = None
    sweeps: int = 3
    refine: int = 2
    gamma: GammaForm = "mean"
    constraints: Sequence[Constraint] = ()
    hypotheses: bool = False

    def __post_init__(self) -> None:
        """Check the settings."""
        object.__setattr__(self, "constraints", tuple(self.constraints))
        if not (np.isfinite(self.step) and self.step > 0):
            raise ValueError(f"step must be > 0 s; got {self.step}")
        ratio = self.leg_duration / self.step
        if not (np.isfinite(ratio) and ratio >= 1 - _TOL and abs(ratio - round(ratio)) < 1e-6):
            raise ValueError(f"leg_duration must be a whole number (>= 1) of steps of "
                             f"{self.step:g} s; got {self.leg_duration}")
        if int(self.headings) != self.headings or self.headings < 4:
            raise ValueError(f"headings (grid size) must be a whole number >= 4; got "
                             f"{self.headings!r}")
        if self.speeds is not None:
            v = np.asarray(self.speeds, dtype=float)
            if v.ndim != 1 or not v.size or np.any(~np.isfinite(v) | (v < 0)):
                raise ValueError("speeds must be a non-empty list of speeds >= 0 m/s")
            object.__setattr__(self, "speeds", tuple(float(s) for s in v))
        check_gamma(self.gamma)

    def legs(self, time: float) -> tuple[Array, Array]:
        """Return the leg start times and the sub-steps per leg from ``time`` to the end.

        Parameters
        ----------
        time : float
            The decision time, s.

        Returns
        -------
        starts : ndarray, shape (L,)
            s.
        counts : ndarray of int, shape (L,)
            Sub-steps of each leg (the last may be shorter).
        """
        total = int(np.floor((self.end_time - time) / self.step + 1e-6))
        per_leg = round(self.leg_duration / self.step)
        counts = np.full(total // per_leg, per_leg)
        if total % per_leg:
            counts = np.append(counts, total % per_leg)
        starts = time + self.step * np.concatenate([[0], np.cumsum(counts)[:-1]])
        return starts.astype(float), counts.astype(int)

    def _start_info(self, belief: Belief, c: int, information: ArrayLike | None = None
                    ) -> Array:
        """``J`` now for ``c`` paths: (c, n, n), or (c, K, n, n) with hypotheses."""
        j = belief.posterior.information
        if not self.hypotheses:
            return np.broadcast_to(j, (c, *j.shape[-2:]))
        shape = (belief.states.shape[0], *j.shape[-2:])
        if information is not None:
            j = np.asarray(information, dtype=float)
            if j.shape != shape:
                raise ValueError(f"information must be one J per hypothesis, {shape}; got "
                                 f"{j.shape}")
        return np.broadcast_to(j, (c, *shape))

    def _step_info(self, belief: Belief, info: Array, sensor: Array,
                   cloud: tuple[Array, Array]) -> Array:
        """Carry ``J`` of every path through one sub-step (per hypothesis when 4-D)."""
        if info.ndim < 4:
            return step_information(belief, info, self.plan, sensor, self.step, self.gamma,
                                    cloud)
        # one recursion per hypothesis (a few), each over every path at once
        return np.stack([step_information(belief, info[:, k], self.plan, sensor, self.step,
                                          "mean", (cloud[0][k:k + 1], np.ones(1)))
                         for k in range(info.shape[1])], axis=1)

    def _rollout(self, belief: Belief, state: PlatformState, info: Array, headings: Array,
                 speeds: Array, counts: Array, first_leg: int) -> Rollout:
        """Fly candidate paths (C,) from the start of ``first_leg`` to the end."""
        leg_states, leg_info, actions = [], [], []
        worst: list[Violation] = []
        hard = np.zeros(headings.shape[0])
        dyn = belief.posterior.dynamics
        times = self.plan.measurement_times(self.step)
        for leg in range(first_leg, counts.size):
            leg_states.append(state)
            leg_info.append(info)
            for _ in range(int(counts[leg])):   # sub-steps in time, every candidate at once
                t = state.time
                act = Actions(wrap_angle(headings[:, leg] - state.heading), 0.0,
                              speeds[:, leg])
                flown = self.kinematics.step(state, act, self.step)
                cloud = (belief.states @ dyn.transition(t - belief.time).T, belief.weights)
                info = self._step_info(belief, info, flown.sensor_states(t + times), cloud)
                actions.append(act)
                state = flown.end
                if self.constraints:
                    found = step_violations(self.constraints, flown, belief, self.step)
                    hard = hard + penalties(found, hard.size)[1]
                    worst = found if not worst else [
                        replace(w, amount=np.maximum(w.amount, f.amount))
                        for w, f in zip(worst, found, strict=True)]
        return Rollout(info, leg_states, leg_info, actions, state, worst, hard,
                       belief.weights if info.ndim == 4 else None)

    def evaluate(self, platform: PlatformState, belief: Belief, headings: ArrayLike,
                 speeds: ArrayLike | None = None) -> Array:
        """Return the predicted final information of candidate paths (C, n, n).

        With :attr:`hypotheses`, one per path and hypothesis, (C, K, n, n).

        Parameters
        ----------
        platform : PlatformState
            The platform now (batch shape ``()``), at ``belief.time``.
        belief : Belief
            ``J`` and the target cloud now.
        headings : array_like, shape (C, L)
            Commanded heading per leg (rad) of each candidate.
        speeds : array_like, shape (C, L), optional
            Commanded speed per leg (m/s); default the platform's speed.

        Returns
        -------
        ndarray, shape (C, n, n)
            SI.

        Raises
        ------
        ValueError
            If the shapes do not match the number of legs left.
        """
        _, counts = self.legs(belief.time)
        h = np.atleast_2d(np.asarray(headings, dtype=float))
        if h.shape[1] != counts.size:
            raise ValueError(f"headings must be (C, {counts.size}) for the {counts.size} legs "
                             f"left; got {h.shape}")
        v = (np.broadcast_to(platform.speed, h.shape) if speeds is None
             else np.broadcast_to(np.asarray(speeds, dtype=float), h.shape))
        c = h.shape[0]
        return self._rollout(belief, repeat_batch(platform, c), self._start_info(belief, c), h,
                             np.array(v), counts, 0).information

    def _grid(self, round_: int, current: Array, speed: Array) -> tuple[Array, Array]:
        """Heading and speed candidates (M, G) for one leg of M start paths."""
        if round_ == 0:
            offsets = 2 * np.pi * np.arange(self.headings) / self.headings
            heads = np.concatenate([current[:, None], offsets[None, :].repeat(current.size,
                                                                              0)], axis=1)
        else:
            spacing = 2 * np.pi / self.headings / 2.0**round_
            heads = current[:, None] + spacing * np.arange(-2, 3)[None, :]
        if self.speeds is None:
            return heads, np.broadcast_to(speed[:, None], heads.shape)
        vs = np.asarray(self.speeds)
        m, g = heads.shape
        heads_all = np.repeat(heads, vs.size, axis=1)
        speed_all = np.concatenate([np.tile(vs, (m, g)), speed[:, None]], axis=1)
        heads_all = np.concatenate([heads_all, current[:, None]], axis=1)
        return heads_all, speed_all

    def _sweep_leg(self, belief: Belief, base: Rollout, headings: Array, speeds: Array,
                   counts: Array, leg: int, round_: int) -> tuple[Array, Array, Rollout]:
        """Try the grid on one leg of every start path; keep the best of each."""
        m = headings.shape[0]
        heads, vs = self._grid(round_, headings[:, leg], speeds[:, leg])
        g = heads.shape[1]
        cand_h = np.repeat(headings, g, axis=0)
        cand_v = np.repeat(speeds, g, axis=0)
        cand_h[:, leg], cand_v[:, leg] = heads.ravel(), vs.ravel()
        state = repeat_batch(base.leg_states[leg], g)
        info = np.repeat(base.leg_info[leg], g, axis=0)
        out = self._rollout(belief, state, info, cand_h, cand_v, counts, leg)
        cost, bad = out.ranked_cost(self.criterion)
        # feasible first, then by cost (the earlier legs, shared by a row, are not re-checked)
        rows = np.arange(m) * g + np.lexsort((cost.reshape(m, g), bad.reshape(m, g)))[:, 0]
        kept = Rollout(out.information[rows],
                       base.leg_states[:leg] + [s[rows] for s in out.leg_states],
                       base.leg_info[:leg] + [i[rows] for i in out.leg_info], [],
                       out.end[rows], [], out.hard[rows], out.weights)
        return cand_h[rows], cand_v[rows], kept

    def optimise(self, platform: PlatformState, belief: Belief,
                 initial: ArrayLike | None = None, information: ArrayLike | None = None
                 ) -> MissionPlan:
        """Find the remaining path that minimises the criterion of the final information.

        Parameters
        ----------
        platform : PlatformState
            The platform now, at ``belief.time``.
        belief : Belief
            ``J`` along the path so far and the target cloud, now.
        initial : array_like, shape (M, L) or (L,), optional
            Start paths (leg headings, rad) besides the straight one.
        information : array_like, shape (K, n, n), optional
            With :attr:`hypotheses`: ``J`` now under each hypothesis (default the belief's).

        Returns
        -------
        MissionPlan

        Raises
        ------
        ValueError
            If the platform is not one state at the belief's time, no leg is left, or
            ``initial`` or ``information`` has the wrong shape.
        """
        if platform.shape != () or abs(platform.time - belief.time) > 1e-6:
            raise ValueError("optimise() takes one platform state at the belief's time")
        starts, counts = self.legs(belief.time)
        if not counts.size:
            raise ValueError(f"no leg left before the mission end ({self.end_time:g} s)")
        heads = np.full((1, counts.size), float(platform.heading))
        if initial is not None:
            extra = np.atleast_2d(np.asarray(initial, dtype=float))
            if extra.shape[1] != counts.size:
                raise ValueError(f"initial paths must have {counts.size} leg headings; got "
                                 f"shape {extra.shape}")
            heads = np.concatenate([heads, extra])
        speeds = np.full(heads.shape, float(platform.speed))
        evaluations = 0
        m = heads.shape[0]
        info0 = self._start_info(belief, 1, information)[0]
        base = self._rollout(belief, repeat_batch(platform, m), np.broadcast_to(
            info0, (m, *info0.shape)), heads, speeds, counts, 0)
        for round_ in range(self.refine + 1):
            for _ in range(self.sweeps if round_ == 0 else 1):
                before = heads.copy()
                for leg in range(counts.size):
                    heads, speeds, base = self._sweep_leg(belief, base, heads, speeds, counts,
                                                          leg, round_)
                    evaluations += heads.shape[0] * self._grid(round_, heads[:, 0],
                                                               speeds[:, 0])[0].shape[1]
                if np.allclose(wrap_angle(heads - before), 0.0):
                    break
        return self._result(platform, belief, heads, speeds, (starts, counts), evaluations,
                            info0)

    def _result(self, platform: PlatformState, belief: Belief, heads: Array, speeds: Array,
                legs: tuple[Array, Array], evaluations: int, info0: Array) -> MissionPlan:
        m = heads.shape[0]
        starts, counts = legs
        final = self._rollout(belief, repeat_batch(platform, m), np.broadcast_to(
            info0, (m, *info0.shape)), heads, speeds, counts, 0)
        cost, bad = final.ranked_cost(self.criterion)
        k = int(np.lexsort((cost, bad))[0])
        acts = final.actions
        actions = Actions(np.array([a.heading_change[k] for a in acts]), 0.0,
                          np.array([a.speed_change[k] for a in acts]))
        info = final.information[k]
        bound = position_bound(info)
        if final.weights is not None:   # RMS over the hypotheses
            bound = np.sqrt(final.weights @ bound**2)
        return MissionPlan(wrap_angle(heads[k]), speeds[k].copy(), starts, float(cost[k]),
                           float(bound), info, actions, evaluations + m,
                           {v.name: float(v.amount[k]) for v in final.violations},
                           bool(bad[k] <= 0.0))

    def recommend(self, platform: PlatformState, belief: Belief,
                  previous: MissionPlan | None = None, pattern: ArrayLike | None = None,
                  information: ArrayLike | None = None) -> MissionPlan:
        """Re-plan the remaining legs from the current belief (receding over legs).

        Parameters
        ----------
        platform, belief
            As for :meth:`optimise`.
        previous : MissionPlan, optional
            The last plan; its legs still ahead start the search.
        pattern : array_like, optional
            An operator's pattern for the legs left (rad), also a start.
        information : array_like, shape (K, n, n), optional
            As for :meth:`optimise`.

        Returns
        -------
        MissionPlan
            Fly its first leg (``actions[:counts[0]]``), then call again.
        """
        _, counts = self.legs(belief.time)
        initial = []
        if previous is not None:
            ahead = previous.headings[previous.leg_starts >= belief.time - 1e-6]
            if ahead.size == counts.size:
                initial.append(ahead)
        if pattern is not None:
            initial.append(np.asarray(pattern, dtype=float))
        return self.optimise(platform, belief, np.array(initial) if initial else None,
                             information)

    def first_leg(self, platform: PlatformState, plan: MissionPlan) -> Actions:
        """Return the sub-step actions of the plan's first leg (fly them, then re-plan).

        Parameters
        ----------
        platform : PlatformState
            The platform at the plan's decision time.
        plan : MissionPlan
            The plan.

        Returns
        -------
        Actions
            One per sub-step of :attr:`step` seconds.
        """
        _, counts = self.legs(platform.time)
        return plan.actions[np.arange(int(counts[0]))]

    def advance(self, platform: PlatformState, belief: Belief, plan: MissionPlan,
                states: ArrayLike, weights: ArrayLike | None = None
                ) -> tuple[PlatformState, Belief]:
        """Fly the plan's first leg; return the platform and the belief at its end.

        ``J`` is carried along the flown leg (the bound conditioned on the path); the cloud
        is the tracker's after the leg (or the truth, to evaluate at the truth).

        Parameters
        ----------
        platform, belief
            As for :meth:`optimise`.
        plan : MissionPlan
            The plan made from them.
        states, weights
            The target cloud at the end of the leg.

        Returns
        -------
        platform : PlatformState
        belief : Belief
        """
        _, counts = self.legs(belief.time)
        info = belief.posterior.information[None]
        out = self._rollout(belief, repeat_batch(platform, 1), info, plan.headings[None, :1],
                            plan.speeds[None, :1], counts[:1], 0)
        end = out.end[0]
        post = type(belief.posterior)(out.information[0], belief.posterior.dynamics, end.time)
        return end, Belief(post, states, weights)

