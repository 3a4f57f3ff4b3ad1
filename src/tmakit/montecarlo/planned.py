"""Run a scenario's ``[planning]`` table: the closed loop, many times; what ``tma plan`` shows.

:func:`plan` loads a scenario with a steered sensor (:func:`tmakit.scenario_file.load_planning`),
runs the closed loop of :mod:`tmakit.planning.closed_loop` (truth, the planner's move, the
simulated measurements, the tracker's update, replan) ``runs`` times through
:func:`~tmakit.montecarlo.closed_loop.closed_loop_study`, and returns a :class:`PlanRun`: the
per-step table (flown path, truth, estimate, bound, error, range, action, violations) and the
summary (final error against the bound, smallest range, violations, decision time).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..keywords import NOT_GIVEN, NotGiven, RngLike, renamed_keyword, study_seed
from ..planning.closed_loop import LoopSetup
from ..scenario_file import load_planning
from ..scenario_planning import MAX_DECISIONS, PlanningSetup
from .closed_loop import ClosedLoopStudy, LoopCase, closed_loop_study

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["CASE", "PlanRun", "loop_case", "plan"]

#: The case name of the planned path in the study and its table.
CASE = "planned"


def loop_case(setup: PlanningSetup, name: str = CASE) -> LoopCase:
    """Return the closed-loop case of a planning setup (its planner, plan and loop setup).

    Parameters
    ----------
    setup : PlanningSetup
        From a scenario's ``[planning]`` table.
    name : str, optional
        The case's name.

    Returns
    -------
    LoopCase
    """
    loop = LoopSetup(setup.target, setup.start, setup.steps, setup.interval, setup.q,
                     setup.prior_std, setup.tracker, setup.particles)
    return LoopCase(name, setup.planner, setup.planner.plan, loop)


@dataclass(frozen=True, eq=False)
class PlanRun:
    """The closed-loop runs of a planned scenario.

    Attributes
    ----------
    setup : PlanningSetup
        What was run.
    study : ClosedLoopStudy
        The runs (case :data:`CASE`), per run a
        :class:`~tmakit.planning.closed_loop.LoopRecord`.
    """

    setup: PlanningSetup
    study: ClosedLoopStudy

    @property
    def records(self) -> list[Any]:
        """The runs' records, in run order."""
        return self.study.records[CASE]

    @property
    def times(self) -> np.ndarray:
        """Decision times ``t_1 .. t_D`` (D,), s."""
        return self.study.times(CASE)

    def rmse(self) -> np.ndarray:
        """Return the position RMSE over the runs at each decision.

        Returns
        -------
        ndarray, shape (D,)
            m.
        """
        return self.study.rmse(CASE)

    def bound(self) -> np.ndarray:
        """Return the RMS over the runs of the position bound along the flown path.

        Returns
        -------
        ndarray, shape (D,)
            m.
        """
        return self.study.bound(CASE)

    def table(self) -> pd.DataFrame:
        """Return the per-step table: one row per run and decision.

        Returns
        -------
        pandas.DataFrame
            The closed-loop study's columns (``case``, ``run``, ``step``, ``time`` (s),
            ``sensor_x``, ``sensor_y`` (m), ``action``, ``bound_m``, ``predicted_bound_m``,
            ``error_m``, ``range_m`` (m), ``decision_ms`` (ms), ``violation_m`` and one
            ``violation_<constraint>_m`` each) and the flown sensor heading ``sensor_heading_deg``
            (deg clockwise from North), the true and estimated target position ``truth_x``,
            ``truth_y``, ``estimate_x``, ``estimate_y`` (m) and velocity ``truth_vx``, ...,
            ``estimate_vy`` (m/s).
        """
        table = self.study.table()
        table = table[table["case"] == CASE].reset_index(drop=True)
        d = self.setup.target.shape[0] // 2
        sensor = np.concatenate([r.sensor for r in self.records])
        table["sensor_heading_deg"] = np.degrees(np.arctan2(sensor[:, 3], sensor[:, 4])) % 360
        names = ["x", "y", "z"][:d] + ["vx", "vy", "vz"][:d]
        for what in ("truth", "estimate"):
            values = np.concatenate([getattr(r, what) for r in self.records])
            for j, name in enumerate(names):
                table[f"{what}_{name}"] = values[:, j]
        return table

    def summary(self) -> dict[str, float | int]:
        """Return the key figures over every run.

        Returns
        -------
        dict
            ``final_rmse_m`` (position RMSE over runs at the last step, m),
            ``final_bound_m`` (RMS over runs of the bound along the flown path, m),
            ``min_range_m`` (true range, over every run and step, m), ``violations`` (steps
            with a constraint violation, over every run), ``max_violation_m`` (m),
            ``mean_decision_ms`` (ms), ``runs``, ``steps``.
        """
        out: dict[str, float | int] = dict(self.study.summary(CASE))
        worst = np.concatenate([np.max(list(r.violations.values()), axis=0)
                                if r.violations else np.zeros(len(r)) for r in self.records])
        out["violations"] = int(np.sum(worst > 1e-3))
        out["max_violation_m"] = float(worst.max())
        out["steps"] = int(self.setup.steps)
        return out


