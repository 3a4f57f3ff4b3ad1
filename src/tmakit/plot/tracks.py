"""Pictures: sensor tracks, measurement time series, tracks and planned paths.

Degrees, km and dBm on the axes (the edges of tmakit); PNG, PDF or SVG by the path's suffix.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..data import MeasurementSet
from ..measurements import KINDS
from .frame import (
    MapFrame,
    clock_label,
    ellipse_points,
    evenly,
    format_time_axis,
    map_legend,
    plot_times,
    pyplot,
    save,
    sensor_path,
    truth_track,
)

if TYPE_CHECKING:  # annotations only: plot is imported without the filters and bounds
    from ..bounds import PosteriorBound
    from ..filters import Track
    from ..montecarlo.planned import PlanRun


def plot_measurements(meas: MeasurementSet, path: str | Path, title: str | None = None
                      ) -> Path:
    """Write a picture of the sensor tracks (and the truth) beside a panel per measurement kind.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements (values drawn in file units: degrees, dBm, Hz, ...).
    path : str or Path
    title : str, optional

    Returns
    -------
    Path
    """
    plt = pyplot()
    kinds = meas.kinds
    fig = plt.figure(figsize=(12, max(4.5, 2.2 * len(kinds))), layout="constrained")
    grid = fig.add_gridspec(len(kinds), 2, width_ratios=[1.1, 1.4])
    ax_map = fig.add_subplot(grid[:, 0])
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    sensor_colour = {s: colours[i % len(colours)] for i, s in enumerate(meas.sensors)}

    frame = MapFrame(meas)
    _draw_sensors(ax_map, meas, frame, [sensor_colour[s] for s in meas.sensors], 1.5, 7)
    target = truth_track(meas)
    if target is not None:
        xs, ys = frame.xy(target[:, 0], target[:, 1])
        ax_map.plot(xs, ys, "k--", label="target (truth)")
        ax_map.plot(xs[0], ys[0], "ks", ms=7)
    frame.decorate(ax_map)
    map_legend(ax_map)
    ax_map.set_title("tracks (squares mark the start)", fontsize=10)
    when, time_label = plot_times(meas, meas.time)

    for i, k in enumerate(kinds):
        ax = fig.add_subplot(grid[i, 1])
        unit = KINDS[k].file_unit
        sel_k = meas.kind == k
        # Frequencies are shown as offsets from the median rounded to the kHz (exactly labelled).
        offset = (round(float(np.median(meas.value[sel_k])) / 1e3) * 1e3
                  if k == "frequency" else 0.0)
        for s in meas.sensors:
            sel = sel_k & (meas.sensor == s)
            if np.any(sel):
                ax.plot(when[sel], meas.value[sel] - offset, ".", ms=3,
                        color=sensor_colour[s], label=s)
        sig = float(np.median(meas.sigma[sel_k]))
        label = k.replace("_", " ")
        if offset:
            ax.set_ylabel(f"{label} - {offset / 1e6:.3f} MHz ({unit})", fontsize=8)
        else:
            ax.set_ylabel(f"{label} ({unit})", fontsize=8)
        sig_unit = "dB" if unit.startswith("dB") else unit  # a power's sigma is a ratio
        ax.set_title(f"{label}: {int(sel_k.sum())} samples, median sigma {sig:.3g} {sig_unit}",
                     fontsize=9)
        ax.grid(True, alpha=0.3)
        if i == len(kinds) - 1:
            ax.set_xlabel(time_label)
            format_time_axis(ax, when)
    return save(fig, path, title)


def _draw_sensors(ax: Any, meas: MeasurementSet, frame: MapFrame, colours: list[str],
                  lw: float, ms: float) -> None:
    """Draw each sensor's path, a square at its start."""
    for s, c in zip(meas.sensors, colours, strict=True):
        _, _, xs, ys = sensor_path(meas, frame, s)
        ax.plot(xs, ys, "-", color=c, lw=lw, label=f"sensor {s}")
        ax.plot(xs[0], ys[0], "s", color=c, ms=ms)


