"""What every tmakit picture shares: the map's coordinates, the time axis and the elements.

A map is in latitude/longitude (degrees, true scale: the aspect is 1 / cos(latitude)) when the
measurement set knows its ENU origin, else in East/North (km); it carries a scale bar.  The
sensor paths, bearing lines, estimated tracks and ellipses are computed here once for the
matplotlib pictures and the Bokeh page.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..core.geodesy import enu_to_geodetic
from ..data import MeasurementSet
from ..results.context import TIME_ORIGIN_KEY, clock_time, origin_of
from ..results.solutions import EstimateResult
from ..scenario.truth import truth_states

__all__ = ["MapFrame", "answer_ellipse", "bearing_lines", "clock_label", "ellipse_points",
           "evenly", "format_time_axis", "map_legend", "plain_ticks", "plot_times", "pyplot",
           "save", "sensor_path", "track_xy", "truth_track"]


class MapFrame:
    """Map coordinates: lon/lat (deg) when the origin is known, else East/North (km).

    Parameters
    ----------
    meas : MeasurementSet
        The measurements; their ``origin_lat``/``origin_lon``/``origin_alt`` metadata.
    """

    def __init__(self, meas: MeasurementSet) -> None:
        self.origin = origin_of(meas)
        self.geodetic = self.origin is not None
        self.labels = (("longitude (deg)", "latitude (deg)") if self.geodetic
                       else ("East (km)", "North (km)"))

    def xy(self, east: Any, north: Any) -> tuple[np.ndarray, np.ndarray]:
        """Return map coordinates of ENU positions (m)."""
        east, north = np.asarray(east, dtype=float), np.asarray(north, dtype=float)
        if self.origin is None:
            return east / 1000.0, north / 1000.0
        lat, lon, _ = enu_to_geodetic(east, north, np.zeros_like(east), self.origin)
        return np.asarray(lon), np.asarray(lat)

    def _metres_per_degree(self) -> tuple[float, float]:
        """Metres per degree of longitude and of latitude at the origin (WGS-84, 1 km steps)."""
        lon, lat = self.xy(np.array([0.0, 1000.0, 0.0]), np.array([0.0, 0.0, 1000.0]))
        return 1000.0 / float(lon[1] - lon[0]), 1000.0 / float(lat[2] - lat[0])

    def metres_per_x(self) -> float:
        """Give the metres per unit of the horizontal map coordinate (at the origin)."""
        return self._metres_per_degree()[0] if self.geodetic else 1000.0

    def aspect(self) -> float:
        """Give the axis aspect ratio that keeps distances true."""
        if not self.geodetic:
            return 1.0
        per_lon, per_lat = self._metres_per_degree()
        return per_lat / per_lon

    def side_m(self, x: np.ndarray, y: np.ndarray) -> float:
        """Give the longer side (m) of the box about map coordinates ``x``, ``y``."""
        return max(float(np.ptp(x)), float(np.ptp(y)) * self.aspect()) * self.metres_per_x()

    def decorate(self, ax: Any) -> None:
        """Label the axes, keep distances true, draw a grid and a scale bar (lower right)."""
        ax.set_xlabel(self.labels[0])
        ax.set_ylabel(self.labels[1])
        ax.set_aspect(self.aspect(), adjustable="datalim")
        ax.grid(True, alpha=0.3)
        plain_ticks(ax)
        ax.apply_aspect()  # the limits the picture will have, for the scale bar's length
        self.scale_bar(ax)

    def scale_bar(self, ax: Any) -> None:
        """Draw a scale bar of a round length, about a fifth of the map's width."""
        from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

        x0, x1 = ax.get_xlim()
        width_m = abs(x1 - x0) * self.metres_per_x()
        target = width_m / 5.0
        step = 10.0 ** np.floor(np.log10(target))
        length = max((m * step for m in (1, 2, 5) if m * step <= target), default=step)
        text = f"{length / 1000:g} km" if length >= 1000 else f"{length:g} m"
        ax.add_artist(AnchoredSizeBar(ax.transData, length / self.metres_per_x(), text,
                                      "lower right", pad=0.5, frameon=True, size_vertical=0,
                                      sep=4, label_top=True))


def plot_times(meas: MeasurementSet, t: Any) -> tuple[np.ndarray, str]:
    """Return times for a plot's axis and the axis label: UTC clock time when known."""
    t = np.asarray(t, dtype=float)
    start = clock_time(meas, 0.0)
    if start is None or TIME_ORIGIN_KEY not in meas.metadata:
        return t, "time (s)"
    t0 = np.datetime64(start.rstrip("Z"), "ms")
    values = t0 + np.round(t * 1000.0).astype("int64").astype("timedelta64[ms]")
    first = clock_time(meas, float(np.nanmin(t))) if t.size else start
    return values, f"time (UTC, {(first or start)[:10]})"


def format_time_axis(ax: Any, values: np.ndarray) -> None:
    """Show clock times as ``HH:MM`` (``HH:MM:SS`` over spans under 10 min); seconds unchanged."""
    if not np.issubdtype(np.asarray(values).dtype, np.datetime64) or not np.size(values):
        return
    import matplotlib.dates as mdates

    span = (np.max(values) - np.min(values)) / np.timedelta64(1, "s")
    ax.xaxis.set_major_formatter(mdates.DateFormatter("%H:%M:%S" if span < 600 else "%H:%M"))


