"""The solution picture of a batch estimate (``tma estimate --plot``): geometry and residuals."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..data import MeasurementSet
from ..results import EstimateResult
from ..results.answers import KNOT, estimate_answer
from ..results.context import sensor_position
from .frame import (
    MapFrame,
    answer_ellipse,
    bearing_lines,
    clock_label,
    format_time_axis,
    map_legend,
    plain_ticks,
    plot_times,
    pyplot,
    save,
    sensor_path,
    track_xy,
    truth_track,
)

#: One nautical mile (m).
NAUTICAL_MILE = 1852.0
#: At most this many bearing lines are drawn (evenly spread over the rows).
MAX_BEARING_LINES = 40


def _draw_bearings(ax: Any, meas: MeasurementSet, frame: MapFrame, reach: float) -> None:
    """Draw the bearing lines from the sensors (evenly spread rows, ``reach`` metres long)."""
    xs, ys, _ = bearing_lines(meas, frame, reach, MAX_BEARING_LINES, points=20)
    for x, y in zip(xs, ys, strict=True):
        ax.plot(x, y, color="tab:orange", lw=0.6, alpha=0.45, zorder=1)
    if xs:
        ax.plot([], [], color="tab:orange", lw=0.8, label=f"bearings ({len(xs)} drawn)")


def _undetermined_words(result: EstimateResult, meas: MeasurementSet) -> str | None:
    """Give the position-undetermined warning of a fit with a track, if any."""
    from ..results.checks import range_spread_warning, wider_model_warning

    found = [w for w in (range_spread_warning(result.solutions, meas),
                         wider_model_warning(result, meas)) if w is not None]
    return None if not found else "position undetermined: " + found[0].message


def _draw_bearing_interval(ax: Any, result: EstimateResult, meas: MeasurementSet,
                           frame: MapFrame, reach: float, level: float) -> None:
    """Shade the reported region of an undetermined position: the bearing interval's fan."""
    from ..results.answers import bearing_interval

    a = estimate_answer(result, meas, level=level)
    span = bearing_interval(a, meas, level)
    if span is None or a.sensor is None:
        return
    origin = sensor_position(meas, a.sensor, a.time)[:2]
    b = np.radians(np.linspace(span[0] - span[1], span[0] + span[1], 30))
    pts = np.vstack([origin, origin + reach * np.stack([np.sin(b), np.cos(b)], axis=1), origin])
    ax.fill(*frame.xy(pts[:, 0], pts[:, 1]), color="tab:red", alpha=0.12, lw=0, zorder=1,
            label=f"{level:.0%} region: bearing {span[0]:.1f}° ± {span[1]:.2g}° "
                  "(range undetermined)")


def _draw_solution(ax: Any, result: EstimateResult, meas: MeasurementSet, frame: MapFrame,
                   n_labels: int, level: float) -> float:
    """Draw the estimated track, its ellipses and labelled times; give the largest semi-axis."""
    largest = 0.0
    _, xs, ys = track_xy(result, meas, frame)
    several = f", solution 1 of {len(result.solutions)}" if len(result.solutions) > 1 else ""
    ax.plot(xs, ys, color="tab:red", lw=2.0, label=f"estimate ({result.status}{several})",
            zorder=4)
    for tk in np.linspace(meas.time.min(), meas.time.max(), n_labels):
        a = estimate_answer(result, meas, time=float(tk), level=level)
        s = result.motion.states(result.estimate, np.array([tk]))[0]
        px, py = frame.xy(np.array([s[0]]), np.array([s[1]]))
        ax.plot(px, py, "o", color="tab:red", ms=4, zorder=5)
        text = "emitter (stationary)" if a.stationary else clock_label(meas, float(tk))
        ax.annotate(text, (px[0], py[0]), textcoords="offset points",
                    xytext=(6, 6), fontsize=8, color="tab:red",
                    bbox={"fc": "white", "alpha": 0.7, "lw": 0, "pad": 1})
        xy = answer_ellipse(frame, a, s[:2], level)
        if xy is not None and a.ellipse is not None:
            ax.plot(*xy, color="tab:red", lw=0.9, alpha=0.8, zorder=4)
            largest = max(largest, a.ellipse.semi_major)
        if a.stationary:
            break
    return largest


def _position_determined(result: EstimateResult, meas: MeasurementSet) -> bool:
    """Whether the fit is an answer whose position the data determine (else no track)."""
    if result.status != "converged" or not np.all(np.isfinite(result.estimate)):
        return False
    return None not in estimate_answer(result, meas).enu[:2]


