"""A planned scenario's setup: the ``[planning]`` table of a scenario file built into a planner."""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any

import numpy as np

from ..core.arrays import Array
from ..measurements import KINDS
from ..scenario.files import ScenarioFileError, planned_scenario, scenario_data
from ..scenario.model import Scenario
from ..scenario.planning_table import (
    MAX_DECISIONS,
    AreaSpec,
    KeepOutSpec,
    PlanningSpec,
    RangeConstraintSpec,
    decisions_text,
)
from ..sensors import Actions, PlatformKinematics, PlatformState, platform_configuration
from .constraints import (
    DEFAULT_PENALTY,
    Constraint,
    KeepOutZones,
    MaximumRange,
    MinimumRange,
    OperatingArea,
)
from .criteria import Criterion, LogDet, WeightedTrace
from .measurement_plan import SensorPlan
from .planner import Planner
from .policies import passive

__all__ = ["PlanningSetup", "build_planning", "load_planning", "planning_from_dict"]


@dataclasses.dataclass(frozen=True, eq=False)
class PlanningSetup:
    """Everything a closed-loop run of a planned scenario needs, in SI.

    Attributes
    ----------
    scenario : Scenario
        The scenario (its target truth; its other sensors are not used by the loop).
    sensor : str
        Id of the steered sensor.
    planner : Planner
        Kinematics, actions, interval, sensor plan, criterion, constraints, gamma, horizon:
        the horizon planner, and what the mission planner takes its settings from.
    start : PlatformState
        The steered sensor at the start (position m, heading rad clockwise from North,
        speed m/s, climb rate m/s, time s).
    target : ndarray, shape (2 dim,)
        True target state at the start time ``[x, y, (z,) vx, vy, (vz)]`` (m, m/s).
    steps : int
        Decisions: ``duration / interval``.
    tracker : {"pf", "ekf", "ukf"}
        The tracker.
    particles : int
        Particles of the particle filter.
    q : float
        Process-noise acceleration std of the target (truth and tracker), m/s^2.
    prior_std : tuple of float
        Prior standard deviations of position (m) and velocity (m/s) per axis.
    runs : int
        Monte Carlo runs.
    source : str
        The file, for messages.
    kind : {"mission", "horizon"}
        The planner that steers (``"auto"`` resolved).
    leg_duration : float or None
        The mission planner's leg, s (None: a tenth of the duration, whole intervals).
    hypotheses : int
        The mission planner's range hypotheses (1: none).
    """

    scenario: Scenario
    sensor: str
    planner: Planner
    start: PlatformState
    target: Array
    steps: int
    tracker: str
    particles: int
    q: float
    prior_std: tuple[float, float]
    runs: int
    source: str = ""
    kind: str = "horizon"
    leg_duration: float | None = None
    hypotheses: int = 3

    @property
    def interval(self) -> float:
        """The decision interval, s."""
        return self.planner.interval

    @property
    def duration(self) -> float:
        """The planned time, s: ``steps * interval``."""
        return self.steps * self.planner.interval

    def replace(self, *, steps: int | None = None, tracker: str | None = None,
                particles: int | None = None, q: float | None = None,
                runs: int | None = None, kind: str | None = None) -> PlanningSetup:
        """Return a copy with run settings changed (None: as it is).

        Parameters
        ----------
        steps, tracker, particles, q, runs : optional
            Decisions per run, the tracker's name, its particles, process noise (m/s^2) and
            Monte Carlo runs.
        kind : str, optional
            The planner that steers: ``"mission"`` or ``"horizon"``.

        Returns
        -------
        PlanningSetup
        """
        given: dict[str, Any] = {"steps": steps, "tracker": tracker, "particles": particles,
                                 "q": q, "runs": runs, "kind": kind}
        return dataclasses.replace(self, **{k: v for k, v in given.items() if v is not None})


def _weight(c: RangeConstraintSpec | KeepOutSpec | AreaSpec) -> float:
    return DEFAULT_PENALTY if c.weight is None else c.weight