def plan(scenario: str | os.PathLike[str] | PlanningSetup, *, runs: int | None = None,
         rng: RngLike = 0, duration: float | None = None, particles: int | None = None,
         tracker: str | None = None, dask: Any = None, progress: bool = False,
         seed: int | NotGiven | None = NOT_GIVEN) -> PlanRun:
    """Run a scenario's planned sensor in the closed loop ``runs`` times.

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
    dask : str or distributed.Client, optional
        Run on a Dask cluster.
    progress : bool, optional
        Show a progress bar.
    seed : int or None, optional
        Deprecated: ``rng``.

    Returns
    -------
    PlanRun

    Raises
    ------
    tmakit.scenario_file.ScenarioFileError
        If the scenario or its ``[planning]`` table is not valid.
    ValueError
        Naming the option out of range.
    TypeError
        If ``scenario`` is none of the types above (a ``Scenario`` object has no planning
        table: use its TOML file).

    Examples
    --------
    >>> import tmakit as tk
    >>> run = tk.plan("plan-bearings-only", runs=1, duration=60.0, particles=300)
    >>> run.summary()["steps"], len(run.table())
    (6, 6)
    """
    if not isinstance(scenario, PlanningSetup | str | os.PathLike):
        raise TypeError(f"plan() takes a scenario name, a TOML file with a [planning] table or "
                        f"a PlanningSetup (tmakit.load_planning), not "
                        f"{type(scenario).__name__}")
    seed_used = study_seed(renamed_keyword("plan", "seed", seed, "rng", rng, 0))
    setup = scenario if isinstance(scenario, PlanningSetup) else load_planning(scenario)
    steps = None
    if duration is not None:
        if isinstance(duration, bool) or not isinstance(duration, int | float | np.floating):
            raise ValueError(f"duration must be a number of seconds; got {duration!r}")
        ratio = float(duration) / setup.interval
        if not (ratio >= 1 and abs(ratio - round(ratio)) <= 1e-6 * ratio):
            raise ValueError(f"duration must be a whole number (>= 1) of decision intervals "
                             f"of {setup.interval:g} s; got {duration} s")
        steps = round(ratio)
        if steps > MAX_DECISIONS:
            raise ValueError(f"duration {duration:g} s: {steps:,} decisions of "
                             f"{setup.interval:g} s per run, more than the limit of "
                             f"{MAX_DECISIONS:,}")
    setup = setup.replace(steps=steps, particles=particles, tracker=tracker)
    study = closed_loop_study([loop_case(setup)], runs=setup.runs if runs is None else runs,
                              seed=seed_used, dask=dask, progress=progress)
    return PlanRun(setup, study)
