"""Run a scenario's ``[planning]`` table: the planned path beside the fixed pattern, many times.

``planned`` steers the sensor by the table's planner (the mission planner over range hypotheses
for a passive sensor, else the horizon planner of Hurtado & Nehorai (2008)); ``fixed`` flies the
sensor's own ``[[sensors]]`` path.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..bounds.pcrb_recursion import RESAMPLES
from ..core.keywords import NOT_GIVEN, NotGiven, RngLike, renamed_keyword, study_seed
from ..planning import MissionPlanner
from ..planning.policies import MissionPolicy, Policy, TrackPolicy, passive
from ..planning.setup import PlanningSetup, load_planning
from ..scenario.planning_table import MAX_DECISIONS, PLANNERS, decisions_text
from .closed_loop import (
    MIN_RUNS_INTERVAL,
    ClosedLoopStudy,
    LoopCase,
    LoopChunk,
    LoopSetup,
    closed_loop_study,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["CASE", "FIXED", "PlanRun", "describe", "fixed_policy", "loop_case",
           "mission_planner", "plan", "policy"]

#: The case name of the planned path in the study and its table.
CASE = "planned"
#: The case name of the scenario's fixed pattern.
FIXED = "fixed"
#: Legs of the mission planner over the duration when ``leg_duration`` is not given.
DEFAULT_LEGS = 10


def leg_duration(setup: PlanningSetup) -> float:
    """Return the mission planner's leg, s: the table's, or a tenth of the duration."""
    if setup.leg_duration is not None:
        return float(setup.leg_duration)
    return max(1, round(setup.steps / DEFAULT_LEGS)) * setup.interval


def mission_planner(setup: PlanningSetup) -> MissionPlanner:
    """Return the mission planner of a planning table, for its whole duration."""
    p = setup.planner
    # the search of the benchmark that measured it (benchmarks/planning_passive_mc.py)
    return MissionPlanner(p.kinematics, p.plan, p.interval, leg_duration(setup),
                          setup.start.time + setup.duration, p.criterion, headings=12,
                          sweeps=2, refine=1, gamma=p.gamma, constraints=p.constraints,
                          hypotheses=setup.hypotheses > 1)


def fixed_policy(setup: PlanningSetup) -> TrackPolicy | str:
    """Return the scenario's fixed pattern as a policy, or why there is none."""
    track = setup.scenario.sensors[setup.sensor]
    times = setup.start.time + setup.interval * np.arange(setup.steps + 1)
    try:
        states = track.states(times)
    except ValueError as e:
        return f"the fixed path of sensor {setup.sensor!r} does not cover the run ({e})"
    if not np.all(np.isfinite(states)):
        return (f"the fixed path of sensor {setup.sensor!r} does not cover the "
                f"{setup.duration:g} s of the run")
    return TrackPolicy(track, setup.planner.plan, setup.interval, setup.planner.constraints)


def policy(setup: PlanningSetup) -> Policy:
    """Return what steers the sensor: the mission policy or the horizon planner."""
    if setup.kind != "mission":
        return setup.planner
    k = setup.hypotheses
    fixed = fixed_policy(setup)
    return MissionPolicy(mission_planner(setup), tuple((2 * i + 1) / (2 * k) for i in range(k)),
                         None if isinstance(fixed, str) else fixed.track)


def describe(setup: PlanningSetup) -> str:
    """Say in words which planner steers and how."""
    p = setup.planner
    if setup.kind == "mission":
        hyp = (f"{setup.hypotheses} range hypotheses, each with its own information"
               if setup.hypotheses > 1 else f"gamma {p.gamma} over the tracker's cloud")
        return (f"mission planner: legs of {leg_duration(setup):g} s to the end, re-planned "
                f"at every leg for the least final {p.criterion.name} over {hyp}")
    return (f"horizon planner (Hurtado & Nehorai 2008): {len(p.actions)} actions every "
            f"{p.interval:g} s, horizon {p.horizon}, criterion {p.criterion.name}, "
            f"gamma {p.gamma}")


def loop_case(setup: PlanningSetup, name: str = CASE, steer: Policy | None = None) -> LoopCase:
    """Return a closed-loop case of a planning setup."""
    loop = LoopSetup(setup.target, setup.start, setup.steps, setup.interval, setup.q,
                     setup.prior_std, setup.tracker, setup.particles)
    return LoopCase(name, policy(setup) if steer is None else steer, setup.planner.plan, loop)


