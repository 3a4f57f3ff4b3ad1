"""The interactive solution page: one self-contained HTML file (``tma estimate --html``).

Left, the geography in latitude/longitude (East/North in km without an origin): the sensors' tracks
with their straight legs, the bearing fan, the estimated track with its position ellipses and, at
the reference time, the solution's handles.
"""

from __future__ import annotations

import html
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..data import MeasurementSet
from ..observation import ObservationModel
from ..results import EstimateResult, normalised_residuals
from ..results.answers import estimate_answer
from ..results.context import TIME_ORIGIN_KEY, clock_time, origin_of
from ..results.own_legs import sensor_legs
from .frame import MapFrame, answer_ellipse, bearing_lines, sensor_path, track_xy
from .solution import series_names

__all__ = ["DRAG_KINDS", "MAX_FAN_LINES", "solution_page_html", "write_solution_page"]

#: The kinds whose residuals the page recomputes as the solution is dragged, by their code in
#: the page's model (``page.js``).
DRAG_KINDS = {"bearing": 0, "range": 1, "frequency": 2}
#: While the mouse drags, each panel of stacked dots draws at most about this many (evenly
#: spread; all of them once the drag stops): repainting 10,000 dots takes Bokeh ~150 ms a frame.
DRAG_DOTS = 1000
#: At most this many bearing lines are drawn in the fan (evenly spread over the cuts).
MAX_FAN_LINES = 300
_COLOURS = ("#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")


def _drag_refusal(meas: MeasurementSet, result: EstimateResult, obs: ObservationModel) -> str:
    """Why the solution cannot be dragged in the page ('' when it can)."""
    motion = type(result.motion).__name__
    if result.status != "converged" or not np.all(np.isfinite(result.estimate)):
        return f"the estimate is {result.status}: no solution to drag"
    if motion not in ("ConstantVelocity", "Stationary"):
        return (f"dragging is for constant-velocity and stationary solutions, not "
                f"{result.motion.name}")
    other = [k for k in meas.kinds if k not in DRAG_KINDS]
    if other:
        return ("dragging recomputes bearing, range and frequency rows; this set also has "
                + ", ".join(other))
    freq = obs.models.get("frequency")
    if freq is not None and getattr(freq, "drift", False):
        return "dragging recomputes frequencies without carrier drift"
    if getattr(obs, "has_reference", False):
        return "dragging recomputes rows without an earlier reference sample"
    return ""


def _state6(result: EstimateResult) -> list[float]:
    """Give the solution's ENU state ``[x y z vx vy vz]`` at its reference time."""
    ref = float(getattr(result.motion, "ref_time", 0.0))
    return [float(v) for v in result.motion.states(result.estimate, np.array([ref]))[0]]


def _reach(frame: MapFrame, xs: list[np.ndarray], ys: list[np.ndarray]) -> float:
    """Give a bearing line's length (m): 1.3 times the larger side of the rest."""
    x = np.concatenate([np.ravel(v) for v in xs])
    y = np.concatenate([np.ravel(v) for v in ys])
    x, y = x[np.isfinite(x)], y[np.isfinite(y)]
    return max(1.3 * frame.side_m(x, y), 5_000.0) if x.size else 10_000.0


