"""The planner's compiled decision: a whole decision, or every candidate's kinematics, at once.

:func:`fly` flies the candidates in one compiled loop; :func:`decide` makes a whole planar
decision (kinematics, ``J``, criterion, bound) in one compiled call.  Both return None where they
do not apply, and the planner takes its general path.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.arrays import Array
from ..sensors.platform import Actions, PlatformKinematics, PlatformState, Step
from . import compiled
from .belief import Belief
from .compiled import PLANAR_KINDS, compiled_basis
from .criteria import WeightedTrace, evaluate


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
    start = PlatformState.view(fields[14:17].transpose(axes), fields[17], fields[18],
                               fields[19], time)
    end = PlatformState.view(fields[0:3].transpose(axes), fields[3], fields[4], fields[5],
                             time + interval)
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
    covariance: Array  # ``J_{k+1}^{-1}``
    cost: Array  # The criterion (no penalties)
    bound: Array  # Position RMS bound, m
    #: The candidate of least cost (ties: the first; NaN last); None for a cost made outside
    best: int | None


def _setup(planner: Any) -> tuple[Any, ...] | None:
    """Return the decision's constant arguments for ``planner`` (None: it does not apply)."""
    plan, kin = planner.plan, planner.kinematics
    times = plan.measurement_times(planner.interval)
    if (kin.on_limit != "clip" or plan.dim != 2 or not set(plan.kinds) <= PLANAR_KINDS
            or plan.options or plan.nuisance or times.size != 1
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
    weighting = criterion.matrix(4) if trace else np.zeros((4, 4))
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


def decide(planner: Any, cache: dict[str, Any], platform: PlatformState,
           belief: Belief) -> Decision | None:
    """One step of every candidate of ``planner`` from ``platform``, in one compiled call.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-13.
    """
    kernel = compiled.kernels()["decide_planar"]
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
    best = kernel(
        c_array(platform.position), float(platform.heading), float(platform.speed),
        float(platform.climb_rate), packed, own_climb, limits, interval,
        c_array(post.information), f_inv, g, f, c_array(states), c_array(belief.weights),
        at_mean, coef, dgf, position_only, weighting, rows, flags, info, cov, cost, bound)
    if best < 0:
        return None
    if not trace:
        cost, best = evaluate(planner.criterion, info, cov), None
    steps = LazyStep.of(rows, flags, (n_act,), interval, platform.time)
    return Decision(steps, info, cov, cost, bound, best)
