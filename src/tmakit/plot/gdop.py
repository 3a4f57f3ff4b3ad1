"""The geolocation picture: CEP50 and CEP90 of a stationary emitter over a grid (``tma gdop``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bounds.layout import LayoutRows, cep, layout_information
from ..core.arrays import Array
from ..core.units import REACH_M
from ..data import MeasurementSet
from ..scenario import Scenario
from .frame import MapFrame

__all__ = ["CepMap", "cep_map", "plot_cep_map"]


@dataclass
class CepMap:
    """CEP50 and CEP90 over a grid of emitter positions."""

    #: east, north: The grid's axes (ENU, m); shape (n,)
    east: Array
    north: Array
    #: cep50, cep90: The radii (m), ``[north, east]``; inf where the position is not observable;
    #: shape (n, n)
    cep50: Array
    cep90: Array
    rows: MeasurementSet  # The layout's rows (sensor states, reference states, sigmas)
    ignored: list[str]  # The kinds of the layout not in the bound (it takes ``tdoa`` and ``fdoa``)


def layout_rows(scenario: Scenario) -> tuple[MeasurementSet, list[str]]:
    """Give a layout's TDOA and FDOA rows (noise-free) and the kinds left out."""
    meas = scenario.simulate(rng=0, noise=False)
    keep = np.isin(meas.kind, ["tdoa", "fdoa"])
    if not keep.any():
        raise ValueError("the layout has no tdoa or fdoa measurements (a measurement entry "
                         "naming sensor pairs against a ref_sensor)")
    ignored = sorted(set(meas.kind[~keep].tolist()))
    rows = meas.take(np.flatnonzero(keep))
    if "fdoa" in rows.kinds and "fdoa_carrier" not in rows.metadata:
        rows.metadata["fdoa_carrier"] = repr(float(scenario.nuisance["carrier"]))
    return rows, ignored


def _default_extent(rows: MeasurementSet) -> tuple[float, float, float]:
    """Give the grid's centre (east, north) and half-width (m): twice the sensors' spread."""
    pos = np.concatenate([rows.sensor_state[:, :2], rows.ref_sensor_state[:, :2]])
    centre = pos.mean(axis=0)
    spread = float(np.max(np.linalg.norm(pos - centre, axis=1)))
    return float(centre[0]), float(centre[1]), max(2.0 * spread, 1000.0)


def cep_map(scenario: Scenario, points: int = 100, half_width: float | None = None,
            height: float = 0.0) -> CepMap:
    """Compute CEP50 and CEP90 over a square grid about the layout."""
    if points < 2:
        raise ValueError(f"points: expected 2 or more per side, found {points}")
    rows, ignored = layout_rows(scenario)
    ce, cn, default = _default_extent(rows)
    half = default if half_width is None else float(half_width)
    if not 0 < half <= REACH_M:  # (farther, the grid leaves the local frame: every CEP inf)
        raise ValueError(f"half_width: expected a distance within (0, {REACH_M:g}] m, found "
                         f"{half_width}")
    if not abs(height) <= REACH_M:
        raise ValueError(f"height: expected a height within +-{REACH_M:g} m, found {height}")
    east = ce + np.linspace(-half, half, points)
    north = cn + np.linspace(-half, half, points)
    ee, nn = np.meshgrid(east, north)
    grid = np.column_stack([ee.ravel(), nn.ravel(), np.full(ee.size, float(height))])
    info = layout_information(LayoutRows(rows), grid, 2)
    with np.errstate(all="ignore"):
        ok = np.linalg.cond(info) < 1e12
        cov = np.linalg.inv(np.where(ok[:, None, None], info, np.eye(2)))
    cov[~ok] = np.inf
    shape = (points, points)
    return CepMap(east, north, cep(cov, 0.5).reshape(shape), cep(cov, 0.9).reshape(shape),
                  rows, ignored)


def plot_cep_map(result: CepMap, path: str | Path, title: str | None = None) -> Path:
    """Draw CEP50 and CEP90 as filled contours (log scale) with the sensors."""
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    frame = MapFrame(result.rows)
    ee, nn = np.meshgrid(result.east, result.north)
    x, y = frame.xy(ee, nn)
    finite = np.concatenate([result.cep50[np.isfinite(result.cep50)],
                             result.cep90[np.isfinite(result.cep90)]])
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (1.0, 10.0)
    levels = np.logspace(np.log10(low), np.log10(max(high, low * 1.01)), 15)
    fig = Figure(figsize=(12, 5.4))
    axes = fig.subplots(1, 2)
    pos = np.unique(np.concatenate([result.rows.sensor_state[:, :2],
                                    result.rows.ref_sensor_state[:, :2]]), axis=0)
    sx, sy = frame.xy(pos[:, 0], pos[:, 1])
    for ax, radius, name in zip(axes, (result.cep50, result.cep90), ("CEP50", "CEP90"),
                                strict=True):
        shown = np.where(np.isfinite(radius), radius, high)
        filled = ax.contourf(x, y, shown, levels=levels, norm=LogNorm(), cmap="viridis")
        lines = ax.contour(x, y, shown, levels=levels[::3], colors="white", linewidths=0.6)
        ax.clabel(lines, fmt=lambda v: f"{v:.3g} m", fontsize=7)
        ax.plot(sx, sy, "r^", label="sensors")
        ax.set_title(f"{name} (m) of a stationary emitter")
        frame.decorate(ax)
        fig.colorbar(filled, ax=ax, shrink=0.85, label=f"{name} (m)", format="%.3g")
        ax.legend(loc="upper right")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)