class _Page:
    """Everything the page draws, in map and clock coordinates (built once, then laid out)."""

    def __init__(self, meas: MeasurementSet, result: EstimateResult,
                 options: dict[str, Any] | None, level: float, labels: int) -> None:
        self.meas, self.result, self.level = meas, result, level
        self.frame = MapFrame(meas)
        self.obs = ObservationModel(meas, result.motion, options)
        self.refusal = _drag_refusal(meas, result, self.obs)
        self.has_track = (result.status in ("converged", "unobservable")
                          and np.all(np.isfinite(result.estimate)))
        self.z = (normalised_residuals(result, meas, options) if self.has_track
                  else np.full(len(meas), np.nan))
        t0 = clock_time(meas, 0.0)
        self.clock = t0 is not None and TIME_ORIGIN_KEY in meas.metadata
        self.t0_ms = (float(np.datetime64(t0.rstrip("Z"), "ms").astype("int64"))
                      if self.clock and t0 else 0.0)
        self.ref_time = float(getattr(result.motion, "ref_time", meas.time.min()))
        self.labels = labels

    def when(self, t: np.ndarray) -> np.ndarray:
        """Plot times: ms since 1970 (Bokeh's datetime axis) or seconds."""
        return self.t0_ms + 1000.0 * np.asarray(t, float) if self.clock else np.asarray(t, float)

    def label(self, t: float) -> str:
        """Give a time in words: UTC clock time or seconds."""
        c = clock_time(self.meas, t)
        return c[11:19] + " UTC" if c else f"t = {t:.0f} s"

    def sensor_tracks(self) -> list[dict[str, Any]]:
        """Each sensor's track on the map, and its leg starts."""
        out = []
        for k, s in enumerate(self.meas.sensors):
            t, st, x, y = sensor_path(self.meas, self.frame, s)
            legs = sensor_legs(self.meas, s) if np.ptp(st[:, 3:5]) > 0 else []
            starts = [int(np.searchsorted(t, leg.start)) for leg in legs]
            out.append({"name": str(s), "x": x, "y": y, "colour": _COLOURS[k % len(_COLOURS)],
                        "leg_x": x[starts], "leg_y": y[starts],
                        "leg_n": [str(i + 1) for i in range(len(starts))]})
        return out

    def track(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Give the estimated track: times (s) and map coordinates over the data's span."""
        t = np.union1d(np.linspace(self.meas.time.min(), self.meas.time.max(), 200),
                       [self.ref_time])
        _, x, y = track_xy(self.result, self.meas, self.frame, t)
        return t, x, y

    def ellipses(self) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
        """Give the position ellipses at labelled times (map coordinates), labelled."""
        xs, ys, words = [], [], []
        times = np.linspace(self.meas.time.min(), self.meas.time.max(), self.labels)
        if type(self.result.motion).__name__ == "Stationary":
            times = times[:1]
        for tk in times:
            a = estimate_answer(self.result, self.meas, time=float(tk), level=self.level)
            s = self.result.motion.states(self.result.estimate, np.array([tk]))[0]
            xy = answer_ellipse(self.frame, a, s[:2], self.level)
            if xy is None:
                continue
            x, y = xy
            xs.append(x)
            ys.append(y)
            words.append(self.label(float(tk)))
        return xs, ys, words

    def rows(self) -> dict[str, np.ndarray]:
        """Give the rows the page's model needs (set order; SI)."""
        m = self.meas
        kind = np.full(len(m), -1, dtype=np.int32)
        for k, code in DRAG_KINDS.items():
            kind[m.kind_mask(k)] = code
        st = m.sensor_state
        return {"t": m.time.astype(float), "kind": kind, "value": m.value_si.astype(float),
                "sigma": m.sigma_si.astype(float), "se": st[:, 0], "sn": st[:, 1],
                "su": st[:, 2], "sve": st[:, 3], "svn": st[:, 4], "svu": st[:, 5],
                "tonal": self.tonals()[1]}

    def tonals(self) -> tuple[list[float], np.ndarray]:
        """Each tonal's reference carrier (mean frequency, Hz) and each row's tonal number."""
        m = self.meas
        fr = m.kind_mask("frequency")
        labels = np.where(fr, "", "-") if m.tonal is None else np.where(fr, m.tonal, "-")
        names, code = np.unique(labels, return_inverse=True)
        keep = names != "-"
        number = np.cumsum(keep) - 1
        refs = [float(np.mean(m.value_si[labels == lab])) for lab in names[keep]]
        return refs or [0.0], np.maximum(number[code.reshape(-1)], 0).astype(np.int32)

    def config(self, tau: float) -> dict[str, Any]:
        """Give the page model's constants."""
        freq = self.obs.models.get("frequency")
        n_par = len(self.result.estimate) + self.obs.n_nuisance
        origin = origin_of(self.meas)
        return {
            "origin": list(origin) if origin is not None else None,
            "ref_time": self.ref_time, "ref_label": self.label(self.ref_time),
            "ml": _state6(self.result) if self.has_track else [0.0] * 6,
            "moving": type(self.result.motion).__name__ == "ConstantVelocity",
            "draggable": not self.refusal, "tau": tau,
            "c": float(getattr(freq, "c", 1.0)), "carrier_ref": self.tonals()[0],
            "ml_chi2": float(self.result.chi2), "n_used": len(self.meas),
            "dof": self.result.dof if self.result.dof > 0 else max(len(self.meas) - n_par, 1),
            "all_kinds": list(self.meas.kinds),
            "kinds": [{"name": k, "code": DRAG_KINDS[k]} for k in self.meas.kinds
                      if k in DRAG_KINDS],
        }

    def handles(self, config: dict[str, Any]) -> dict[str, list[Any]]:
        """Give the handles' data: the position at the reference time, the velocity's end."""
        s, tau = config["ml"], config["tau"]
        east, north = [s[0]], [s[1]]
        if config["moving"]:
            east.append(s[0] + s[3] * tau)
            north.append(s[1] + s[4] * tau)
        x, y = self.frame.xy(np.array(east), np.array(north))
        return {"x": [float(v) for v in x], "y": [float(v) for v in y],
                "m": ["square", "circle"][:len(east)]}

    def tau(self, x: np.ndarray, y: np.ndarray) -> float:
        """Seconds ahead of the velocity handle: its stick a sixth of the map's width."""
        s = _state6(self.result) if self.has_track else [0.0] * 6
        speed = float(np.hypot(s[3], s[4]))
        width = self.frame.side_m(x, y) if x.size else 10_000.0
        span = float(np.ptp(self.meas.time)) or 600.0
        if speed <= 0:
            return span / 4
        return float(np.clip(width / 6 / speed, 60.0, 4 * span))


def _escaped(text: object) -> str:
    return html.escape(str(text), quote=True)


def _header(page: _Page, title: str) -> str:
    """Give the page's heading and the data it shows, escaped (file and sensor names)."""
    m, r = page.meas, page.result
    counts = ", ".join(f"{int(m.kind_mask(k).sum())} {_escaped(k)}" for k in m.kinds)
    sensors = ", ".join(_escaped(s) for s in m.sensors)
    lines = [f"<h3 style='margin:4px 0'>{_escaped(title)}</h3>",
             f"<div>{counts} rows from sensor(s) {sensors}; {_escaped(r.method)} estimate, "
             f"{_escaped(r.motion.name)}, {_escaped(r.status)}; reference time "
             f"{_escaped(page.label(page.ref_time))}</div>"]
    how = ("Drag the square (position at the reference time) or the circle (course and speed)"
           " on the map: the stacked dots and χ² follow; <i>back to ML</i> restores the fit."
           if not page.refusal else f"Not draggable: {_escaped(page.refusal)}.")
    lines.append(f"<div style='color:#444'>{how}</div>")
    # a plain button: Bokeh's widgets would add 380 kB of script to parse at every opening
    lines.append("<button id='tma-reset' type='button' style='margin-top:4px'"
                 + (" disabled" if page.refusal else "") + ">back to ML solution</button>")
    return "\n".join(lines)


def _map_figure(page: _Page) -> tuple[Any, dict[str, Any]]:
    """Draw the geography: sensor tracks and legs, bearing fan, track, ellipses, handles."""
    from bokeh.models import ColumnDataSource, PointDrawTool
    from bokeh.plotting import figure

    f = page.frame
    fig = figure(width=640, height=600, match_aspect=True, aspect_scale=f.aspect(),
                 x_axis_label=f.labels[0], y_axis_label=f.labels[1],
                 tools="pan,wheel_zoom,box_zoom,reset,save", title="geography", name="map")
    tracks = page.sensor_tracks()
    xs = [t["x"] for t in tracks]
    ys = [t["y"] for t in tracks]
    parts: dict[str, Any] = {"figure": fig}
    t, tx, ty = (page.track() if page.has_track else (np.zeros(0), np.zeros(0), np.zeros(0)))
    ex, ey, _ = (page.ellipses() if page.has_track and page.result.status == "converged"
                 else ([], [], []))
    reach = _reach(f, [*xs, tx, *ex], [*ys, ty, *ey])
    fan_x, fan_y, cuts = bearing_lines(page.meas, f, reach, MAX_FAN_LINES)
    twin_x, twin_y, _ = bearing_lines(page.meas, f, reach, MAX_FAN_LINES, twins=True)
    if twin_x:
        fig.multi_line(twin_x, twin_y, color="#7f7f7f", alpha=0.35, line_width=0.7,
                       line_dash="dashed", legend_label="ambiguous cuts: the other side")
    if fan_x:
        side = ", the side fitted" if twin_x else ""
        fig.multi_line(fan_x, fan_y, color="#ff7f0e", alpha=0.35, line_width=0.7,
                       legend_label=f"bearings ({len(fan_x)} of {cuts} cuts drawn{side})")
    for tr in tracks:
        fig.line(tr["x"], tr["y"], color=tr["colour"], line_width=2, legend_label=tr["name"])
        fig.scatter(tr["x"][:1], tr["y"][:1], marker="triangle", size=9, color=tr["colour"])
        if len(tr["leg_x"]) > 1:
            legs = ColumnDataSource({"x": tr["leg_x"], "y": tr["leg_y"], "n": tr["leg_n"]})
            fig.scatter("x", "y", source=legs, marker="diamond", size=8, color="black",
                        legend_label="own-ship leg starts")
            fig.text("x", "y", text="n", source=legs, x_offset=5, y_offset=-5,
                     text_font_size="9pt")
    if ex:
        fig.multi_line(ex, ey, color="#d62728", line_width=1, alpha=0.8,
                       legend_label=f"{page.level:.0%} position ellipses (ML)")
    if page.has_track:
        fig.line(tx, ty, color="#d62728", line_width=2, alpha=0.45, line_dash="dashed",
                 legend_label="ML solution")
        # What a drag moves is drawn on Bokeh's overlay layer, left out of the map's extent
        # and of its legend (a one-point twin stands there): a drag repaints that layer alone
        fixed = list(fig.renderers)
        solid = {"color": "#d62728", "line_width": 2.5}
        fig.line(tx[:1], ty[:1], legend_label="solution shown", **solid)
        track = ColumnDataSource({"t": t, "x": tx.copy(), "y": ty.copy()})
        fig.line("x", "y", source=track, level="overlay", **solid)
        parts["track"] = track
        stick = ColumnDataSource({"x": [], "y": []})
        fig.line("x", "y", source=stick, color="black", line_width=1.5, level="overlay")
        handles = ColumnDataSource({"x": [], "y": [], "m": []}, name="handles")
        r = fig.scatter("x", "y", source=handles, size=14, fill_color="white",
                        line_color="black", line_width=2, marker="m", level="overlay")
        fig.x_range.renderers = fig.y_range.renderers = fixed
        if not page.refusal:
            tool = PointDrawTool(renderers=[r], add=False, drag=True,
                                 description="drag the solution")
            fig.add_tools(tool)
            fig.toolbar.active_drag = tool
        parts.update(stick=stick, handles=handles,
                     tau=page.tau(np.concatenate([*xs, tx]), np.concatenate([*ys, ty])))
    fig.legend.location = "top_left"
    fig.legend.click_policy = "hide"
    fig.legend.label_text_font_size = "8pt"
    return fig, parts


def _dots_figures(page: _Page, width: int) -> tuple[list[Any], list[dict[str, Any]],
                                                   dict[str, Any]]:
    """Draw one panel of stacked dots per kind, the bands at ±1σ and ±3σ."""
    from bokeh.models import BoxAnnotation, ColumnDataSource, Range1d, Span
    from bokeh.plotting import figure

    m = page.meas
    figs: list[Any] = []
    sources: list[dict[str, Any]] = []
    ranges: dict[str, Any] = {}
    height = max(180, min(300, 600 // max(len(m.kinds), 1)))
    lo, hi = page.when(np.array([m.time.min(), m.time.max()]))
    pad = max(0.05 * float(hi - lo), 1000.0 if page.clock else 1.0)
    shared = Range1d(lo - pad, hi + pad)  # fixed: a drag's dots do not recompute it
    for kind in m.kinds:
        rows = np.flatnonzero(m.kind_mask(kind))
        z = page.z[rows]
        big = max(4.0, 1.1 * float(np.nanmax(np.abs(z)))) if np.any(np.isfinite(z)) else 4.0
        yr = Range1d(-big, big)
        fig = figure(width=width, height=height, x_range=shared, y_range=yr,
                     x_axis_type="datetime" if page.clock else "linear",
                     x_axis_label="time (UTC)" if page.clock else "time (s)",
                     y_axis_label=f"{kind} residual (σ)", title=f"{kind}: stacked dots",
                     tools="xpan,xwheel_zoom,box_zoom,reset,save")
        fig.add_layout(BoxAnnotation(bottom=-1, top=1, fill_color="green", fill_alpha=0.1))
        for y in (-3, 3):
            fig.add_layout(Span(location=y, dimension="width", line_color="red",
                                line_dash="dotted"))
        sensors = series_names(m)[rows]
        step = -(-rows.size // DRAG_DOTS)  # while dragging: every step-th dot
        for k, name in enumerate(dict.fromkeys(sensors)):
            mine = np.flatnonzero(sensors == name)
            named = {"legend_label": str(name)} if len(set(sensors)) > 1 else {}
            entry: dict[str, Any] = {"kind": kind}
            for key, pick in (("", mine), ("light_", mine[::step] if step > 1 else None)):
                if pick is None:
                    continue
                src = ColumnDataSource({"x": page.when(m.time[rows[pick]]),
                                        "z": z[pick].astype(float),
                                        "row": rows[pick].astype(np.int32)})
                entry[key + "source"] = src
                entry[key + "renderer"] = fig.scatter(
                    "x", "z", source=src, size=5, line_color=None,
                    fill_color=_COLOURS[k % len(_COLOURS)],
                    visible=not key, **({"level": "overlay"} if key else named))
            sources.append(entry)
        figs.append(fig)
        ranges[kind] = yr
    return figs, sources, ranges


def solution_page_html(meas: MeasurementSet, result: EstimateResult, *,
                       options: dict[str, Any] | None = None, title: str | None = None,
                       level: float = 0.95, labels: int = 5) -> str:
    """Give the solution page of a batch estimate as one self-contained HTML document."""
    from bokeh.document import Document
    from bokeh.embed import file_html
    from bokeh.layouts import column, row
    from bokeh.models import ColumnDataSource, CustomJS
    from bokeh.resources import INLINE

    page = _Page(meas, result, options, level, labels)
    fig, parts = _map_figure(page)
    dots, sources, ranges = _dots_figures(page, 560)
    if "handles" in parts:
        config = page.config(parts["tau"])
        parts["handles"].data = page.handles(config)
        parts["stick"].data = {k: parts["handles"].data[k] for k in ("x", "y")}
        script = resources.files("tmakit.plot").joinpath("page.js").read_text("utf-8")
        args = {"config": config, "rows": ColumnDataSource(page.rows()),
                "handles": parts["handles"], "stick": parts["stick"], "track": parts["track"],
                "dots": sources, "ranges": ranges, "figures": [fig, *dots]}
        ready = CustomJS(args=args, code="const entered = performance.now();\n" + script
                         + "\nwindow.tmaPage = tmaSolutionPage({"
                         + ", ".join(f"{k}: {k}" for k in args) + "});"
                         + "\nwindow.tmaPage.enteredAt = entered;")
        parts["handles"].js_on_change("change", CustomJS(
            code="if (window.tmaPage) window.tmaPage.onHandles();"))
    else:
        ready = CustomJS(code="window.tmaPage = {ready: true, timings: [], "
                              "readyAt: performance.now()}; requestAnimationFrame(() => "
                              "{ window.tmaPage.paintedAt = performance.now(); });")
    doc = Document()
    doc.add_root(row(fig, column(*dots)))
    doc.js_on_event("document_ready", ready)
    # The heading and the live numbers are plain HTML above the plots (escaped here: file
    # names and sensor names are text); Bokeh's layout is not redone when the numbers change.
    return file_html(doc, INLINE, title="tmakit solution page", template=_TEMPLATE,
                     template_variables={"tma_head": _header(page, title or
                                                             f"{result.method} estimate")})


_TEMPLATE = """{% block contents %}
<div style="font-family: sans-serif; font-size: 13px; margin: 6px 10px">{{ tma_head | safe }}
<div id="tma-stats" style="margin-top: 4px"></div></div>
{{ super() }}
{% endblock %}"""


def write_solution_page(meas: MeasurementSet, result: EstimateResult, path: str | Path, *,
                        options: dict[str, Any] | None = None, title: str | None = None,
                        level: float = 0.95) -> Path:
    """Write the solution page (:func:`solution_page_html`) to ``path``."""
    path = Path(path)
    path.write_text(solution_page_html(meas, result, options=options, title=title, level=level),
                    encoding="utf-8")
    return path
