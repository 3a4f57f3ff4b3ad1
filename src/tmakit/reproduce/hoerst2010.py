"""Reproduce Hörst & Oispuu (2010): the Cramér–Rao analysis of §4, Fig. 2.

The scenario is ``hoerst2010`` (§4: target from (-9 km, 12 km) at 50 m/s heading East, a turn with
a_n = 0.5 m/s^2 from 400 s to 600 s; observer circling counter-clockwise at 50 m/s; one azimuth
(sigma 2 deg) and one azimuth rate (sigma 1 mrad/s) per second, to 900 s).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..bounds.manoeuvre import CrbSequence, curvilinear_crb_sequence
from ..motion import PiecewiseCurvilinear
from ..scenario.files import load_scenario
from ..scenario.model import Scenario
from .common import Reproduction, Section


def _change_overs(scn: Scenario) -> list[float]:
    """Give the change-over times (s) of a scenario's piecewise curvilinear target."""
    assert isinstance(scn.motion, PiecewiseCurvilinear)
    return [scn.truth[f"t_{m}"] for m in range(1, scn.motion.manoeuvres + 1)]


STEP = 10.0                 # s between reference times / ellipses (§4)
LEVEL = 0.9                 # 90 % confidence ellipses (§4)
OMIT_EXTENT = 30e3          # m: "ellipses with an extent of over 30 km have been omitted"
TABLE_TIMES = (300.0, 400.0, 600.0, 750.0, 900.0)
BOTH = ("bearing", "azimuth_rate")
# key: (label, kinds, manoeuvres known)
CASES: dict[str, tuple[str, tuple[str, ...], bool]] = {
    "azimuth": ("azimuth only", ("bearing",), False),
    "azimuth+rate": ("azimuth + azimuth rate", BOTH, False),
    "azimuth+rate, known": ("azimuth + rate, manoeuvres known", BOTH, True),
    "azimuth, known": ("azimuth only, manoeuvres known", ("bearing",), True),
}


@dataclass
class Hoerst2010Reproduction(Reproduction):
    """The report plus what :func:`plot` needs."""

    scenario: Scenario | None = field(default=None, repr=False)  # The hoerst2010 scenario
    #: One bound sequence per case of :data:`CASES`
    sequences: dict[str, CrbSequence] = field(default_factory=dict, repr=False)


def reference_times(scn: Scenario, step: float = STEP) -> np.ndarray:
    """Give the reference times ``t0 + step, t0 + 2 step, ...`` up to the last sample."""
    t0, t1 = scn.time_span()
    return t0 + step * np.arange(1, int(np.floor((t1 - t0) / step + 1e-9)) + 1)


def sequences(step: float = STEP, scn: Scenario | None = None) -> dict[str, CrbSequence]:
    """Compute the bound sequence of every case of :data:`CASES`, every ``step`` s (§4)."""
    scn = scn or load_scenario("hoerst2010")
    refs = reference_times(scn, step)
    return {key: curvilinear_crb_sequence(scn, refs, kinds, known, level=LEVEL)
            for key, (_, kinds, known) in CASES.items()}


def _m(v: float) -> object:
    return round(float(v), 1) if np.isfinite(v) else "unobservable"


def _text(v: float) -> str:
    return f"{v:.1f} m" if np.isfinite(v) else "unobservable"


def _num(v: float) -> float | None:
    return round(float(v), 1) if np.isfinite(v) else None


def run(runs: int = 0, seed: int = 1, progress: bool = True, step: float = STEP
        ) -> Hoerst2010Reproduction:
    """Compute the bounds and check the paper's statements about Fig. 2 (§4)."""
    scn = load_scenario("hoerst2010")
    seqs = sequences(step, scn)
    rep = Hoerst2010Reproduction("hoerst2010", scenario=scn, sequences=seqs)
    cot = _change_overs(scn)

    _table_section(rep, seqs)
    _claims_section(rep, seqs, cot, step)
    _figure_section(rep, seqs, step)
    return rep