class _Build:
    """Turns a validated :class:`PlanningSpec` into objects (errors name the field)."""

    def __init__(self, spec: PlanningSpec, scenario: Scenario, ccw: bool) -> None:
        self.spec, self.scenario, self.ccw = spec, scenario, ccw
        self.config = None
        if spec.platform is not None:
            try:
                self.config = platform_configuration(spec.platform)
            except ValueError as e:
                raise ValueError(f"planning.platform: {e}") from None

    def kinematics(self) -> PlatformKinematics:
        base = self.config.kinematics if self.config is not None else PlatformKinematics()
        lim = self.spec.limits
        changes: dict[str, Any] = {}
        for name in ("min_speed", "max_speed", "max_acceleration", "max_climb_rate",
                     "min_altitude", "max_altitude"):
            if getattr(lim, name) is not None:
                changes[name] = float(getattr(lim, name))
        if lim.max_turn_rate_deg_s is not None:
            changes["max_turn_rate"] = math.radians(lim.max_turn_rate_deg_s)
        try:
            return dataclasses.replace(base, **changes)
        except ValueError as e:
            raise ValueError(f"planning.limits: {e}") from None

    def actions(self) -> Actions:
        a = self.spec.actions
        if a is None:
            if self.config is None:
                raise ValueError("planning.actions: give the candidate actions "
                                 "(heading_changes_deg, speed_factors) or a platform")
            return self.config.actions
        sign = -1.0 if self.ccw else 1.0
        return Actions.grid(sign * np.radians(a.heading_changes_deg), a.speed_factors,
                            a.climb_rates)

    def interval(self) -> float:
        if self.spec.interval is not None:
            return float(self.spec.interval)
        if self.config is None:
            raise ValueError("planning.interval: give the decision interval (s) or a platform")
        return float(self.config.interval)

    def sensor_plan(self, dim: int) -> SensorPlan:
        rows = self.spec.measurements
        if rows is None:  # the steered sensor's own [[measurements]]
            plans = [p for p in self.scenario.plans if p.sensor == self.spec.sensor]
            if not plans or any(p.sigma is None for p in plans):
                raise ValueError("planning.measurements: give the kinds and sigmas measured "
                                 "in each step (the sensor's [[measurements]] do not all "
                                 "have a sigma)")
            kinds = [p.kind for p in plans]
            sigmas = [float(p.sigma) for p in plans if p.sigma is not None]  # (all have one)
        else:
            kinds, sigmas = [], []
            for i, m in enumerate(rows):
                if m.kind not in KINDS:
                    raise ValueError(f"planning.measurements[{i}].kind: unknown kind "
                                     f"{m.kind!r}; expected one of {', '.join(KINDS)}")
                kinds.append(m.kind)
                sigmas.append(float(KINDS[m.kind]().sigma_to_si(m.sigma)))
        return SensorPlan(kinds, sigmas, dim=dim, nuisance=self.scenario.nuisance or None,
                          options=self.scenario.measurement_options or None)

    def criterion(self, n: int) -> Criterion:
        s = self.spec
        if s.criterion == "logdet":
            if s.weights is not None:
                raise ValueError("planning.weights: weights apply to criterion = 'trace' only")
            return LogDet()
        if s.weights is None:
            return WeightedTrace()
        w = np.asarray(s.weights, dtype=float)
        if w.ndim == 1:
            if w.shape != (n,):
                raise ValueError(f"planning.weights: give {n} diagonal weights or a {n} x {n} "
                                 f"matrix for the state [position, velocity]; got {w.size}")
            w = np.diag(w)
        if not np.any(w):
            raise ValueError("planning.weights: all zero, so every candidate would cost 0 "
                             "and the choice would be arbitrary")
        crit = WeightedTrace(w)
        try:
            crit.matrix(n)
        except ValueError as e:
            raise ValueError(f"planning.weights: {e}") from None
        return crit

    def polygon(self, where: str, enu: list[list[float]] | None,
                geo: list[list[float]] | None) -> Array:
        if (enu is None) == (geo is None):
            raise ValueError(f"{where}: give exactly one of the [east, north] and the "
                             "geodetic [lat, lon] form")
        if enu is not None:
            return np.asarray(enu, dtype=float)
        if self.scenario.origin is None:
            raise ValueError(f"{where}: geodetic vertices need the scenario's origin "
                             "= [lat, lon, alt]")
        from ..core.geodesy import geodetic_to_enu

        g = np.asarray(geo, dtype=float)
        e, n, _ = geodetic_to_enu(g[:, 0], g[:, 1], np.full(len(g), self.scenario.origin[2]),
                                  self.scenario.origin)
        return np.column_stack([e, n])

    def constraints(self) -> list[Constraint]:
        out: list[Constraint] = []
        for i, c in enumerate(self.spec.constraints):
            where = f"planning.constraints[{i}]"
            try:
                if isinstance(c, RangeConstraintSpec):
                    cls = MinimumRange if c.type == "min_range" else MaximumRange
                    out.append(cls(c.distance, c.hard, _weight(c)))
                elif isinstance(c, KeepOutSpec):
                    n = len(c.polygons or c.polygons_geodetic or [])
                    zones = [self.polygon(
                        f"{where} polygon {j}", None if c.polygons is None else c.polygons[j],
                        None if c.polygons_geodetic is None else c.polygons_geodetic[j])
                        for j in range(n)] if n else [self.polygon(where, None, None)]
                    out.append(KeepOutZones(zones, c.hard, _weight(c)))
                else:
                    area = self.polygon(where, c.polygon, c.polygon_geodetic)
                    out.append(OperatingArea(area, c.hard, _weight(c)))
            except ValueError as e:
                msg = str(e)
                raise ValueError(msg if msg.startswith(where) else f"{where}: {msg}") from None
        ranges = [(c.type, c.distance) for c in self.spec.constraints
                  if isinstance(c, RangeConstraintSpec)]
        near = max((d for k, d in ranges if k == "min_range"), default=0.0)
        far = min((d for k, d in ranges if k == "max_range"), default=math.inf)
        if near >= far:
            raise ValueError(f"planning.constraints: the minimum range {near:g} m is not below "
                             f"the maximum range {far:g} m; no path can keep both")
        return out

    def start(self, sensor_spec: Any) -> PlatformState:
        sid = self.spec.sensor
        t0 = self.spec.start_time
        if t0 is None:
            if getattr(sensor_spec, "type", "") == "fixed":
                raise ValueError(f"planning.sensor: sensor {sid!r} is fixed; a steered sensor "
                                 "starts moving (type legs, waypoints or recorded)")
            t0 = (sensor_spec.times[0] if sensor_spec.type == "recorded"
                  else sensor_spec.start_time)
        try:
            s = self.scenario.sensors[sid].states(np.array([float(t0)]))[0]
        except ValueError as e:
            raise ValueError(f"planning.start_time: {e}") from None
        speed = float(np.hypot(s[3], s[4]))
        if speed <= 0.0:
            raise ValueError(f"planning.sensor: sensor {sid!r} is not moving at t = {t0:g} s; "
                             "a steered sensor needs a heading and a speed > 0")
        return PlatformState.from_velocity(s[:3], s[3:], float(t0))

    def target(self, t0: float) -> Array:
        motion = self.scenario.motion
        if not motion.name.startswith("cv"):
            raise ValueError(f"planning: the target moves by nearly constant velocity in the "
                             f"closed loop; target.motion must be cv2d or cv3d, not "
                             f"{motion.name!r}")
        x = self.scenario.target_states([t0])[0]
        d = motion.dim
        return np.concatenate([x[:d], x[3:3 + d]])

    def steps(self, interval: float) -> int:
        ratio = self.spec.duration / interval
        steps = round(ratio)
        if steps < 1 or abs(ratio - steps) > 1e-6 * max(1.0, ratio):
            raise ValueError(f"planning.duration: {self.spec.duration:g} s is not a whole "
                             f"number (>= 1) of decision intervals of {interval:g} s")
        if steps > MAX_DECISIONS:
            raise ValueError(f"planning.duration: {decisions_text(steps)} decisions of "
                             f"{interval:g} s, more than the limit of {MAX_DECISIONS:,}")
        return int(steps)