def _words_box(ax: Any, words: str) -> None:
    """Write ``words`` in a box at the map panel's top left."""
    import textwrap

    ax.text(0.02, 0.98, "\n".join(textwrap.fill(w, 70) for w in words.split("\n")),
            transform=ax.transAxes, fontsize=8, va="top", ha="left", zorder=6,
            bbox={"fc": "white", "alpha": 0.85, "lw": 0.5, "pad": 4})


def _no_track_words(result: EstimateResult) -> str:
    """Why no track is drawn."""
    why = [f"no track: the estimate is {result.status}"
           + ("" if result.status == "converged" else
              f" ({result.message.split(';')[0]})" if result.message else "")]
    if result.bound is not None:
        why += [d.sentence for d in result.bound.observability.directions]
    return "\n".join(why)


#: Colours of the separated solutions after the first (which is drawn in red).
SOLUTION_COLOURS = ("tab:purple", "tab:green", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")


def _draw_other_solutions(ax: Any, result: EstimateResult, meas: MeasurementSet,
                          frame: MapFrame, level: float) -> float:
    """Draw each separated solution after the first: its track and its ellipse at the end."""
    largest = 0.0
    for k, sol in enumerate(result.solutions[1:]):
        colour = SOLUTION_COLOURS[k % len(SOLUTION_COLOURS)]
        states, xs, ys = track_xy(sol.result, meas, frame)
        ax.plot(xs, ys, "--", color=colour, lw=1.6, zorder=4,
                label=f"solution {sol.rank}: {sol.result.motion.name}, χ² "
                      f"{sol.result.chi2:.3g} (p {sol.p_value:.2g})")
        a = sol.answer(meas, time=float(meas.time.max()), level=level)
        ax.plot(*frame.xy(states[-1:, 0], states[-1:, 1]), "o", color=colour, ms=4, zorder=5)
        xy = answer_ellipse(frame, a, states[-1, :2], level)
        if xy is not None and a.ellipse is not None:
            ax.plot(*xy, color=colour, lw=0.9, zorder=4)
            largest = max(largest, a.ellipse.semi_major)
    return largest


def _ellipse_legend(ax: Any, frame: MapFrame, level: float, largest: float) -> None:
    """Add the ellipses' legend entry; say so when they are too small to be seen on the map."""
    x0, x1 = ax.get_xlim()
    width_m = abs(x1 - x0) * frame.metres_per_x()
    note = (f" (largest {largest:.3g} m: hidden by the dots)" if 0 < largest < 0.01 * width_m
            else "")
    ax.plot([], [], color="tab:red", lw=0.9, label=f"{level:.0%} position ellipses{note}")


def _fill_panel(ax: Any, frame: MapFrame, ratio: float = 1.15) -> None:
    """Widen the shorter side of the map so that, at true scale, width / height = ``ratio``."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    w, h = (x1 - x0), (y1 - y0) * frame.aspect()  # both in horizontal map units
    if w < ratio * h:
        pad = (ratio * h - w) / 2
        ax.set_xlim(x0 - pad, x1 + pad)
    else:
        pad = (w / ratio - h) / 2 / frame.aspect()
        ax.set_ylim(y0 - pad, y1 + pad)


def _draw_map(ax: Any, result: EstimateResult, meas: MeasurementSet, n_labels: int,
              level: float, legs: dict[str, Any] | None = None) -> None:
    """Draw the geometry panel (the own ship's turns and legs when ``legs`` are given)."""
    frame = MapFrame(meas)
    for s in meas.sensors:
        t, _, xs, ys = sensor_path(meas, frame, s)
        ax.plot(xs, ys, color="tab:blue", lw=1.5, zorder=3)
        ax.plot(xs[:1], ys[:1], "^", color="tab:blue", ms=6, zorder=3)
        ax.annotate(f"{s} {clock_label(meas, float(t[0]))}", (xs[0], ys[0]),
                    textcoords="offset points", xytext=(-6, -12), fontsize=8,
                    color="tab:blue")
    ax.plot([], [], color="tab:blue", lw=1.5, label="sensor track (▲ start)")
    if legs is not None and len(meas.sensors) == 1:
        _draw_legs(ax, meas, frame, legs)
    finite = _position_determined(result, meas)
    truth = truth_track(meas, 100)
    if truth is not None:
        xs, ys = frame.xy(truth[:, 0], truth[:, 1])
        ax.plot(xs, ys, "--", color="0.35", lw=1.2, label="truth (file metadata)", zorder=2)
    largest = _draw_solution(ax, result, meas, frame, n_labels, level) if finite else 0.0
    if finite:
        largest = max(largest, _draw_other_solutions(ax, result, meas, frame, level))
    ax.autoscale()
    _fill_panel(ax, frame)
    ax.set_aspect(frame.aspect(), adjustable="box")
    # bearing lines long enough to cross the solution, not to set the scale; without a
    # solution they fan out as far (at least 10 km) and the words say why there is none
    reach = 1.3 * frame.side_m(np.array(ax.get_xlim()), np.array(ax.get_ylim()))
    if finite:
        ax.set_autoscale_on(False)
        _ellipse_legend(ax, frame, level, largest)
        _draw_bearings(ax, meas, frame, reach)
        words = _undetermined_words(result, meas)
        if words is not None:
            _draw_bearing_interval(ax, result, meas, frame, reach, level)
            _words_box(ax, words)
    else:
        _draw_bearings(ax, meas, frame, max(reach, 10_000.0))
        _words_box(ax, _no_track_words(result))
    ax.set_xlabel(frame.labels[0])
    ax.set_ylabel(frame.labels[1])
    ax.grid(True, alpha=0.3)
    plain_ticks(ax)
    map_legend(ax)
    frame.scale_bar(ax)


def series_names(meas: MeasurementSet) -> np.ndarray:
    """Each row's series of stacked dots: its sensor, and its tonal on frequency rows."""
    if meas.tonal is None:
        return meas.sensor
    tonal = np.char.add(" " if len(meas.sensors) > 1 else "", meas.tonal)
    return np.where(meas.tonal != "", np.char.add(
        meas.sensor if len(meas.sensors) > 1 else "", tonal), meas.sensor)


def _draw_residuals(axes: list[Any], meas: MeasurementSet, residuals: np.ndarray) -> None:
    """One panel per kind: residuals (σ) against time, a series per sensor and tonal."""
    when, label = plot_times(meas, meas.time)
    series = series_names(meas)
    for ax, kind in zip(axes, meas.kinds, strict=True):
        rows = meas.kind_mask(kind)
        z = residuals[rows]
        names = list(dict.fromkeys(series[rows]))
        for s in names:
            sel = series[rows] == s
            ax.plot(when[rows][sel], z[sel], ".", ms=4, label=s)
        ax.axhspan(-1, 1, color="tab:green", alpha=0.12)
        for y in (-3, 3):
            ax.axhline(y, color="tab:red", lw=0.8, ls=":")
        ax.axhline(0, color="0.3", lw=0.6)
        rms = float(np.sqrt(np.nanmean(z ** 2))) if z.size else float("nan")
        out3 = int(np.sum(np.abs(z) > 3))
        ax.set_title(f"{kind} residuals: RMS {rms:.2f} σ, {out3} beyond 3σ", fontsize=9)
        ax.set_ylabel("residual (σ)")
        lim = max(4.0, float(np.nanmax(np.abs(z))) * 1.1) if np.any(np.isfinite(z)) else 4.0
        ax.set_ylim(-lim, lim)
        ax.grid(True, alpha=0.3)
        if len(names) > 1:
            ax.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel(label)
    format_time_axis(axes[-1], when)


def _draw_legs(ax: Any, meas: MeasurementSet, frame: MapFrame, legs: dict[str, Any]) -> None:
    """Mark the own ship's turns on its track and number its legs (L1, L2, ...)."""
    sensor = meas.sensors[0]
    for k, turn in enumerate(legs["turns"]):
        t = np.linspace(max(turn["start"], meas.time.min()), min(turn["stop"], meas.time.max()),
                        12)
        if t[-1] >= t[0]:
            pos = np.array([sensor_position(meas, sensor, float(tt)) for tt in t])
            xs, ys = frame.xy(pos[:, 0], pos[:, 1])
            ax.plot(xs, ys, color="0.25", lw=3.5, zorder=4, solid_capstyle="butt",
                    label="own-ship turns (legs L1, L2, ...)" if k == 0 else None)
    for k, leg in enumerate(legs["legs"]):
        mid = 0.5 * (leg["start"] + leg["stop"])
        if meas.time.min() <= mid <= meas.time.max():
            x, y = frame.xy(*sensor_position(meas, sensor, mid)[:2])
            ax.annotate(f"L{k + 1}", (float(x), float(y)), textcoords="offset points",
                        xytext=(4, 4), fontsize=8, color="0.25", zorder=5)


def _mark_turn_times(axes: list[Any], meas: MeasurementSet, legs: dict[str, Any]) -> None:
    """Shade the own ship's turns on the residuals' time axes."""
    for turn in legs["turns"]:
        when, _ = plot_times(meas, np.array([turn["start"], turn["stop"]], dtype=float))
        for ax in axes:
            ax.axvspan(when[0], when[1], color="0.5", alpha=0.18, lw=0)


def plot_solution(meas: MeasurementSet, result: EstimateResult, path: str | Path, *,
                  residuals: np.ndarray, answer: Any = None, title: str | None = None,
                  labels: int = 5, level: float = 0.95, units: str = "si") -> Path:
    """Write the solution picture: geometry with bearing lines and ellipses, and residuals.

    Parameters
    ----------
    meas, result : MeasurementSet and EstimateResult
        The measurements fitted and the estimate.
    path : str or Path
        The picture (PNG, PDF, SVG).
    residuals : ndarray, shape (n,)
        Each row's residual in units of its sigma (:func:`tmakit.results.normalised_residuals`).
    answer : tmakit.results.answers.Answer, optional
        The answers shown under the title (course, speed, position ellipse).
    title : str, optional
    labels : int
        Times labelled along the estimated track (each with its ellipse).
    level : float
        Probability inside the ellipses (default 0.95).
    units : str
        ``si`` (speed m/s, range km) or ``nautical`` (speed kn, range nmi) in the title.

    Returns
    -------
    Path
    """
    plt = pyplot()
    kinds = meas.kinds
    fig = plt.figure(figsize=(13, 7.5), layout="constrained")
    grid = fig.add_gridspec(max(len(kinds), 1), 2, width_ratios=(1.35, 1))
    ax_map = fig.add_subplot(grid[:, 0])
    res_axes = [fig.add_subplot(grid[i, 1]) for i in range(len(kinds))]
    for ax in res_axes[1:]:
        ax.sharex(res_axes[0])
    legs = result.extra.get("legs")
    legs = legs if isinstance(legs, dict) and legs.get("turns") else None
    _draw_map(ax_map, result, meas, labels, level, legs)
    _draw_residuals(res_axes, meas, np.asarray(residuals, dtype=float))
    if legs is not None:
        _mark_turn_times(res_axes, meas, legs)
    lines = [title or f"{result.method} estimate"]
    if answer is not None:
        lines.append(_answer_line(answer, result, units))
    fig.suptitle("\n".join(lines), fontsize=11)
    return save(fig, path, None)


def _answer_line(a: Any, result: EstimateResult, units: str = "si") -> str:
    """One line of answers for the title: course, speed, range, ellipse, chi2/dof."""
    nautical = units == "nautical"
    speed_unit, speed_scale = ("kn", KNOT) if nautical else ("m/s", 1.0)
    range_unit, range_scale = ("nmi", NAUTICAL_MILE) if nautical else ("km", 1000.0)
    parts = [f"at {a.clock or f't = {a.time:g} s'}"]
    if a.geodetic is not None and None not in a.geodetic[:2]:
        parts.append(f"lat {a.geodetic[0]:.5f}°, lon {a.geodetic[1]:.5f}°")
    if a.course_deg is not None and a.speed is not None:
        parts.append(f"course {a.course_deg:.1f}° ± {a.course_std_deg:.1f}°, speed "
                     f"{a.speed / speed_scale:.2f} ± {a.speed_std / speed_scale:.2f} "
                     f"{speed_unit}")
    if a.range_m is not None:
        parts.append(f"range {a.range_m / range_scale:.3g} ± {a.range_std / range_scale:.2g} "
                     f"{range_unit}, bearing {a.bearing_deg:.1f}° ± {a.bearing_std_deg:.2g}° "
                     f"from {a.sensor}")
    if a.ellipse is not None:
        parts.append(f"{a.ellipse.level:.0%} ellipse semi-axes {a.ellipse.semi_major:.3g} x "
                     f"{a.ellipse.semi_minor:.3g} m, major axis {a.ellipse.orientation_deg:.0f}° "
                     "true")
    if result.dof > 0:
        parts.append(f"χ²/dof {result.chi2 / result.dof:.2f}")
    if len(result.solutions) > 1:
        parts.append(f"{len(result.solutions)} separated solutions fit about as well: all drawn")
    half = (len(parts) + 1) // 2
    return (parts[0] + ": " + ", ".join(parts[1:half]) + "\n" + ", ".join(parts[half:]))