def plot_track(tr: Track, meas: MeasurementSet, path: str | Path, *,
               truth: np.ndarray | None = None, pcrb: PosteriorBound | None = None,
               pcrb_note: str = "", ellipses: int = 8,
               probabilities: tuple[float, ...] = (0.90, 0.95), title: str | None = None
               ) -> Path:
    """Write a picture of a :class:`~tmakit.filters.Track`.

    Parameters
    ----------
    tr, meas : Track and MeasurementSet
        The track (SI) and its measurements (the sensor paths, the truth in the metadata).
    path : str or Path
    truth : ndarray, shape (K, n), optional
        True states at the track's times (m, m/s); with it, the error panels are drawn.
    pcrb : PosteriorBound, optional
        The posterior CRB (:func:`tmakit.tracking.track_pcrb`) drawn beside the errors.
    pcrb_note : str
        What the legend says when ``pcrb`` is ``None``.
    ellipses : int
        Number of times spread over the track with position ellipses.
    probabilities : tuple of float
        The ellipses' probabilities (90 % and 95 %).
    title : str, optional

    Returns
    -------
    Path
    """
    plt = pyplot()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    modes = tr.extra.model_probabilities
    rows = 1 if modes is None else 2
    ratios = [1.0] if modes is None else [3.0, 1.0]
    if truth is not None:
        fig = plt.figure(figsize=(14, 7 + 2 * (rows - 1)), layout="constrained")
        grid = fig.add_gridspec(rows, 2, width_ratios=[1.1, 1.3], height_ratios=ratios)
        sub = grid[0, 1].subgridspec(2, 1)
        ax_map = fig.add_subplot(grid[0, 0])
        ax_axes = fig.add_subplot(sub[0])
        ax_norm = fig.add_subplot(sub[1], sharex=ax_axes)
    else:
        fig = plt.figure(figsize=(8, 7 + 2 * (rows - 1)), layout="constrained")
        grid = fig.add_gridspec(rows, 1, height_ratios=ratios)
        ax_map = fig.add_subplot(grid[0, 0])
    _track_map(ax_map, tr, meas, truth, ellipses, probabilities, colours)
    if modes is not None:
        _model_probabilities(fig.add_subplot(grid[1, :]), tr, meas, colours)
    if truth is not None:
        def axis(t: np.ndarray) -> np.ndarray:
            return plot_times(meas, t)[0]

        _axis_errors(ax_axes, tr, truth, pcrb, colours, axis)
        _norm_errors(ax_norm, tr, truth, pcrb, pcrb_note, colours, axis)
        ax_norm.set_xlabel(plot_times(meas, tr.times)[1])
        format_time_axis(ax_norm, axis(tr.times))
    return save(fig, path, title)


