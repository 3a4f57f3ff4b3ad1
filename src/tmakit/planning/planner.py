"""Choose the sensor's next action by the predicted posterior CRB (Hurtado & Nehorai 2008).

The :class:`Planner` flies every candidate action for one decision interval, carries the
information along each (eqs. 10-13), scores it by the criterion (eq. 12) under the constraints;
:func:`search` looks ``horizon`` steps ahead.  :func:`decide` makes a whole planar decision in one
compiled call, or returns None and the planner takes its general path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..bounds.pcrb_recursion import PosteriorInformation, predict_information
from ..core.arrays import Array
from ..core.linalg import symmetrise
from ..filters.base import TrackingFilter
from ..motion.dynamics import NearlyConstantVelocity
from ..sensors.platform import Actions, PlatformKinematics, PlatformState, Step
from . import compiled
from .belief import Belief, cubature_points
from .candidates import GammaForm, check_gamma, step_information
from .compiled import compiled_basis, planar_plan
from .constraints import Constraint, Violation
from .criteria import Criterion, WeightedTrace, bound_covariance, evaluate
from .measurement_plan import SensorPlan

#: Times per step at which the constraints are checked (equally spaced, end included).
CHECK_POINTS = 4
#: Most action sequences an exhaustive search scores per decision (``A ** horizon``, no
#: ``beam``): 166,375 took 0.4 s and 0.5 GB per decision; beyond, memory runs out.
MAX_SEQUENCES = 200_000
_ONE = np.ones(1)


@dataclass(frozen=True, eq=False)
class Recommendation:
    """The planner's answer at one decision, per candidate action (C,).

    Attributes
    ----------
    index : int
        The chosen candidate.
    actions : Actions
        The candidates.
    steps : Step
        Every candidate flown for one decision interval.
    information : ndarray, shape (C, n, n)
        Predicted Bayesian information ``J_{k+1}`` after one step, SI.
    cost : ndarray
        The criterion with penalties (with a horizon, the best sequence's that starts with it).
    bound : ndarray
        Predicted position RMS bound after one step, m.
    feasible : ndarray of bool
        Whether the candidate (or a sequence starting with it) keeps every hard constraint.
    violations : dict of str to ndarray
        Largest violation of each constraint over the candidate's first step, m.
    all_infeasible : bool
        True when no candidate kept the hard constraints (the least violating was chosen).
    """

    index: int
    actions: Actions
    steps: Step
    information: Array
    cost: Array
    bound: Array
    feasible: NDArray[np.bool_]
    violations: dict[str, Array]
    all_infeasible: bool

    @property
    def step(self) -> Step:
        """The chosen candidate's step."""
        return self.steps[self.index]

    @property
    def action(self) -> Actions:
        """The chosen action."""
        return self.actions[self.index]


def position_bound(information: Array, covariance: Array | None = None) -> Array:
    """Return ``sqrt(trace)`` of the position block of ``J^{-1}``, m."""
    dim = information.shape[-1] // 2
    cov = bound_covariance(information) if covariance is None else covariance
    return cast(Array, np.sqrt(np.clip(np.einsum("...ii->...", cov[..., :dim, :dim]), 0.0, None)))


@dataclass(frozen=True, eq=False)
class Planner:
    """Adaptive sensor path planning by the predicted posterior CRB.

    Parameters
    ----------
    kinematics : PlatformKinematics
        The platform's limits.
    actions : Actions, shape (A,)
        The candidate actions of one decision.
    interval : float
        Decision interval, s.
    plan : SensorPlan
        What the sensor measures in each step.
    criterion : Criterion, optional
        Cost of ``J`` (default :class:`WeightedTrace`, position only: eq. 12).
    constraints : sequence, optional
        Tactical constraints.
    gamma : {"mean", "cloud"}, optional
        How ``Gamma`` is formed in the first step.
    horizon : int, optional
        Decision steps looked ahead (1 = Hurtado & Nehorai (2008)).
    beam : int, optional
        Nodes kept per depth of the horizon's tree search (None: exhaustive).
    continuation : Continuation, optional
        Score sequences at the mission end after a default path beyond the horizon.

    Raises
    ------
    ValueError
        On an empty action set, a non-positive interval or horizon, an unknown gamma, or an
        exhaustive search of more than :data:`MAX_SEQUENCES` sequences.
    TypeError
        If ``actions`` is not an :class:`~tmakit.sensors.Actions`.

    References
    ----------
    Hurtado & Nehorai (2008), sections 4.1-4.2, eqs. 10-13.
    """

    kinematics: PlatformKinematics
    actions: Actions
    interval: float
    plan: SensorPlan
    criterion: Criterion = field(default_factory=WeightedTrace)
    constraints: Sequence[Constraint] = ()
    gamma: GammaForm = "mean"
    horizon: int = 1
    beam: int | None = None
    continuation: Continuation | None = None
    _decision: dict[str, object] = field(default_factory=dict, init=False, repr=False,
                                         compare=False)

    def __post_init__(self) -> None:
        """Check the settings."""
        if not isinstance(self.actions, Actions):
            raise TypeError(f"actions must be a tmakit.sensors.Actions (e.g. Actions.grid), "
                            f"not {type(self.actions).__name__}")
        if len(self.actions.shape) != 1 or self.actions.shape[0] < 1:
            raise ValueError("the planner needs a 1-D set of at least one candidate action")
        if not (np.isfinite(self.interval) and self.interval > 0):
            raise ValueError(f"the decision interval must be > 0 s; got {self.interval}")
        if isinstance(self.horizon, bool) or int(self.horizon) != self.horizon \
                or self.horizon < 1:
            raise ValueError(f"the horizon must be a whole number of steps >= 1; got "
                             f"{self.horizon!r}")
        check_gamma(self.gamma)
        if self.beam is not None and (isinstance(self.beam, bool) or int(self.beam) != self.beam
                                      or self.beam < 1):
            raise ValueError(f"beam must be a whole number >= 1 or None; got {self.beam!r}")
        if self.beam is None and self.actions.shape[0] ** int(self.horizon) > MAX_SEQUENCES:
            raise ValueError(
                f"{self.actions.shape[0]} actions over a horizon of {self.horizon} make "
                f"{self.actions.shape[0] ** int(self.horizon):,} sequences to score per "
                f"decision, more than {MAX_SEQUENCES:,} (memory and time grow with them): "
                "lower the horizon, offer fewer actions or search with Planner(beam=N)")
        object.__setattr__(self, "constraints", tuple(self.constraints))

    def _expand(self, platform: PlatformState, information: Array, belief: Belief,
                gamma: GammaForm) -> tuple[Step, Array, list[Violation]]:
        """Fly every action from each state (batch ``B``) for one step: (*B, A)."""
        steps = fly(self.kinematics, platform, self.actions, self.interval)
        if steps is None:   # limits that raise: the NumPy step
            start = PlatformState.trusted(
                platform.position[..., None, :], platform.heading[..., None],
                platform.speed[..., None], platform.climb_rate[..., None], platform.time)
            steps = self.kinematics.step(start, self.actions, self.interval)
        t0 = platform.time
        offsets = self.plan.measurement_times(self.interval)
        if offsets.size == 1 and offsets[0] == self.interval:   # one pulse, at the end
            sensor = steps.end.sensor_state[..., None, :]
        else:
            sensor = steps.sensor_states(t0 + offsets)          # (*B, A, k, 6)
        cloud = None   # at the decision time: the belief's own cloud
        if t0 != belief.time:
            f = belief.posterior.dynamics.transition(t0 - belief.time)
            # Xi at the mean needs the moved mean only (the moved cloud's mean: F is linear)
            cloud = (((f @ belief.mean)[None], _ONE) if gamma == "mean"
                     else (belief.states @ f.T, belief.weights))
        info = step_information(belief, information[..., None, :, :], self.plan, sensor,
                                self.interval, gamma, cloud)
        return steps, info, step_violations(self.constraints, steps, belief, self.interval)

    def recommend(self, platform: PlatformState, belief: Belief) -> Recommendation:
        """Choose the next action.

        Parameters
        ----------
        platform : PlatformState
            The platform now (batch shape ``()``), at ``belief.time``.
        belief : Belief
            ``J_k`` along the path so far and the target cloud, at the same time.

        Returns
        -------
        Recommendation

        Raises
        ------
        ValueError
            If the platform is not one state or is not at the belief's time.
        """
        if platform.shape != ():
            raise ValueError("recommend() takes one platform state")
        if abs(platform.time - belief.time) > 1e-6:
            raise ValueError(f"the platform is at t = {platform.time:g} s and the belief at "
                             f"t = {belief.time:g} s")
        fast = decide(self, self._decision, platform, belief)
        if (fast is not None and fast.best is not None and not self.constraints
                and self.horizon == 1 and self.continuation is None):
            n_act = len(self.actions)   # nothing to penalise or search: the kernel's choice
            return Recommendation(fast.best, self.actions, fast.steps, fast.information,
                                  fast.cost, fast.bound, np.ones(n_act, dtype=bool), {}, False)
        if fast is None:
            steps, info, viol = self._expand(platform, belief.posterior.information, belief,
                                             self.gamma)
            cov = bound_covariance(info)      # once, for the criterion and the bound
            cost, bound = evaluate(self.criterion, info, cov), position_bound(info, cov)
        else:
            steps, info, cost, bound = fast.steps, fast.information, fast.cost, fast.bound
            viol = step_violations(self.constraints, steps, belief, self.interval)
        factor, bad = penalties(viol, len(self.actions))
        cost = cost * factor
        if self.horizon > 1 or self.continuation is not None:
            cost, bad = search(self, steps.end, steps.turn_rate, info, belief, factor, bad)
        return _choose(self.actions, steps, info, cost, bad, viol, bound)

    def advance(self, belief: Belief, recommendation: Recommendation, states: Array,
                weights: Array | None = None) -> Belief:
        """Return the next decision's belief after flying the chosen step.

        ``J_{k+1}`` is the chosen candidate's predicted information (the bound along the
        flown path, conditioned on it); the cloud is the tracker's after its update.

        Parameters
        ----------
        belief : Belief
            The belief the recommendation was made from.
        recommendation : Recommendation
            Its answer.
        states, weights
            The tracker's cloud at the end of the step.

        Returns
        -------
        Belief
        """
        post = belief.posterior
        nxt = type(post)(recommendation.information[recommendation.index], post.dynamics,
                         belief.time + self.interval)
        return Belief(nxt, states, weights)


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

    def _thinned_plan(self, plan: SensorPlan, interval: float, remaining: float
                      ) -> SensorPlan | None:
        """Return the plan of the measurements over ``remaining`` s (None: nothing measured)."""
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

    def _information(self, planner: Planner, ends: PlatformState, turn_rate: Array,
                     information: Array, belief: Belief) -> Array:
        """Return ``J`` at :attr:`end_time` of every node (batch ``B``) continued by the path."""
        remaining = self.end_time - ends.time
        if remaining <= 1e-9:
            return information
        f = belief.posterior.dynamics.transition(ends.time - belief.time)
        cloud = (belief.states @ f.T, belief.weights)
        thin = self._thinned_plan(planner.plan, planner.interval, remaining)
        if thin is None:
            f_inv, g = belief.posterior.step_factors(remaining)
            return predict_information(information, f_inv, g)
        turn = turn_rate * remaining if self.mode == "hold" else np.zeros(ends.shape)
        path = planner.kinematics.step(ends, Actions(turn), remaining)
        sensor = path.sensor_states(ends.time + thin.measurement_times(remaining))
        return step_information(belief, information, thin, sensor, remaining, "mean", cloud)


def _score(planner: Planner, ends: PlatformState, turn_rate: Array, info: Array,
           factor: Array, belief: Belief) -> Array:
    if planner.continuation is not None:
        info = planner.continuation._information(planner, ends, turn_rate, info, belief)
    return planner.criterion(info) * factor


def search(planner: Planner, ends: PlatformState, turn_rate: Array, information: Array,
           belief: Belief, factor: Array, bad: Array) -> tuple[Array, Array]:
    """Return the best leaf cost of ``planner.horizon`` steps per first action and its violation.

    Both (A,); the violation is the leaf's total hard one (m); inf where the beam dropped every
    leaf of an action.

    References
    ----------
    Hurtado & Nehorai (2008), eq. 12 (the criterion; the paper's horizon is one step).
    """
    a, beam = len(planner.actions), planner.beam
    paths = np.arange(a)[:, None]
    for _ in range(1, planner.horizon):
        if beam is not None and paths.shape[0] > beam:
            score = _score(planner, ends, turn_rate, information, factor, belief)
            keep = np.lexsort((score, bad))[:int(beam)]
            ends, turn_rate, information = ends[keep], turn_rate[keep], information[keep]
            factor, bad, paths = factor[keep], bad[keep], paths[keep]
        steps, info, viol = planner._expand(ends, information, belief, "mean")
        f_new, bad_new = penalties(viol, steps.turn_rate.size)
        m = paths.shape[0]
        factor = (factor[:, None] * f_new.reshape(m, a)).ravel()
        bad = (bad[:, None] + bad_new.reshape(m, a)).ravel()
        paths = np.concatenate([np.repeat(paths, a, axis=0),
                                np.tile(np.arange(a), m)[:, None]], axis=1)
        ends, turn_rate = _flat(steps.end), steps.turn_rate.ravel()
        information = info.reshape(m * a, *info.shape[-2:])
    leaf = _score(planner, ends, turn_rate, information, factor, belief)
    cost = np.full(a, np.inf)
    worst = np.full(a, np.inf)
    order = np.lexsort((leaf, bad))
    firsts, at = np.unique(paths[order, 0], return_index=True)   # best leaf per first action
    cost[firsts], worst[firsts] = leaf[order[at]], bad[order[at]]
    return cost, worst


def _flat(state: PlatformState) -> PlatformState:
    """Flatten a batch of platform states to one axis."""
    return PlatformState.trusted(state.position.reshape(-1, 3), state.heading.ravel(),
                                 state.speed.ravel(), state.climb_rate.ravel(), state.time)


def step_violations(constraints: Sequence[Constraint], steps: Step, belief: Belief,
                    interval: float) -> list[Violation]:
    """Check every constraint along candidate steps against the estimated target."""
    if not constraints:
        return []
    times = steps.start.time + interval * np.arange(1, CHECK_POINTS + 1) / CHECK_POINTS
    pos = steps.sensor_states(times)[..., :3].reshape(-1, CHECK_POINTS, 3)
    dyn = belief.posterior.dynamics
    dim = belief.posterior.dim
    target = np.zeros((CHECK_POINTS, 3))
    for j, t in enumerate(times):   # CHECK_POINTS times, not candidates
        target[j, :dim] = (dyn.transition(t - belief.time) @ belief.mean)[:dim]
    return [c.check(pos, target) for c in constraints]


def _choose(actions: Actions, steps: Step, info: Array, cost: Array, bad: Array,
            violations: list[Violation], bound: Array) -> Recommendation:
    feasible = bad <= 0.0
    all_bad = not bool(feasible.any())
    # feasible first by cost; if none, least total violation, then cost
    index = int(np.lexsort((cost, np.where(feasible, 0.0, bad)))[0])
    return Recommendation(index, actions, steps, info, cost, bound, feasible,
                          {v.name: v.amount for v in violations}, all_bad)

Estimate = TrackingFilter | tuple[ArrayLike, ArrayLike] | Sequence[ArrayLike]


def _gaussian(track: Estimate) -> tuple[np.ndarray, np.ndarray]:
    try:
        mean, cov = track  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError("recommend() takes a TrackingFilter or a (mean, covariance) "
                         "pair") from None
    m = np.asarray(mean, dtype=float).reshape(-1)
    p = np.asarray(cov, dtype=float)
    n = m.shape[0]
    if n not in (4, 6) or p.shape != (n, n) or not (np.all(np.isfinite(m))
                                                     and np.all(np.isfinite(p))):
        raise ValueError(f"the estimate must be a finite mean [x, y, (z,) vx, vy, (vz)] (4 or "
                         f"6 values) and its (n, n) covariance; got {m.shape} and {p.shape}")
    p = symmetrise(p)
    if np.any(np.linalg.eigvalsh(p) <= 0.0):
        raise ValueError("the estimate's covariance must be positive definite (SI: m^2, "
                         "m^2/s^2)")
    return m, p


def _check_types(platform: object, planner: object, posterior: object) -> None:
    """Refuse arguments of the wrong type with their name (not an AttributeError later)."""
    for name, value, cls in (("platform", platform, PlatformState),
                             ("planner", planner, Planner)):
        if not isinstance(value, cls):
            raise TypeError(f"recommend(): {name} must be a {cls.__name__}, not "
                            f"{type(value).__name__}")
    if posterior is not None and not isinstance(posterior, PosteriorInformation):
        raise TypeError(f"recommend(): posterior must be a PosteriorInformation or None, not "
                        f"{type(posterior).__name__}")


def recommend(track: Estimate, platform: PlatformState, planner: Planner,
              posterior: PosteriorInformation | None = None, *, q: float = 0.0,
              cloud: str = "auto") -> Recommendation:
    """Return the planner's next action for a user's tracker and platform (one decision).

    Parameters
    ----------
    track : TrackingFilter or (mean, covariance)
        The tracker after its last update, at the platform's time; or its estimate
        ``[x, y, (z,) vx, vy, (vz)]`` (m, m/s) and covariance (SI).
    platform : PlatformState
        The platform now (one state; its ``time`` is the decision time, s).
    planner : Planner
        Kinematics, actions, interval, sensor plan, criterion, constraints.
    posterior : PosteriorInformation, optional
        ``J_k`` at the platform's time (default: the inverse of the tracker's covariance, with the
        tracker's dynamics, or ``NearlyConstantVelocity(dim, q)`` for a pair).
    q : float, optional
        Process-noise acceleration std (m/s^2) of the target, for a (mean, covariance) pair without
        ``posterior``.
    cloud : {"auto", "particles", "sigma", "mean"}, optional
        The target cloud ``Gamma`` is averaged over with ``planner.gamma = "cloud"``
        (:meth:`Belief.from_filter`); a pair gives its cubature points (``"auto"``, ``"sigma"``) or
        its mean.

    Returns
    -------
    Recommendation
        ``index`` and ``action`` (what to fly), ``bound`` (m, predicted position RMS bound of every
        candidate after one step), ``feasible``, ``violations`` (m), ``cost``.

    Raises
    ------
    ValueError, TypeError
        On a bad estimate or cloud, a tracker or posterior not at the platform's time; a platform,
        planner or posterior not of its type.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13 (the predicted posterior CRB), eq. 12 (the
    criterion ``Tr{Pi J^{-1}}``).
    """
    _check_types(platform, planner, posterior)
    if isinstance(track, TrackingFilter):
        if abs(track.time - platform.time) > 1e-6:
            raise ValueError(f"the tracker is at t = {track.time:g} s and the platform at "
                             f"t = {platform.time:g} s; predict the tracker to the decision "
                             "time first")
        if posterior is None:
            posterior = PosteriorInformation(np.linalg.inv(symmetrise(track.covariance)),
                                             track.dynamics, platform.time)
        return planner.recommend(platform, Belief.from_filter(track, posterior, cloud))
    mean, cov = _gaussian(track)
    if posterior is None:
        posterior = PosteriorInformation(np.linalg.inv(cov),
                                         NearlyConstantVelocity(mean.shape[0] // 2, q),
                                         platform.time)
    if cloud not in ("auto", "particles", "sigma", "mean"):
        raise ValueError(f"cloud must be 'auto', 'sigma' or 'mean'; got {cloud!r}")
    if cloud == "mean":
        belief = Belief(posterior, mean)
    elif cloud == "particles":
        raise ValueError("a (mean, covariance) estimate has no particles")
    else:
        belief = Belief(posterior, *cubature_points(mean, cov))
    return planner.recommend(platform, belief)


def pack_actions(actions: Actions) -> tuple[Array, bool]:
    """Return the actions as rows (4, A) and whether each platform keeps its climb rate."""
    climb = actions.climb_rate
    rows = np.stack([actions.heading_change, actions.speed_factor, actions.speed_change,
                     np.zeros(actions.shape) if climb is None else climb]).astype(float)
    return np.ascontiguousarray(rows.reshape(4, -1)), climb is None


def pack_limits(kinematics: PlatformKinematics) -> Array:
    """Return the limits (7,): speed range, turn rate, acceleration, climb rate, altitude band."""
    k = kinematics
    return np.array([k.min_speed, k.max_speed, k.max_turn_rate, k.max_acceleration,
                     k.max_climb_rate, k.min_altitude, k.max_altitude], dtype=float)


def pack_starts(platform: PlatformState) -> Array:
    """Return the start states by rows (M, 6): ``[x, y, z, heading, speed, climb rate]``."""
    out = np.empty((platform.speed.size, 6))
    out[:, :3] = platform.position.reshape(-1, 3)
    out[:, 3] = platform.heading.ravel()
    out[:, 4] = platform.speed.ravel()
    out[:, 5] = platform.climb_rate.ravel()
    return out


def step_from_rows(fields: Array, flags: Array, shape: tuple[int, ...], interval: float,
                   time: float) -> Step:
    """Return the :class:`Step` whose fields are views of the compiled kernel's output."""
    if len(shape) != 1:
        fields = fields.reshape(fields.shape[0], *shape)
        flags = flags.reshape(4, *shape)
    axes = (*range(1, len(shape) + 1), 0)   # (3, *shape) -> (*shape, 3)
    start = PlatformState.trusted(fields[14:17].transpose(axes), fields[17], fields[18],
                                  fields[19], time, as_given=True)
    end = PlatformState.trusted(fields[0:3].transpose(axes), fields[3], fields[4], fields[5],
                                time + interval, as_given=True)
    return Step(start, end, fields[6], fields[7], fields[5], float(interval), flags[0],
                flags[1], flags[2], flags[3])


class LazyStep(Step):
    """A :class:`Step` whose fields are made from the compiled kernel's output when first read."""

    @classmethod
    def of(cls, fields: Array, flags: Array, shape: tuple[int, ...], interval: float,
           time: float) -> LazyStep:
        """Return the lazy step over the kernel's output (arguments of :func:`step_from_rows`)."""
        step = object.__new__(cls)
        object.__setattr__(step, "_source", (fields, flags, shape, interval, time))
        return step

    def __getattr__(self, name: str) -> Any:
        """Make every field on the first read of one (only called for missing attributes)."""
        if name.startswith("__") or name == "_source":
            raise AttributeError(name)
        made = step_from_rows(*object.__getattribute__(self, "_source"))
        for f in dataclasses.fields(Step):
            object.__setattr__(self, f.name, getattr(made, f.name))
        return object.__getattribute__(self, name)


def fly(kinematics: PlatformKinematics, platform: PlatformState, actions: Actions,
        interval: float) -> Step | None:
    """Fly every action from every state of ``platform`` for one step, compiled."""
    if (kinematics.on_limit != "clip"
            or len(actions.shape) != 1 or not interval > 0):
        return None
    packed, own_climb = pack_actions(actions)
    rows, flags = compiled.fly(pack_starts(platform), packed, own_climb,
                               pack_limits(kinematics), interval)
    return step_from_rows(rows, flags, (*platform.shape, actions.shape[0]), interval,
                          platform.time)


@dataclass(frozen=True, eq=False)
class Decision:
    """Every candidate (A,) of one decision, as the compiled kernel computed it."""

    steps: Step
    information: Array  # ``J_{k+1}``, SI; shape (A, 4, 4)
    cost: Array  # The criterion (no penalties)
    bound: Array  # Position RMS bound, m
    #: The candidate of least cost (ties: the first; NaN last); None for a cost made outside
    best: int | None


def _setup(planner: Planner) -> tuple[Any, ...] | None:
    """Return the decision's constant arguments for ``planner`` (None: it does not apply)."""
    plan, kin = planner.plan, planner.kinematics
    times = plan.measurement_times(planner.interval)
    if (kin.on_limit != "clip" or not planar_plan(plan) or times.size != 1
            or times[0] != planner.interval or len(planner.actions.shape) != 1):
        return None
    names, coef, dgf = compiled_basis(plan)
    position_only = names == ["ir2"]
    if not position_only:   # the general kernel writes every product: zero rows for the rest
        full = np.zeros((len(compiled.PRODUCTS), 3))
        for j, name in enumerate(names):
            full[compiled.PRODUCTS.index(name)] = coef[j]
        coef = full
    criterion = planner.criterion
    trace = type(criterion) is WeightedTrace
    weighting = cast(WeightedTrace, criterion).matrix(4) if trace else np.zeros((4, 4))
    packed, own_climb = pack_actions(planner.actions)
    return (packed, own_climb, pack_limits(kin), float(planner.interval), coef, dgf,
            position_only, np.ascontiguousarray(weighting), trace)


def _step_factors(cache: dict[str, Any], post: Any, interval: float
                  ) -> tuple[Array, Array, Array]:
    """Return ``F^{-1}``, ``G`` and ``F`` of one step, kept while the dynamics stay the same."""
    dyn = post.dynamics
    kept = cache.get("dynamics")
    if kept is None or not (kept[0] is dyn or kept[0] == dyn):
        f_inv, g = post.step_factors(interval)
        c_array = np.ascontiguousarray
        kept = cache["dynamics"] = (dyn, c_array(f_inv, dtype=float), c_array(g, dtype=float),
                                    c_array(dyn.transition(interval), dtype=float))
    return kept[1], kept[2], kept[3]


def decide(planner: Planner, cache: dict[str, Any], platform: PlatformState,
           belief: Belief) -> Decision | None:
    """One step of every candidate of ``planner`` from ``platform``, in one compiled call.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13.
    """
    if "setup" not in cache:
        cache["setup"] = _setup(planner)
    setup = cache["setup"]
    post = belief.posterior
    if setup is None or post.information.shape != (4, 4):
        return None
    packed, own_climb, limits, interval, coef, dgf, position_only, weighting, trace = setup
    f_inv, g, f = _step_factors(cache, post, interval)
    n_act = packed.shape[1]
    rows, flags = np.empty((20, n_act)), np.empty((4, n_act), dtype=np.bool_)
    info, cov = np.empty((n_act, 4, 4)), np.empty((n_act, 4, 4))
    cost, bound = np.empty(n_act), np.empty(n_act)
    states = belief.states
    at_mean = planner.gamma == "mean" or states.shape[0] == 1
    c_array = np.ascontiguousarray   # one compiled layout: no new compilation for a view
    found: int = compiled.decide_planar(
        c_array(platform.position), float(platform.heading), float(platform.speed),
        float(platform.climb_rate), packed, own_climb, limits, interval,
        c_array(post.information), f_inv, g, f, c_array(states), c_array(belief.weights),
        at_mean, coef, dgf, position_only, weighting, rows, flags, info, cov, cost, bound)
    if found < 0:
        return None
    best = found if trace else None
    if not trace:
        cost = evaluate(planner.criterion, info, cov)
    steps = LazyStep.of(rows, flags, (n_act,), interval, platform.time)
    return Decision(steps, info, cost, bound, best)