def map_legend(ax: Any, columns: int = 3) -> None:
    """Put a map's legend under the figure, outside the map: it hides no data, no scale bar."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.figure.legend(handles, labels, loc="outside lower left", ncol=columns, fontsize=8,
                         frameon=False)


def plain_ticks(ax: Any) -> None:
    """Write a map's tick labels in full (47.955, not an offset +4.795e1), at most 6 per axis."""
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    for axis in (ax.xaxis, ax.yaxis):
        formatter = ScalarFormatter(useOffset=False)
        formatter.set_scientific(False)
        axis.set_major_formatter(formatter)
        axis.set_major_locator(MaxNLocator(nbins=6, steps=[1, 2, 2.5, 5, 10]))


def pyplot() -> Any:
    """Give ``matplotlib.pyplot`` on the non-interactive Agg backend."""
    if "matplotlib" not in sys.modules:  # Agg is chosen below: an MPLBACKEND that matplotlib
        os.environ.pop("MPLBACKEND", None)  # does not know would fail its import
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, path: str | Path, title: str | None, **options: Any) -> Path:
    """Title (if any), write and close a figure; return the path written."""
    if title:
        fig.suptitle(title)
    path = Path(path)
    fig.savefig(path, **({"dpi": 110} | options))
    pyplot().close(fig)
    return path


def clock_label(meas: MeasurementSet, t: float) -> str:
    """Give ``HH:MM:SS`` (UTC) when the set records its time origin, else ``t s``."""
    clock = clock_time(meas, t)
    return clock[11:19] if clock else f"{t:.0f} s"


def evenly(count: int, most: int) -> np.ndarray:
    """Give at most ``most`` indices evenly spread over ``range(count)``, ends included."""
    if count <= 0 or most <= 0:
        return np.zeros(0, dtype=int)
    return np.unique(np.linspace(0, count - 1, min(count, most)).round().astype(int))


def ellipse_points(cov2: np.ndarray, level: float, n: int = 90) -> np.ndarray:
    """Give the points ``(n, 2)`` about 0 of the ``level`` ellipse of a 2x2 covariance."""
    evals, evecs = np.linalg.eigh(0.5 * (cov2 + cov2.T))
    radius = np.sqrt(-2.0 * np.log1p(-level))  # the chi-squared quantile of 2 dof
    a = np.linspace(0.0, 2.0 * np.pi, n)
    circle = np.stack([np.cos(a), np.sin(a)], axis=1)
    return radius * circle * np.sqrt(np.clip(evals, 0.0, None)) @ evecs.T


def answer_ellipse(frame: MapFrame, a: Any, centre: np.ndarray, level: float
                   ) -> tuple[np.ndarray, np.ndarray] | None:
    """Give an answer's position ellipse about ``centre`` (m) in map coordinates, or None."""
    cov = a.covariance[:2, :2]
    if a.ellipse is None or not np.all(np.isfinite(cov)):
        return None
    pts = ellipse_points(cov, level) + centre
    return frame.xy(pts[:, 0], pts[:, 1])


def truth_track(meas: MeasurementSet, n: int = 200) -> np.ndarray | None:
    """Give the true states ``(n, 6)`` over the set's time span from its metadata (None: none)."""
    if len(meas) == 0:
        return None
    return truth_states(meas, np.linspace(meas.time.min(), meas.time.max(), n), 3)


def sensor_path(meas: MeasurementSet, frame: MapFrame, sensor: str
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Give a sensor's distinct times, its states then and its path in map coordinates."""
    rows = meas.sensor_mask(sensor)
    t, first = np.unique(meas.time[rows], return_index=True)
    states = meas.sensor_state[rows][first]
    x, y = frame.xy(states[:, 0], states[:, 1])
    return t, states, x, y


def track_xy(result: EstimateResult, meas: MeasurementSet, frame: MapFrame,
             times: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Give an estimate's states and map path at ``times`` (200 over the data's span)."""
    t = np.linspace(meas.time.min(), meas.time.max(), 200) if times is None else times
    states = result.motion.states(result.estimate, t)
    x, y = frame.xy(states[:, 0], states[:, 1])
    return states, x, y


def bearing_lines(meas: MeasurementSet, frame: MapFrame, reach: float, most: int,
                  points: int = 12, twins: bool = False
                  ) -> tuple[list[np.ndarray], list[np.ndarray], int]:
    """Give bearing lines ``reach`` m long from the sensors (``most`` rows, evenly spread).

    The x and y of each line in map coordinates, and the number of bearing rows; with
    ``twins``, the lines of the rows' ambiguous twin bearings instead.
    """
    rows = meas.kind_mask("bearing")
    count = int(np.count_nonzero(rows))
    pick = np.flatnonzero(rows)[evenly(count, most)]
    b = meas.value_si[pick] if not twins else (
        np.full(pick.size, np.nan) if meas.ambiguous_si is None else meas.ambiguous_si[pick])
    u = np.linspace(0.0, 1.0, points)
    xs: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    for (e0, n0), angle in zip(meas.sensor_state[pick, :2], b, strict=True):
        if np.isfinite(angle):
            x, y = frame.xy(e0 + reach * u * np.sin(angle), n0 + reach * u * np.cos(angle))
            xs.append(x)
            ys.append(y)
    return xs, ys, count