@dataclass(frozen=True, eq=False)
class PlanRun:
    """The closed-loop runs of a planned scenario, and of its fixed pattern beside.

    Attributes
    ----------
    setup : PlanningSetup
        What was run.
    study : ClosedLoopStudy
        The runs: case :data:`CASE` and, when the pattern covers the run, :data:`FIXED` (its
        figures per decision: ``study.rmse(case)``, ``study.pcrb(case)``, ...).
    fixed_note : str or None
        Why there is no fixed case (None when there is one).
    """

    setup: PlanningSetup
    study: ClosedLoopStudy
    fixed_note: str | None = None

    def table(self) -> pd.DataFrame:
        """Return the per-step table: one row per case, run and decision.

        Returns
        -------
        pandas.DataFrame
            :meth:`ClosedLoopStudy.table`'s columns, the flown sensor heading
            ``sensor_heading_deg`` (deg clockwise from North), the true and estimated target
            position ``truth_x``, ..., ``estimate_y`` (m) and velocity ``truth_vx``, ...,
            ``estimate_vy`` (m/s).
        """
        table = self.study.table()
        records = [r for case in self.study.cases for r in self.study.records[case]]
        d = self.setup.target.shape[0] // 2
        sensor = np.concatenate([r.sensor for r in records])
        table["sensor_heading_deg"] = np.degrees(np.arctan2(sensor[:, 3], sensor[:, 4])) % 360
        names = ["x", "y", "z"][:d] + ["vx", "vy", "vz"][:d]
        for what in ("truth", "estimate"):
            values = np.concatenate([getattr(r, what) for r in records])
            for j, name in enumerate(names):
                table[f"{what}_{name}"] = values[:, j]
        return table

    def summary(self, case: str = CASE) -> dict[str, float | int | None]:
        """Return the key figures of one case over every run.

        Parameters
        ----------
        case : str, optional

        Returns
        -------
        dict
            :meth:`ClosedLoopStudy.summary`'s figures, ``violations`` (steps with a
            constraint violation, over every run), ``max_violation_m`` (m) and ``steps``.
        """
        out: dict[str, float | int | None] = dict(self.study.summary(case))
        worst = np.concatenate([np.max(list(r.violations.values()), axis=0)
                                if r.violations else np.zeros(len(r))
                                for r in self.study.records[case]])
        out["violations"] = int(np.sum(worst > 1e-3))
        out["max_violation_m"] = float(worst.max())
        out["steps"] = int(self.setup.steps)
        return out

    def comparison(self, level: float = 0.95) -> dict[str, Any] | None:
        """Compare the planned path's final RMSE with the fixed pattern's, run for run.

        The runs share their draws, so the ratio's interval is a paired bootstrap over the
        runs (:data:`RESAMPLES`, seeded by the study's seed).

        Parameters
        ----------
        level : float, optional
            The interval's coverage.

        Returns
        -------
        dict or None
            ``planned_over_fixed`` (final RMSE ratio), ``low``, ``high`` (its interval; None
            with fewer than ``MIN_RUNS_INTERVAL`` runs) and ``verdict``: ``"better"``
            (interval below 1), ``"worse"`` (above 1), ``"not distinguishable"`` or too few
            runs; None without a fixed case.
        """
        if FIXED not in self.study.records:
            return None
        planned = self.study.stack(CASE, "error_m")[:, -1] ** 2
        fixed = self.study.stack(FIXED, "error_m")[:, -1] ** 2
        r = planned.shape[0]
        found: dict[str, Any] = {"planned_over_fixed": float(np.sqrt(planned.mean()
                                                                      / fixed.mean())),
                                 "low": None, "high": None,
                                 "verdict": f"too few runs to tell (< {MIN_RUNS_INTERVAL})"}
        if r >= MIN_RUNS_INTERVAL:
            rng = np.random.default_rng([0 if self.study.seed is None else self.study.seed, r,
                                         1])
            w = rng.multinomial(r, np.full(r, 1.0 / r), size=RESAMPLES)
            boot = np.sqrt((w @ planned) / (w @ fixed))
            lo, hi = (float(v) for v in np.quantile(boot, [(1 - level) / 2, (1 + level) / 2]))
            found.update(low=lo, high=hi, verdict="better" if hi < 1 else "worse" if lo > 1
                         else "not distinguishable")
        return found

    def warnings(self) -> list[str]:
        """Say what a user must know before flying the planned path.

        Returns
        -------
        list of str
            A sentence when the planned path did worse than the fixed pattern (or could not
            be shown better), when there is no fixed pattern to compare with, and when a
            case's RMSE is below its bound beyond the Monte Carlo uncertainty.
        """
        said = []
        found = self.comparison()
        if found is None:
            said.append(f"no comparison with a fixed pattern: {self.fixed_note}")
        elif found["planned_over_fixed"] >= 1.0:
            said.append(f"the planned path did WORSE than the scenario's fixed pattern "
                        f"(final RMSE {found['planned_over_fixed']:.2f}x the fixed one's"
                        f"{_interval(found['low'], found['high'])}): fly the fixed pattern, or "
                        "plan with another planner (--planner)")
        elif found["verdict"] != "better":
            said.append(f"the planned path is not shown better than the fixed pattern over "
                        f"{self.study.runs(CASE)} runs (final RMSE "
                        f"{found['planned_over_fixed']:.2f}x"
                        f"{_interval(found['low'], found['high'])}): run more (--runs)")
        for case in self.study.cases:
            s = self.study.summary(case)
            high = s["rmse_over_pcrb_high"]
            if high is not None and high < 1.0:
                said.append(f"{case}: the RMSE is below the posterior CRB beyond its Monte "
                            f"Carlo uncertainty (ratio {s['rmse_over_pcrb']:.2f}, 95 % "
                            f"interval up to {high:.2f}): the tracker and the bound do not "
                            "share a model")
        return said