def _table_section(rep: Hoerst2010Reproduction, seqs: dict[str, CrbSequence]) -> None:
    """Add the table of position RMS bounds at the paper's reference times."""
    rows = []
    times = [t for t in TABLE_TIMES if t in set(seqs["azimuth"].ref_times)]
    for t in times:
        pts = {k: s.at(t) for k, s in seqs.items()}
        rows.append([t, pts["azimuth"].manoeuvres,
                     *(_m(pts[k].rms) for k in CASES)])
    rep.sections.append(Section(
        "Position RMS bound sqrt(var x + var y) (m) at t_ref, data up to t_ref",
        ["t_ref (s)", "manoeuvres started", *(CASES[k][0] for k in CASES)], rows,
        "Unknowns: state at t_ref (x, y, speed, course), the accelerations of every segment "
        "so far and the change-over times of the manoeuvres started before t_ref (a "
        "manoeuvre starting exactly at t_ref is not yet one); 'manoeuvres known' leaves "
        "only the state unknown.  The paper prints no numbers for Fig. 2."))
    rep.figures["rms_m"] = {k: [_num(s.at(t).rms) for t in times] for k, s in seqs.items()}
    rep.figures["rms_times_s"] = times


def _claims_section(rep: Hoerst2010Reproduction, seqs: dict[str, CrbSequence],
                    cot: list[float], step: float) -> None:
    """Add the paper's statements about Fig. 2 (§4), each checked against the bounds."""
    az, azr = seqs["azimuth"], seqs["azimuth+rate"]
    refs = az.ref_times
    either = np.isfinite(az.rms) | np.isfinite(azr.rms)
    smaller = azr.rms[either] < az.rms[either]
    neither = refs[~either]
    checks = []
    checks.append([
        "azimuth + rate more accurate than azimuth only (all legs)",
        f"smaller bound at {int(smaller.sum())} of the {int(either.sum())} reference times "
        f"where either is finite (every {step:g} s from {refs[0]:g} to {refs[-1]:g} s)"
        + (f"; both unobservable at {', '.join(f'{t:g}' for t in neither)} s"
           if neither.size else ""),
        "yes" if bool(np.all(smaller)) else "NO"])
    jumps = {}
    for m, tm in enumerate(cot, start=1):
        if tm not in set(refs) or tm + step not in set(refs):
            continue
        before = {k: s.at(tm).rms for k, s in (("azimuth", az), ("azimuth+rate", azr))}
        after = {k: s.at(tm + step).rms for k, s in (("azimuth", az), ("azimuth+rate", azr))}
        grows = all(after[k] > before[k] for k in before)
        checks.append([
            f"accuracy decreases after manoeuvre {m} (t_{m} = {tm:g} s)",
            "; ".join(f"{k}: {_text(before[k])} at {tm:g} s -> {_text(after[k])} at "
                      f"{tm + step:g} s" for k in before),
            "yes" if grows else "NO"])
        jumps[f"t_{m}"] = {k: [_num(before[k]), _num(after[k])] for k in before}
    rep.figures["rms_before_after_m"] = jumps
    if len(cot) >= 2:
        turn = (refs > cot[0]) & (refs <= cot[1])
        med = {k: float(np.median(s.rms[turn])) for k, s in (("azimuth", az),
                                                             ("azimuth+rate", azr))}
        checks.append([
            f"turn leg ({cot[0]:g}-{cot[1]:g} s): reasonable with azimuth + rate, inferior "
            "with azimuth only",
            f"median RMS bound {_text(med['azimuth+rate'])} with azimuth + rate, "
            f"{_text(med['azimuth'])} with azimuth only",
            "yes" if med["azimuth+rate"] < med["azimuth"] else "NO"])
        rep.figures["turn_leg_median_rms_m"] = {k: _num(v) for k, v in med.items()}

    def first_below(s: CrbSequence, level_m: float) -> float | None:
        hit = np.flatnonzero(s.rms < level_m)
        return float(s.ref_times[hit[0]]) if hit.size else None

    f_az, f_azr = first_below(az, 1000.0), first_below(azr, 1000.0)
    checks.append([
        "azimuth + rate converges faster",
        f"position RMS bound first below 1 km at {f_azr:g} s with azimuth + rate, "
        f"{f_az:g} s with azimuth only" if f_az is not None and f_azr is not None else
        f"first below 1 km: azimuth + rate {f_azr}, azimuth only {f_az}",
        "yes" if f_azr is not None and (f_az is None or f_azr < f_az) else "NO"])
    rep.figures["first_below_1km_s"] = {"azimuth": f_az, "azimuth+rate": f_azr}
    rep.sections.append(Section("Fig. 2: the paper's statements (§4) checked",
                                ["statement", "tmakit", "holds"], checks))