def _track_map(ax_map: Any, tr: Track, meas: MeasurementSet, truth: np.ndarray | None,
               ellipses: int, probabilities: tuple[float, ...], colours: list[str]) -> None:
    """Draw the map: sensor paths, the true path, the track and its position ellipses."""
    frame = MapFrame(meas)
    _draw_sensors(ax_map, meas, frame,
                  [colours[(i + 2) % len(colours)] for i in range(len(meas.sensors))], 1.2, 6)
    if truth is not None:
        path_true = truth_track(meas)
        path_true = truth if path_true is None else path_true
        ax_map.plot(*frame.xy(path_true[:, 0], path_true[:, 1]), "k--", lw=1.2,
                    label="target (truth)")
    xs, ys = frame.xy(tr.states[:, 0], tr.states[:, 1])
    ax_map.plot(xs, ys, "-", color=colours[0], lw=1.5, label=f"track ({tr.filter_name})")
    ax_map.plot(xs[0], ys[0], "o", color=colours[0], ms=6, label="track start")
    sm = tr.extra.smoothed
    if sm is not None:
        ax_map.plot(*frame.xy(sm.states[:, 0], sm.states[:, 1]), "-", color=colours[3],
                    lw=1.5, label=f"smoothed ({sm.extra.options.get('smoother', 'rts')})")
    k_sel = evenly(len(tr), ellipses)
    styles = ("-", "--", ":", "-.")
    for j, p in enumerate(probabilities):
        for n_k, k in enumerate(k_sel):
            pts = tr.states[k, :2] + ellipse_points(tr.covariances[k, :2, :2], p)
            ax_map.plot(*frame.xy(pts[:, 0], pts[:, 1]), styles[j % len(styles)],
                        color=colours[1], lw=0.9, label=f"{p:.0%} ellipse" if n_k == 0 else None)
    frame.decorate(ax_map)
    map_legend(ax_map)
    times = ", ".join(clock_label(meas, float(tr.times[k])) for k in k_sel[:: max(
        1, len(k_sel) // 4)])
    ax_map.set_title(f"track and position ellipses at {len(k_sel)} times ({times}, ...)"
                     if len(k_sel) else "track", fontsize=10)


def _model_probabilities(ax: Any, tr: Track, meas: MeasurementSet, colours: list[str]
                         ) -> None:
    """Draw a multiple-model filter's model probabilities against time."""
    mu = np.asarray(tr.extra.model_probabilities, dtype=float)
    t, label = plot_times(meas, tr.times)
    for j, model in enumerate(tr.extra.models or [{}] * mu.shape[1]):
        q = model.get("q", [float("nan")])
        turn = model.get("turn_rate", 0.0)
        what = (", turn at an estimated rate" if turn is None
                else f", turn {np.degrees(turn):+.3g} deg/s" if turn else "")
        ax.plot(t, mu[:, j], "-", color=colours[j % len(colours)], lw=1.2,
                label=f"model {j + 1} (q = {max(q):g} m/s^2{what})")
    smoothed = getattr(tr.extra.smoothed, "extra", None)
    if smoothed is not None and smoothed.model_probabilities is not None:
        mu_s = np.asarray(smoothed.model_probabilities, dtype=float)
        for j in range(mu_s.shape[1]):
            ax.plot(t, mu_s[:, j], "--", color=colours[j % len(colours)], lw=0.9,
                    label="smoothed (dashed)" if j == 0 else None)
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel("probability")
    ax.set_xlabel(label)
    ax.set_title(f"{(tr.filter_name or 'imm').upper()} model probabilities", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    format_time_axis(ax, t)


def _axis_errors(ax_axes: Any, tr: Track, truth: np.ndarray, pcrb: PosteriorBound | None,
                 colours: list[str], axis: Any) -> None:
    """Estimate minus truth per axis, within the filter's ±1 std and the PCRB's."""
    dim = len(tr.state_names) // 2
    t = axis(tr.times)
    err = tr.states[:, :dim] - truth[:, :dim]
    std = tr.std[:, :dim]
    for a, name in enumerate(tr.state_names[:dim]):
        c = colours[a % len(colours)]
        ax_axes.plot(t, err[:, a], "-", color=c, lw=1.0, label=f"error {name}")
        ax_axes.fill_between(t, -std[:, a], std[:, a], color=c, alpha=0.15,
                             label=f"±1 filter std {name}")
        if pcrb is not None:
            ax_axes.plot(axis(pcrb.times), pcrb.std[:, a], ":", color=c, lw=1.0,
                         label=f"±PCRB std {name}")
            ax_axes.plot(axis(pcrb.times), -pcrb.std[:, a], ":", color=c, lw=1.0)
    ax_axes.set_ylabel("position error (m)")
    ax_axes.set_title("estimate minus truth per axis", fontsize=10)
    ax_axes.grid(True, alpha=0.3)
    ax_axes.legend(loc="upper right", fontsize=7, ncol=2)
    if len(t):  # the start's wide std would flatten the rest; outliers may leave the panel
        lim = max(4.0 * float(np.nanmedian(np.linalg.norm(std, axis=1))),
                  1.2 * float(np.nanpercentile(np.abs(err), 95)))
        if np.isfinite(lim) and lim > 0:
            ax_axes.set_ylim(-lim, lim)


def _norm_errors(ax_norm: Any, tr: Track, truth: np.ndarray, pcrb: PosteriorBound | None,
                 pcrb_note: str, colours: list[str], axis: Any) -> None:
    """|position error| against the filter's sqrt(tr P) and the PCRB position RMS."""
    dim = len(tr.state_names) // 2
    t = axis(tr.times)
    err = tr.states[:, :dim] - truth[:, :dim]
    norm = np.linalg.norm(err, axis=1)
    sd = np.sqrt(np.einsum("kii->k", tr.covariances[:, :dim, :dim]))
    ax_norm.semilogy(t, np.maximum(norm, 1e-3), "-", color=colours[0], lw=1.0,
                     label="|position error|")
    ax_norm.semilogy(t, sd, "-", color=colours[1], lw=1.2,
                     label="filter position RMS std sqrt(tr P)")
    sm = tr.extra.smoothed
    if sm is not None:
        ax_norm.semilogy(t, np.maximum(np.linalg.norm(sm.states[:, :dim] - truth[:, :dim],
                                                      axis=1), 1e-3), "-", color=colours[3],
                         lw=1.0, label="|smoothed position error|")
        ax_norm.semilogy(t, np.sqrt(np.einsum("kii->k", sm.covariances[:, :dim, :dim])), ":",
                         color=colours[3], lw=1.2, label="smoothed position RMS std")
    if pcrb is not None:
        how = ("along the true path" if pcrb.mode == "deterministic"
               else f"{pcrb.trajectories} trajectories")
        ax_norm.semilogy(axis(pcrb.times), pcrb.position_rms, "k--", lw=1.2,
                         label=f"PCRB position RMS ({how})")
    else:
        ax_norm.plot([], [], " ", label=pcrb_note or "PCRB not available")
    ax_norm.set_ylabel("m")
    ax_norm.set_title("position error against the filter's std and the posterior CRB",
                      fontsize=10)
    ax_norm.grid(True, which="both", alpha=0.3)
    ax_norm.legend(loc="upper right", fontsize=8)


def plot_plan(run: PlanRun, path: str | Path, *, paths: int = 3, title: str | None = None
              ) -> Path:
    """Write a picture of planned closed-loop runs (:func:`tmakit.plan`).

    Parameters
    ----------
    run : tmakit.montecarlo.planned.PlanRun
    path : str or Path
    paths : int, optional
        How many runs' paths are drawn on the map.
    title : str, optional
        Default: the scenario's name and the number of runs.

    Returns
    -------
    Path
    """
    plt = pyplot()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig = plt.figure(figsize=(14, 7), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=[1.1, 1.3])
    ax_map, ax_range = fig.add_subplot(grid[:, 0]), fig.add_subplot(grid[0, 1])
    ax_err = fig.add_subplot(grid[1, 1], sharex=ax_range)
    start, study = run.setup.start, run.study
    cases = study.cases
    planned = study.records[cases[0]]
    for i, rec in enumerate(planned[:max(paths, 1)]):
        first = i == 0
        for case, style in zip(cases, ("-", ":"), strict=False):
            flown = study.records[case][i].sensor[:, :2]
            sensor = np.vstack([start.position[None, :2], flown]) / 1e3
            ax_map.plot(sensor[:, 0], sensor[:, 1], color=colours[0], lw=1.2, ls=style,
                        label=f"sensor ({case})" if first else None)
        ax_map.plot(rec.truth[:, 0] / 1e3, rec.truth[:, 1] / 1e3, color=colours[1],
                    label="target (truth)" if first else None)
        ax_map.plot(rec.estimate[:, 0] / 1e3, rec.estimate[:, 1] / 1e3, color=colours[2],
                    ls="--", lw=1.0, label="target (estimate, planned)" if first else None)
    ax_map.plot(*(start.position[:2] / 1e3), "o", color=colours[0], label="sensor start")
    ax_map.set(xlabel="east (km)", ylabel="north (km)", aspect="equal")
    ax_map.legend(loc="best", fontsize="small")
    t = study.times(cases[0])
    for rec in planned:
        ax_range.plot(t, rec.range_m / 1e3, color=colours[0], lw=0.8, alpha=0.6)
    ax_range.set(ylabel="range to target (km), planned path")
    for case, colour in zip(cases, (colours[3], colours[4]), strict=False):
        ax_err.semilogy(t, study.rmse(case), color=colour, label=f"position RMSE ({case})")
        ax_err.semilogy(t, study.pcrb(case), color=colour, ls="--",
                        label=f"posterior CRB at the truth ({case})")
    ax_err.set(xlabel="time (s)", ylabel="position error (m)")
    ax_err.legend(loc="best", fontsize="small")
    default = f"{run.setup.scenario.name}: planned path, {len(planned)} run(s)"
    return save(fig, path, title or default)
