"""Reproduce Hurtado & Nehorai (2008), section 5: adaptive path of a moving radar, Figs. 1-3.

A target East at 25 m/s, a radar measuring azimuth, range and range rate each 0.5 s pulse,
tracked by a particle filter; three cases (fixed path North, adaptive, minimum range 5 km as a
hard constraint and as the paper's penalty).  What the paper leaves open is chosen in
:data:`SETUP` (start positions, noise, the hard limit's turn-radius margin of 573 m, the radar
variants); docs/planning.md gives the choices and the measured claims.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..montecarlo.closed_loop import (
    TRACKERS,
    ClosedLoopStudy,
    LoopCase,
    LoopChunk,
    LoopSetup,
    closed_loop_study,
)
from ..planning import MinimumRange, Planner, SensorPlan
from ..planning.policies import FixedPolicy

__all__ = ["CASES", "OPTIONS", "RADARS", "SETUP", "TRACKERS", "Hurtado2008Reproduction",
           "Hurtado2008Setup", "cases", "claims", "plot", "radar_plan", "run"]
from ..scenario.planning_table import MAX_DECISIONS, decisions_text
from ..sensors.platform import HURTADO_NEHORAI_2008, PlatformState
from .common import Reproduction, Section

#: The radar variants.
RADARS = ("derived", "resolution", "scenario", "derived-correlated")
#: The cases, in order.
CASES = ("fixed", "adaptive", "min-range hard", "min-range penalty")
#: Options of :func:`run` beyond ``runs``, ``seed`` and ``progress`` (``tma reproduce``
#: passes them when given).
OPTIONS = ("particles", "steps", "radar", "tracker", "chunk", "dask", "on_chunk")


@dataclass(frozen=True)
class Hurtado2008Setup:
    """The section 5 scenario with tmakit's choices."""

    #: radar_start, target_start: ENU start positions (m)
    radar_start: tuple[float, float] = (0.0, 0.0)
    target_start: tuple[float, float] = (5000.0, 15000.0)
    #: radar_speed, target_velocity: 50 m/s North; (25, 0) m/s
    radar_speed: float = 50.0
    target_velocity: tuple[float, float] = (25.0, 0.0)
    #: duration, interval: 300 s; PRI 0.5 s
    duration: float = 300.0
    interval: float = 0.5
    min_range: float = 5000.0  # Example 2's limit (m)
    q: float = 0.1  # Target process noise (m/s^2)
    prior_std: tuple[float, float] = (100.0, 5.0)  # Prior standard deviations (m, m/s)

    @property
    def steps(self) -> int:
        """Decisions over the duration (600)."""
        return round(self.duration / self.interval)

    @property
    def turn_margin(self) -> float:
        """Tightest turn radius at full speed (m), the hard constraint's margin."""
        kin = HURTADO_NEHORAI_2008.kinematics
        return float(kin.max_speed / kin.max_turn_rate)


SETUP = Hurtado2008Setup()


def radar_plan(radar: str = "derived") -> SensorPlan:
    """Return what the radar measures at each pulse: azimuth, range, range rate."""
    if radar not in RADARS:
        raise ValueError(f"radar must be one of {', '.join(RADARS)}, got {radar!r}")
    kinds = ("bearing", "range", "range_rate")
    if radar == "scenario":
        return SensorPlan(kinds, [math.radians(1.0), 30.0, 0.5])
    try:
        from ..sensors.radar import RadarModel
    except ImportError:
        raise ValueError(f"radar {radar!r} needs the radar model (tmakit.sensors.radar), "
                         "which this build lacks; use radar 'scenario'") from None
    model = RadarModel(range_accuracy="derived" if radar == "derived-correlated" else radar)
    if radar == "derived-correlated":
        return SensorPlan(kinds, model.measurement_sigmas(kinds),
                          covariance=model.measurement_covariance(kinds))
    return SensorPlan(kinds, model.measurement_sigmas(kinds))


def cases(radar: str = "derived", particles: int = 2000, steps: int | None = None,
          tracker: str = "pf", setup: Hurtado2008Setup = SETUP) -> list[LoopCase]:
    """Build the four cases of the reproduction (Hurtado & Nehorai (2008), §5, Examples 1 and 2)."""
    plan = radar_plan(radar)
    cfg = HURTADO_NEHORAI_2008
    loop = LoopSetup(
        target=np.array([*setup.target_start, *setup.target_velocity], dtype=np.float64),
        platform=PlatformState(setup.radar_start, 0.0, setup.radar_speed),
        steps=setup.steps if steps is None else steps, interval=setup.interval, q=setup.q,
        prior_std=setup.prior_std, tracker=tracker, particles=particles)

    def planner(*constraints: Any) -> Planner:
        return Planner(cfg.kinematics, cfg.actions, setup.interval, plan,
                       constraints=constraints)

    return [
        LoopCase("fixed", FixedPolicy(cfg.kinematics, plan, setup.interval), plan, loop),
        LoopCase("adaptive", planner(), plan, loop),
        LoopCase("min-range hard", planner(MinimumRange(setup.min_range + setup.turn_margin)),
                 plan, loop),
        LoopCase("min-range penalty", planner(MinimumRange(setup.min_range, hard=False)),
                 plan, loop)]