def _figure_section(rep: Hoerst2010Reproduction, seqs: dict[str, CrbSequence],
                    step: float) -> None:
    """Add what the figure shows: ellipses drawn and left out per panel."""
    rows = []
    for key in ("azimuth", "azimuth+rate"):
        s = seqs[key]
        drawn, too_big, unobs = _ellipse_counts(s)
        rows.append([CASES[key][0], len(s.points), drawn, too_big, unobs])
        rep.figures[f"ellipses_drawn_{key}"] = drawn
    rep.sections.append(Section(
        f"Fig. 2 ellipses ({LEVEL:.0%}, every {step:g} s)",
        ["panel", "reference times", "drawn", f"left out: extent > {OMIT_EXTENT / 1e3:g} km",
         "left out: unobservable"], rows,
        "tma reproduce hoerst2010 --plot FILE.png draws the two panels."))


def _ellipse_counts(s: CrbSequence) -> tuple[int, int, int]:
    unobs = sum(1 for p in s.points if not p.observable)
    too_big = sum(1 for p in s.points if p.observable and p.extent > OMIT_EXTENT)
    return len(s.points) - unobs - too_big, too_big, unobs


def plot(rep: Hoerst2010Reproduction, path: str | Path) -> Path:
    """Draw Fig. 2 of Hörst & Oispuu (2010)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Ellipse

    scn = rep.scenario
    if scn is None or not rep.sequences:
        raise ValueError("plot() needs the result of hoerst2010.run()")
    t0, t1 = scn.time_span()
    t = np.linspace(t0, t1, 901)
    target = scn.target_states(t)[:, :2] / 1e3
    observer = scn.sensors["observer"].states(t)[:, :2] / 1e3
    cot = np.array(_change_overs(scn))
    turns = scn.target_states(cot)[:, :2] / 1e3 if cot.size else np.zeros((0, 2))

    fig = Figure(figsize=(13, 6.2), layout="constrained")
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    for ax, key in zip(axes, ("azimuth", "azimuth+rate"), strict=True):
        s = rep.sequences[key]
        ax.plot(observer[:, 0], observer[:, 1], "-", color="green", lw=1.2, label="observer")
        ax.plot(observer[0, 0], observer[0, 1], "s", color="green", ms=7)
        ax.plot(target[:, 0], target[:, 1], "-", color="blue", lw=1.2, label="target")
        ax.plot(target[0, 0], target[0, 1], "s", color="blue", ms=7)
        ax.plot(turns[:, 0], turns[:, 1], "o", color="blue", mfc="none", ms=8,
                label="change-over points")
        drawn, too_big, unobs = _ellipse_counts(s)
        first = True
        for p in s.points:
            if not p.observable or p.extent > OMIT_EXTENT:
                continue
            e = p.ellipse
            # matplotlib: width along the axis at `angle` degrees counter-clockwise from East;
            # the ellipse's major axis has a bearing (clockwise from North).
            ax.add_patch(Ellipse((e["east"] / 1e3, e["north"] / 1e3), 2 * e["major"] / 1e3,
                                 2 * e["minor"] / 1e3, angle=90.0 - e["bearing_deg"],
                                 fill=False, color="red", lw=0.7,
                                 label=f"{s.level:.0%} CRB ellipse" if first else None))
            first = False
        ax.set_title(f"{CASES[key][0]}: {drawn} ellipses drawn, {too_big} over "
                     f"{OMIT_EXTENT / 1e3:g} km and {unobs} unobservable left out",
                     fontsize=9)
        ax.set_xlabel("East (km)")
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left", fontsize=8)
    axes[0].set_ylabel("North (km)")
    fig.suptitle("Hörst & Oispuu 2010, Fig. 2: position CRB every "
                 f"{s.ref_times[1] - s.ref_times[0]:g} s from the data so far, accelerations "
                 "and change-over times unknown", fontsize=10)
    fig.savefig(path, dpi=120)
    return Path(path)