def build_planning(spec: PlanningSpec, scenario: Scenario, sensor_spec: Any,
                   ccw: bool = False, source: str = "") -> PlanningSetup:
    """Build the :class:`PlanningSetup` of a validated ``[planning]`` table."""
    b = _Build(spec, scenario, ccw)
    interval = b.interval()
    start = b.start(sensor_spec)
    target = b.target(start.time)
    dim = target.shape[0] // 2
    try:
        planner = Planner(b.kinematics(), b.actions(), interval, b.sensor_plan(dim),
                          b.criterion(2 * dim), b.constraints(), spec.gamma, spec.horizon)
    except ValueError as e:
        msg = str(e)
        raise ValueError(msg if msg.startswith("planning") else f"planning: {msg}") from None
    kind = spec.planner
    if kind == "auto":
        kind = "mission" if passive(planner.plan) else "horizon"
    legs = spec.mission.leg_duration
    if legs is not None:
        ratio = legs / interval
        if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
            raise ValueError(f"planning.mission.leg_duration: {legs:g} s is not a whole number "
                             f"(>= 1) of decision intervals of {interval:g} s")
    return PlanningSetup(scenario, spec.sensor, planner, start, target, b.steps(interval),
                         spec.tracker, spec.particles, spec.q,
                         (spec.prior.position_std, spec.prior.velocity_std), spec.runs, source,
                         kind, legs, spec.mission.hypotheses)


def planning_from_dict(data: dict[str, Any], source: str = "<dict>") -> PlanningSetup:
    """Validate a scenario with a ``[planning]`` table and build its planning setup."""
    scenario, table, sensor, ccw = planned_scenario(data, source)
    try:
        return build_planning(table, scenario, sensor, ccw, source)
    except ValueError as err:
        raise ScenarioFileError(f"{source}: {err}") from None


def load_planning(name_or_path: str | os.PathLike[str]) -> PlanningSetup:
    """Load the planning setup of a scenario (built-in name or TOML file) with ``[planning]``.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A built-in name (``plan-bearings-only``) or a path.

    Returns
    -------
    PlanningSetup
        See :func:`planning_from_dict`.

    Raises
    ------
    ScenarioFileError
        If the scenario is unknown, invalid, or has no valid ``[planning]`` table.
    """
    return planning_from_dict(*scenario_data(name_or_path))