@dataclass
class Hurtado2008Reproduction(Reproduction):
    """The report, with the study kept for the figure."""

    study: ClosedLoopStudy | None = field(default=None, repr=False)  # The runs


def _turns(study: ClosedLoopStudy, case: str, start: int) -> float:
    """Median over runs of the turns the sensor makes around the true target from ``start``."""
    sensor = study.stack(case, "sensor")[:, start:, :2]
    target = study.stack(case, "truth")[:, start:, :2]
    rel = sensor - target
    ang = np.unwrap(np.arctan2(rel[..., 0], rel[..., 1]), axis=1)
    return float(np.median(np.abs(ang[:, -1] - ang[:, 0])) / (2 * math.pi))


def claims(study: ClosedLoopStudy, setup: Hurtado2008Setup = SETUP) -> list[list[object]]:
    """Check the paper's qualitative claims on the runs (§5, Examples 1 and 2)."""
    d = len(study.times("adaptive"))
    late = (2 * d) // 3  # the last third of the run: the circling phase
    mean_range = {c: study.stack(c, "range_m").mean(axis=0) for c in study.cases}
    r0 = float(mean_range["adaptive"][0])
    close = float(mean_range["adaptive"].min())
    first = int(np.argmax(mean_range["adaptive"] <= 2 * close))
    turns = _turns(study, "adaptive", first)
    far = {c: float(np.median(study.stack(c, "range_m")[:, late:])) for c in study.cases}
    final = {c: _figure(study.summary(c), "final_rmse_m") for c in study.cases}
    hard_min = _figure(study.summary("min-range hard"), "min_range_m")
    return [
        ["the adaptive radar moves toward the target",
         f"mean range {r0 / 1e3:.2f} km -> {close / 1e3:.2f} km", close < 0.25 * r0],
        ["then circles around it",
         f"median {turns:.2f} turns around the target after t = "
         f"{float(study.times('adaptive')[first]):.0f} s", turns >= 1.0],
        ["with the 5 km limit it circles further away",
         f"median range, last third: {far['adaptive'] / 1e3:.2f} km (adaptive), "
         f"{far['min-range hard'] / 1e3:.2f} km (hard), "
         f"{far['min-range penalty'] / 1e3:.2f} km (penalty)",
         far["min-range hard"] > far["adaptive"] and far["min-range penalty"] > far["adaptive"]],
        ["the hard limit is kept", f"minimum true range {hard_min / 1e3:.3f} km",
         hard_min >= setup.min_range],
        ["both adaptive paths beat the fixed path",
         "final RMSE " + ", ".join(f"{c} {v:.1f} m" for c, v in final.items()),
         final["adaptive"] < final["fixed"] and final["min-range hard"] < final["fixed"]
         and final["min-range penalty"] < final["fixed"]],
    ]


def run(runs: int = 100, seed: int = 1, progress: bool = True, *, particles: int = 2000,
        steps: int | None = None, radar: str = "derived", tracker: str = "pf",
        chunk: int | None = None, dask: Any = None,
        on_chunk: Callable[[LoopChunk], None] | None = None) -> Hurtado2008Reproduction:
    """Run the four cases and check the paper's claims (§5, Figs. 1-3)."""
    if runs < 1:
        raise ValueError(f"runs must be >= 1 for this reproduction, got {runs}")
    if steps is not None and not 3 <= steps <= MAX_DECISIONS:  # (1e8 ran on for hours)
        raise ValueError(f"steps must be within [3, {MAX_DECISIONS:,}] (decisions per run, "
                         f"as a [planning] duration), got {decisions_text(steps)}")
    if tracker not in TRACKERS:
        raise ValueError(f"tracker must be one of {', '.join(TRACKERS)}, got {tracker!r}")
    study = closed_loop_study(cases(radar, particles, steps, tracker), runs, seed, chunk,
                              dask, progress, on_chunk)
    rep = Hurtado2008Reproduction("hurtado2008", study=study, print_figures=False)
    summaries = {c: study.summary(c) for c in study.cases}
    rep.sections.append(Section(
        f"Hurtado & Nehorai (2008) section 5: {runs} runs, {len(study.times('fixed'))} pulses, "
        f"radar {radar!r}, tracker {tracker} ({particles} particles): error and bound",
        ["case", "RMSE (m)", "bound: PCRB (m)", "RMSE/bound", "95 % interval"],
        [_row(c, s) for c, s in summaries.items()], BOUND_NOTE))
    rep.sections.append(Section(
        "The paths flown", ["case", "planning criterion (m)", "min range (m)", "decision (ms)"],
        [[c, round(_figure(s, "final_criterion_m"), 3), round(_figure(s, "min_range_m"), 1),
          round(_figure(s, "mean_decision_ms"), 3)] for c, s in summaries.items()], PATHS_NOTE))
    checked = claims(study)
    rep.sections.append(Section("The paper's claims, measured", ["claim", "measured", "holds"],
                                [[c, m, "yes" if ok else "NO"] for c, m, ok in checked]))
    fixed = _figure(summaries["fixed"], "final_rmse_m")
    rep.figures = {
        "cases": summaries,
        "claims": {c: bool(ok) for c, _, ok in checked},
        "rmse_ratio_to_fixed": {c: _figure(s, "final_rmse_m") / fixed
                                for c, s in summaries.items()},
        "settings": {"radar": radar, "tracker": tracker, "particles": particles,
                     "seed": seed, "target_start_m": list(SETUP.target_start),
                     "radar_start_m": list(SETUP.radar_start),
                     "hard_margin_m": SETUP.turn_margin},
    }
    return rep