def _interval(low: float | None, high: float | None) -> str:
    return "" if low is None or high is None else f", 95 % interval {low:.2f}-{high:.2f}"


def _changes(setup: PlanningSetup, duration: float | None, particles: int | None,
             tracker: str | None, planner: str | None) -> dict[str, Any]:
    """Return the setup fields that the options change (ValueError naming a bad option)."""
    changes: dict[str, Any] = {}
    if duration is not None:
        if isinstance(duration, bool) or not isinstance(duration, int | float | np.floating):
            raise ValueError(f"duration must be a number of seconds; got {duration!r}")
        ratio = float(duration) / setup.interval
        if not (ratio >= 1 and abs(ratio - round(ratio)) <= 1e-6 * ratio):
            raise ValueError(f"duration must be a whole number (>= 1) of decision intervals "
                             f"of {setup.interval:g} s; got {duration} s")
        changes["steps"] = round(ratio)
        if changes["steps"] > MAX_DECISIONS:
            raise ValueError(f"duration {duration:g} s: {decisions_text(changes['steps'])} "
                             f"decisions of {setup.interval:g} s per run, more than the limit "
                             f"of {MAX_DECISIONS:,}")
    if particles is not None:
        changes["particles"] = particles
    if tracker is not None:
        changes["tracker"] = tracker
    if planner is not None:
        if planner not in PLANNERS:
            raise ValueError(f"planner must be one of {', '.join(PLANNERS)}; got {planner!r}")
        changes["kind"] = (("mission" if passive(setup.planner.plan) else "horizon")
                           if planner == "auto" else planner)
    return changes


def plan(scenario: str | os.PathLike[str] | PlanningSetup, *, runs: int | None = None,
         rng: RngLike = 0, duration: float | None = None, particles: int | None = None,
         tracker: str | None = None, planner: str | None = None, fixed: bool = True,
         dask: Any = None, progress: bool = False,
         seed: int | NotGiven | None = NOT_GIVEN,
         on_chunk: Callable[[LoopChunk], None] | None = None) -> PlanRun:
    """Run a scenario's planned sensor, and its fixed pattern, in the closed loop ``runs`` times.

    Parameters
    ----------
    scenario : str, path or PlanningSetup
        A built-in scenario name (``"plan-bearings-only"``), a TOML file with a ``[planning]``
        table, or a setup already built.
    runs : int, optional
        Monte Carlo runs (default the table's ``runs``).
    rng : int, numpy.random.Generator or None, optional
        The study's seed (same seed, same table); a Generator gives one; None: fresh entropy.
    duration : float, optional
        Planned time (s), a whole number of decision intervals (default the table's).
    particles : int, optional
        Particles of the particle filter (default the table's).
    tracker : {"pf", "ekf", "ukf"}, optional
        The tracker (default the table's).
    planner : {"auto", "mission", "horizon"}, optional
        The planner (default the table's ``planner``; ``"auto"``: the mission planner for a passive
        sensor).
    fixed : bool, optional
        Also fly the scenario's fixed pattern with the same seeds.
    dask : str or distributed.Client, optional
        Run on a Dask cluster.
    progress : bool, optional
        Show a progress bar.
    seed : int or None, optional
        Deprecated: ``rng``.
    on_chunk : callable, optional
        Called with each finished :class:`~tmakit.montecarlo.closed_loop.LoopChunk` (``tma plan
        -o`` saves each one as it ends: a long study interrupted keeps its finished runs).

    Returns
    -------
    PlanRun

    Raises
    ------
    tmakit.scenario.files.ScenarioFileError
        If the scenario or its ``[planning]`` table is not valid.
    ValueError
        Naming the option out of range.
    TypeError
        If ``scenario`` is none of the types above (a ``Scenario`` object has no planning table: use
        its TOML file).
    """
    if not isinstance(scenario, PlanningSetup | str | os.PathLike):
        raise TypeError(f"plan() takes a scenario name, a TOML file with a [planning] table or "
                        f"a PlanningSetup (tmakit.load_planning), not "
                        f"{type(scenario).__name__}")
    seed_used = study_seed(renamed_keyword("plan", "seed", seed, "rng", rng, 0))
    setup = scenario if isinstance(scenario, PlanningSetup) else load_planning(scenario)
    changes = _changes(setup, duration, particles, tracker, planner)
    setup = setup.replace(**changes) if changes else setup
    cases = [loop_case(setup)]
    pattern = fixed_policy(setup) if fixed else "not asked for (fixed=False)"
    if not isinstance(pattern, str):
        cases.append(loop_case(setup, FIXED, pattern))
    study = closed_loop_study(cases, runs=setup.runs if runs is None else runs, seed=seed_used,
                              dask=dask, progress=progress, on_chunk=on_chunk)
    return PlanRun(setup, study, pattern if isinstance(pattern, str) else None)
