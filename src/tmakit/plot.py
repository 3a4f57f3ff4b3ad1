"""Pictures: sensor tracks and measurement time series.

Degrees, km and dBm on the axes (the edges of tmakit); the figures are written with
matplotlib's non-interactive Agg backend.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .data import MeasurementSet
from .measurements import KINDS


def truth_track(meas: MeasurementSet, n: int = 200) -> np.ndarray | None:
    """The true target positions over the set's time span, if its metadata carries the truth
    (as simulated sets do); ``None`` otherwise."""
    meta = meas.metadata
    if "motion" not in meta or "truth" not in meta:
        return None
    from .motion import motion_from_name

    try:
        motion = motion_from_name(meta["motion"], float(meta.get("ref_time", 0.0)))
        theta = motion.theta(json.loads(meta["truth"]))
    except (ValueError, json.JSONDecodeError):
        return None
    t = np.linspace(meas.time.min(), meas.time.max(), n)
    return motion.states(theta, t)


def plot_measurements(meas: MeasurementSet, path: str | Path, title: str | None = None
                      ) -> Path:
    """Write a picture of the sensor tracks (and the true target track when known) beside
    one time-series panel per measurement kind.  Returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = meas.kinds
    fig = plt.figure(figsize=(12, max(4.5, 2.2 * len(kinds))), layout="constrained")
    grid = fig.add_gridspec(len(kinds), 2, width_ratios=[1.1, 1.4])
    ax_map = fig.add_subplot(grid[:, 0])
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    sensor_colour = {s: colours[i % len(colours)] for i, s in enumerate(meas.sensors)}

    for s in meas.sensors:
        sel = meas.sensor == s
        order = np.argsort(meas.time[sel], kind="stable")
        xy = meas.sensor_state[sel][order, :2] / 1e3
        ax_map.plot(xy[:, 0], xy[:, 1], "-", color=sensor_colour[s], label=f"sensor {s}")
        ax_map.plot(xy[0, 0], xy[0, 1], "s", color=sensor_colour[s], ms=7)
    target = truth_track(meas)
    if target is not None:
        ax_map.plot(target[:, 0] / 1e3, target[:, 1] / 1e3, "k--", label="target (truth)")
        ax_map.plot(target[0, 0] / 1e3, target[0, 1] / 1e3, "ks", ms=7)
    ax_map.set_xlabel("East (km)")
    ax_map.set_ylabel("North (km)")
    ax_map.set_aspect("equal", adjustable="datalim")
    ax_map.grid(True, alpha=0.3)
    ax_map.legend(loc="best", fontsize=8)
    ax_map.set_title("tracks (squares mark the start)", fontsize=10)

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
                ax.plot(meas.time[sel], meas.value[sel] - offset, ".", ms=3,
                        color=sensor_colour[s], label=s)
        sig = float(np.median(meas.sigma[sel_k]))
        label = k.replace("_", " ")
        if offset:
            ax.set_ylabel(f"{label} - {offset / 1e6:.3f} MHz ({unit})", fontsize=8)
        else:
            ax.set_ylabel(f"{label} ({unit})", fontsize=8)
        ax.set_title(f"{label}: {int(sel_k.sum())} samples, median sigma {sig:.3g} {unit}",
                     fontsize=9)
        ax.grid(True, alpha=0.3)
        if i == len(kinds) - 1:
            ax.set_xlabel("time (s)")
    if title:
        fig.suptitle(title)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