#: What the first table's bound is (printed under it).
BOUND_NOTE = (
    "RMSE: position error over the runs at the last pulse. Bound: the posterior CRB at the "
    "true target along the flown paths (Tichavsky et al. 1998; Gamma the mean over the runs "
    "of the information at the truth and the flown radar state, with the tracker's prior and "
    "process noise), which no tracker of the same model beats on average. RMSE/bound with "
    "its 95 % Monte Carlo interval (a chi-square and a bootstrap over the runs; none under 10 "
    "runs; below 1 beyond it would mean the bound and the tracker differ).")
#: What the second table's columns are.
PATHS_NOTE = (
    "Planning criterion: what the planner believed along its path at the last pulse (the "
    "same recursion with Gamma over the tracker's particles, RMS over runs); not a bound. "
    "Min range: true range over every run and pulse. Decision: mean time of one decision.")


def _figure(summary: Mapping[str, float | int | None], key: str) -> float:
    """Give a figure of :meth:`ClosedLoopStudy.summary` that is always a number."""
    value = summary[key]
    if value is None:
        raise ValueError(f"the closed-loop study gives no {key}")
    return float(value)


def _row(case: str, s: dict[str, Any]) -> list[object]:
    return [case, round(s["final_rmse_m"], 3), round(s["final_pcrb_m"], 3),
            round(s["rmse_over_pcrb"], 3),
            "-" if s["rmse_over_pcrb_low"] is None
            else f"{s['rmse_over_pcrb_low']:.3f}-{s['rmse_over_pcrb_high']:.3f}"]


def plot(rep: Hurtado2008Reproduction, path: str | Path) -> Path:
    """Draw example paths, RMSE against the bound and the range to the target (§5, Figs. 1-3)."""
    from matplotlib.figure import Figure

    study = rep.study
    if study is None:
        raise ValueError("the reproduction holds no runs to draw")
    fig = Figure(figsize=(17, 5.5))
    ax_map, ax_err, ax_rng = fig.subplots(1, 3)
    colours = dict(zip(study.cases, ("tab:gray", "tab:blue", "tab:red", "tab:orange"),
                       strict=False))
    truth = study.stack("fixed", "truth")[0]
    ax_map.plot(truth[:, 0] / 1e3, truth[:, 1] / 1e3, "k-", lw=2, label="target (run 0)")
    styles = dict(zip(study.cases, ("-", "-", "--", ":"), strict=False))
    for case in study.cases:
        s = study.stack(case, "sensor")[0]
        c = colours[case]
        ax_map.plot(s[:, 0] / 1e3, s[:, 1] / 1e3, color=c, lw=1.2, ls=styles[case],
                    label=case)
        t = study.times(case)
        ax_err.semilogy(t, study.rmse(case), color=c, lw=1, label=f"{case} RMSE")
        ax_err.semilogy(t, study.pcrb(case), color=c, lw=1, ls="--", label=f"{case} PCRB")
        r = study.stack(case, "range_m") / 1e3
        ax_rng.plot(t, r.mean(axis=0), color=c, lw=1, label=case)
        ax_rng.fill_between(t, r.min(axis=0), r.max(axis=0), color=c, alpha=0.15, lw=0)
    ax_map.set(xlabel="East (km)", ylabel="North (km)", title="Paths (Fig. 1), run 0",
               aspect="equal")
    ax_map.legend(fontsize=7)
    ax_err.set(xlabel="time (s)", ylabel="position error (m)",
               title="RMSE (solid) and posterior CRB at the truth (dashed)")
    ax_err.legend(fontsize=6, ncol=2)
    ax_rng.axhline(SETUP.min_range / 1e3, color="k", lw=0.5, ls=":")
    ax_rng.set(xlabel="time (s)", ylabel="range (km)",
               title="Range to target: mean, min-max over runs")
    ax_rng.legend(fontsize=7)
    fig.suptitle("Hurtado & Nehorai (2008), section 5")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return Path(path)
