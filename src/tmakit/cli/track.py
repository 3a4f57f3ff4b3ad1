"""``tma track``: a recursive filter's state and covariance after every update.

Its table, JSON, file and picture.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Annotated, Any

import typer

from .answers_out import (
    SPEED_UNITS,
    SensorOption,
    UnitsOption,
    answer_or_fail,
    check_units,
    print_answers,
    print_warnings,
)
from .common import (
    BearingSigmaOption,
    ContactOption,
    DriftOption,
    FilesArgument,
    ForceOption,
    FormatOption,
    FreeExponentOption,
    FrequencySigmaOption,
    KindsOption,
    MappingOption,
    OriginOption,
    OwnshipOption,
    PropagationSpeedOption,
    RangeSigmaOption,
    RangesOption,
    err,
    fail,
    model_options,
    out,
    parse_origin,
    print_wide,
    reader_options,
)
from .legs_out import sides_for_filter
from .reading import read_or_fail
from .solution_out import HtmlOption, check_page
from .track_options import (
    ComponentOption,
    FollowOption,
    HeightPriorOption,
    IntervalOption,
    LagOption,
    MaxUpdatesOption,
    ModelQOption,
    NuisanceOption,
    ParticlesOption,
    PriorTimeOption,
    QDensityOption,
    RangePriorOption,
    SeedOption,
    SmoothOption,
    SpeedPriorOption,
    TransitionOption,
    TurnRateOption,
    check_track_options,
    component_settings,
    parse_bearing_prior,
    parse_prior,
    parse_q,
    smoothed_track,
    tracking_failure,
)


# `tma track`: the docstring is its --help text, so no numpydoc sections (help= has them).
def track(
    files: FilesArgument,
    filter_name: Annotated[str, typer.Option(
        "--filter", help="ekf, ukf, ckf, mgekf, mpekf, pf, gsf or imm (tmakit.filters.FILTERS)")
    ] = "ekf",
    q: Annotated[str, typer.Option(
        "--q", help="process noise: acceleration std (m/s^2), one value or per axis "
                    "qx,qy[,qz]; 0 = constant velocity")] = "0",
    q_density: QDensityOption = "0", range_prior: RangePriorOption = None,
    speed_prior: SpeedPriorOption = None, height_prior: HeightPriorOption = None,
    component: ComponentOption = "ekf", model_q: ModelQOption = None, transition:
    TransitionOption = None, turn_rate: TurnRateOption = None, smooth: SmoothOption = False,
    lag: LagOption = None, particles: ParticlesOption = None, seed: SeedOption = None,
    prior: Annotated[str | None, typer.Option(
        help="start from this state instead of a batch estimate, e.g. "
             "x=4000,y=9000,vx=-6,vy=-3 (m, m/s); needs --prior-std")] = None,
    prior_std: Annotated[str | None, typer.Option(
        help="the prior's standard deviations, e.g. x=3000,y=3000,vx=10,vy=10")] = None,
    prior_time: PriorTimeOption = None, nuisance: NuisanceOption = None,
    init_window: Annotated[int | None, typer.Option(
        help="start from a batch estimate over this many first measurement times "
             "(default: the shortest window good enough, see --start-std)")] = None,
    start_std: Annotated[float, typer.Option(
        help="start quality: the batch start's position std must be below this fraction "
             "of the range")] = 0.25,
    dim: Annotated[int | None, typer.Option(
        help="2 or 3 (default: 3 when the data or the file's motion need it)")] = None,
    drift: DriftOption = False, free_exponent: FreeExponentOption = False,
    propagation_speed: PropagationSpeedOption = None,
    origin: OriginOption = None,
    format: FormatOption = None, ownship: OwnshipOption = None, contact: ContactOption = None,
    mapping: MappingOption = None, bearing_sigma: BearingSigmaOption = None,
    range_sigma: RangeSigmaOption = None, frequency_sigma: FrequencySigmaOption = None,
    kinds: KindsOption = None, ranges: RangesOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the track as JSON")] = False,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="write the track table (.csv or .parquet)")] = None,
    plot: Annotated[Path | None, typer.Option(
        help="draw the track (PNG, PDF, SVG); with the truth in the file, its error "
             "against the posterior CRB")] = None,
    ellipses: Annotated[int, typer.Option(
        help="number of 90 %/95 % position ellipses drawn along the track")] = 8,
    rows: Annotated[int, typer.Option(help="rows of the summary table")] = 12,
    sensor: SensorOption = None, units: UnitsOption = "si",
    html: HtmlOption = None, follow: FollowOption = False,
    interval: IntervalOption = 1.0, max_updates: MaxUpdatesOption = None,
    force: ForceOption = False,
) -> None:
    """Track the emitter with a recursive filter: state and covariance after every update.

    No initial guess: a batch estimate over the shortest good initial window (or --prior);
    gsf, or --range-prior / --speed-prior, start at the first bearing from those intervals.
    With --html, the solution page of the batch estimate (constant velocity) of the data.
    """
    output, plot = check_track_options(output, plot, force, filter_name, particles, seed,
                                       ellipses, rows, (*files, mapping))
    check_units(units)
    page = check_page(html, force, [*files], plot)
    reading = (parse_origin(origin), dim, reader_options(format, ownship, contact, mapping,
               bearing_sigma, range_sigma, frequency_sigma, kinds=kinds, ranges=ranges))
    options = model_options(drift, free_exponent, propagation_speed)
    tracked = partial(track_files, reading=reading, q=(q, q_density), filter_name=filter_name,
                      smooth=(smooth, lag), keywords=start_keywords(
                          (prior, prior_std, nuisance, prior_time),
                          (range_prior, speed_prior, height_prior), init_window, start_std,
                          (particles, seed, component, smooth or lag is not None,
                           (model_q, transition, turn_rate)),
                          filter_name, options))
    name, say = Path(" + ".join(map(str, files))), err if as_json else out
    if follow:
        from .follow import follow as watch

        return watch(list(files), format, Watch(tracked, name, output, plot, page, ellipses,
                                                force, as_json, sensor, units, options),
                     interval, max_updates, say)
    meas, tr, truth = tracked(list(files))
    report_track(tr, meas, truth, rows, as_json, answer_or_fail(tr, meas, sensor), units)
    write_track_outputs(name, meas, tr, truth, output, plot, ellipses, force, say)
    if page is not None:
        write_track_page(meas, tr, page, force, options, name, say)


def start_keywords(prior: tuple[str | None, str | None, str | None, float | None],
                   bearing: tuple[str | None, float | None, str | None], init_window: int | None,
                   start_std: float, filter_settings: tuple[Any, ...],
                   filter_name: str, options: dict[str, Any]) -> dict[str, Any]:
    """Give the keywords of :func:`tmakit.tracking.track` that ``tma track``'s options set."""
    mean, sd, known = parse_prior(prior[0], prior[1], prior[2], init_window)
    particles, seed, component, smoothing, imm = filter_settings
    return dict(particles=particles, prior=mean, prior_std=sd, prior_time=prior[3],
                init_window=init_window, max_relative_std=start_std, rng=seed,
                options=options, nuisance=known,
                bearing_prior=parse_bearing_prior(*bearing, mean is not None
                                                  or init_window is not None),
                settings=component_settings(filter_name, component, smoothing, *imm))


def track_files(paths: list[Path], reading: tuple[Any, int | None, dict[str, Any]],
                q: tuple[str, str], filter_name: str, smooth: tuple[bool, int | None],
                keywords: dict[str, Any], notes: bool = True) -> tuple[Any, Any, Any]:
    """Read the files and track the emitter: the command's work on the data."""
    from .. import tracking

    origin, dim, options = reading
    meas = read_or_fail(paths, origin, dim=dim, notes=notes, **options)
    try:
        d = tracking.filter_dim(meas, dim)
        meas = sides_for_filter(meas, d)
        q_axes = tracking.process_noise(parse_q(q[0], d), d)
        density = tracking.noise_density(parse_q(q[1], d, "--q-density"), d)
    except tracking.TrackingError as e:
        raise tracking_failure(e) from None
    tr = run_track(meas, filter_name, {**keywords, "q": q_axes, "q_density": density, "dim": d},
                   *smooth)
    return meas, tr, tracking.truth_states(meas, tr.times, d)


def write_track_page(meas: Any, tr: Any, path: Path, force: bool, options: dict[str, Any],
                     name: Path, say: Any) -> None:
    """``--html``: the solution page of the batch estimate (constant velocity) of the data."""
    from ..batch import estimate as run
    from ..motion import ConstantVelocity
    from .solution_out import SolutionOutputs, write_solution_outputs

    dim = len(tr.state_names) // 2
    try:
        result = run(meas, ConstantVelocity(dim, ref_time=float(meas.time.max())),
                     options=options)
    except ValueError as e:
        say.print(f"--html: not written: the batch estimate failed ({e})", highlight=False)
        return
    write_solution_outputs(meas, result, SolutionOutputs(
        html=path, force=force, options=options,
        title=f"{name} (tma track)"),
        True, say)


class Watch:
    """One update of ``tma track --follow``: track the data so far, say it, rewrite outputs."""

    def __init__(self, tracked: Any, name: Path, output: Path | None, plot: Path | None,
                 page: Path | None, ellipses: int, force: bool, as_json: bool,
                 sensor: str | None, units: str, options: dict[str, Any]) -> None:
        self.tracked, self.name = tracked, name
        self.output, self.plot, self.page, self.ellipses = output, plot, page, ellipses
        self.force, self.as_json, self.sensor, self.units = force, as_json, sensor, units
        self.options = options
        self.count = 0
        self.say = err if as_json else out

    def __call__(self, paths: list[Path]) -> bool:
        """Make one update; False (and why, on standard error) when the data give none yet."""
        try:
            meas, tr, truth = self.tracked(paths, notes=self.count == 0)
        except typer.Exit as e:
            if e.exit_code != 2:
                raise
            err.print("waiting for more data", highlight=False)
            return False
        self.count += 1
        answer = answer_or_fail(tr, meas, self.sensor)
        trust = track_trust(tr, measurement_warnings(meas))
        if self.as_json:
            import json

            typer.echo(json.dumps({"update": self.count, "rows": len(meas),
                                   "answer": answer.as_dict(), **trust.as_dict()}))
        else:
            out.print(update_line(self.count, len(meas), answer, trust.level, self.units),
                      highlight=False, soft_wrap=True)
        write_track_outputs(self.name, meas, tr, truth, self.output, self.plot,
                            self.ellipses, self.force or self.count > 1, self.say)
        if self.page is not None:
            write_track_page(meas, tr, self.page, self.force or self.count > 1, self.options,
                             self.name, self.say)
        return True


def update_line(count: int, rows: int, a: Any, trust: str, units: str) -> str:
    """One line of a live watch: the latest position, course and speed, and the trust."""
    when = a.clock[11:19] + " UTC" if a.clock else f"t = {a.time:g} s"
    if a.geodetic is not None and None not in a.geodetic[:2]:
        where = f"lat {a.geodetic[0]:.5f}, lon {a.geodetic[1]:.5f}"
    else:
        where = f"E {a.enu[0]:.0f} m, N {a.enu[1]:.0f} m"
    sd = [v for v in a.enu_std[:2] if v is not None]
    spread = f" (± {max(sd):.0f} m)" if sd else ""
    unit, scale = SPEED_UNITS[units]
    motion = ""
    if a.course_deg is not None and a.speed is not None:
        motion = (f", course {a.course_deg:.1f}° ± {a.course_std_deg:.1f}°, speed "
                  f"{a.speed / scale:.2f} ± {a.speed_std / scale:.2f} {unit}")
    return f"update {count}: {when}, {rows} rows, {where}{spread}{motion}, trust {trust}"


def run_track(meas: Any, filter_name: str, keywords: dict[str, Any], smooth: bool,
              lag: int | None) -> Any:
    """Track (:func:`tmakit.track` with ``keywords``), and smooth with ``--smooth``/``--lag``."""
    from .. import tracking

    try:
        tr = tracking.track(meas, filter_name, **keywords)
        if smooth or lag is not None:
            tr = smoothed_track(tr, lag)
    except tracking.TrackingError as e:
        raise tracking_failure(e) from None
    except ValueError as e:
        raise fail(str(e)) from None
    return tr


def report_track(tr: Any, meas: Any, truth: Any, rows: int, as_json: bool, answer: Any,
                 units: str) -> None:
    """Print the track (table or one line of JSON), its final answers and the warnings."""
    import json

    from .. import tracking

    warnings = measurement_warnings(meas)
    trust = track_trust(tr, warnings)
    if as_json:  # one line: the track is long, and rich's JSON printer slow on it
        typer.echo(json.dumps({**tracking.track_dict(tr), "answer": answer.as_dict(),
                               **trust.as_dict()}))
    else:
        print_track(tr, truth, rows, meas, units)
        print_answers(answer, units, meas)
        out.print(f"trust: {trust.level}", highlight=False)
    print_warnings(warnings)


def track_trust(tr: Any, warnings: list[Any]) -> Any:
    """Return how far to trust a track: ``warning`` when its innovations are inconsistent."""
    import numpy as np

    from ..results import TRUST_OK, TRUST_WARNING, SanityWarning, Trust

    reasons = list(warnings)
    used = tr.dof > 0
    if np.any(used):
        verdict = nis_verdict(float(np.sum(tr.nis[used])), int(np.sum(tr.dof[used])))
        if verdict:
            reasons.insert(0, SanityWarning("inconsistent-innovations", verdict))
    return Trust(TRUST_WARNING if reasons else TRUST_OK, reasons)


def measurement_warnings(meas: Any) -> list[Any]:
    """Return the sanity warnings about the measurements (radians, far sensors)."""
    from ..results import measurement_warnings as check

    return check(meas)


def write_track_outputs(file: Path, meas: Any, tr: Any, truth: Any, output: Path | None,
                        plot: Path | None, ellipses: int, force: bool, say: Any) -> None:
    """Write the track table (``-o``) and picture (``--plot``), and say so."""
    from .. import tracking
    from ..io.track_files import write_track

    if output is not None:
        try:
            write_track(tr, output, force=force)
        except FileExistsError:
            raise fail(f"{output} already exists; use --force to overwrite it") from None
        say.print(f"wrote {output}", highlight=False)
    if plot is not None:
        from ..plot.tracks import plot_track
        from .outputs import write_picture

        bound, note = (tracking.track_pcrb(meas, tr, truth) if truth is not None
                       else (None, ""))
        title = f"{file}: {tr.filter_name} track"
        if "scenario" in meas.metadata:
            title += f" of scenario {meas.metadata['scenario']}"
        write_picture(plot, force, lambda tmp: plot_track(
            tr, meas, tmp, truth=truth, pcrb=bound, pcrb_note=note, ellipses=ellipses,
            title=title))
        say.print(f"wrote {plot}", highlight=False)


def start_sentence(tr: Any) -> str:
    """How the filter started: the prior, or the batch window, its quality and its checks."""
    s = tr.extra.start
    if s["method"] == "prior":
        return f"start: the given prior at t = {s['time']:g} s"
    if s["method"] == "first-bearing":
        from ..filters import BearingPrior

        p = s["prior"]
        prior = BearingPrior(p["range_m"][0], p["range_m"][1], p["speed_max_m_s"],
                             (p["height_m"][0], p["height_m"][1]), tuple(p["given"]))
        return (f"start: the first bearing ({s['bearing_deg']:.1f} deg at t = "
                f"{s['time']:g} s) with the prior {prior.describe()}"
                + ("" if "range" in p["given"] else "; give --range-prior MIN:MAX and "
                   "--speed-prior MAX for this emitter")
                + (f"; {len(s['rejected'])} earlier bearings rejected by the innovations "
                   f"that followed them (from t = {s['rejected'][0]['time']:g} s)"
                   if s.get("rejected") else ""))
    text = (f"start: batch ML estimate over the first {s['window']} measurement times "
            f"({s['rows']} rows, t <= {s['time']:g} s), {s['status']}, position std "
            f"{s['relative_position_std']:.1%} of the range")
    if s.get("max_relative_std") is not None:
        text += f" (needed < {s['max_relative_std']:.0%})"
    if s.get("nuisance"):
        text += ("; nuisance held at " + ", ".join(
            f"{k} = {v['value']:.10g} (std {v['std']:.3g})" for k, v in s["nuisance"].items())
            + " (the filter does not carry their uncertainty)")
    check = s.get("confirmation")
    if check and check["dof"]:
        text += (f"; confirmed by the next {check['updates']} updates (NIS {check['nis']:.1f} "
                 f"on {check['dof']} dof, p = {check['p_value']:.2g})")
    for r in s.get("rejected", []):
        text += (f"; rejected first: the window of {r['window']} times (t <= {r['time']:g} s), "
                 f"NIS {r['nis']:.1f} on {r['dof']} dof over the next {r['updates']} updates "
                 f"(p = {r['p_value']:.2g})")
    return text


def print_track(tr: Any, truth: Any, n_rows: int, meas: Any = None,
                units: str = "si") -> None:
    """Print the track's summary table (``n_rows`` rows spread over it) and its checks."""
    import numpy as np
    from rich.table import Table  # (loaded where a table is made: not for --help)

    from ..results.context import clock_time

    dim = len(tr.state_names) // 2
    k_sel = np.unique(np.linspace(0, len(tr) - 1, min(n_rows, len(tr))).round().astype(int))
    q = ", ".join(f"{v:g}" for v in tr.extra.q)
    if any(tr.extra.q_density or ()):
        q += " m/s^2, q~ = " + ", ".join(f"{v:g}" for v in tr.extra.q_density) + " m^2/s^3"
    else:
        q += " m/s^2"
    table = Table(title=f"{tr.filter_name} track: {len(tr)} rows, t = {tr.times[0]:g} .. "
                        f"{tr.times[-1]:g} s, q = {q} ({len(k_sel)} rows shown)",
                  title_justify="left")
    clock = meas is not None and clock_time(meas, 0.0) is not None
    sp_unit, sp_scale = SPEED_UNITS[units]
    cols = [*(["UTC"] if clock else []), "t\n(s)",
            *(f"{n}\n(m)" for n in tr.state_names[:dim]), "std\n(m)",
            f"speed\n({sp_unit})", "course\n(deg)", "NIS/\ndof"]
    if truth is not None:
        cols.append("error\n(m)")
    for c in cols:
        table.add_column(c, justify="right", no_wrap=True)
    pos_sd = np.sqrt(np.einsum("kii->k", tr.covariances[:, :dim, :dim]))
    for k in k_sel:
        v = tr.states[k, dim:]
        speed = float(np.linalg.norm(v)) / sp_scale
        course = float(np.degrees(np.arctan2(v[0], v[1])) % 360.0)
        nis = (f"{tr.nis[k]:.2f}/{tr.dof[k]}" if tr.dof[k] > 0 else "start")
        row = [*([str(clock_time(meas, float(tr.times[k])))[:19]] if clock else []),
               f"{tr.times[k]:g}", *(f"{x:.1f}" for x in tr.states[k, :dim]),
               f"{pos_sd[k]:.1f}", f"{speed:.2f}", f"{course:.1f}", nis]
        if truth is not None:
            row.append(f"{np.linalg.norm(tr.states[k, :dim] - truth[k, :dim]):.1f}")
        table.add_row(*row)
    print_wide(table)
    out.print("std: position RMS std sqrt(trace P); NIS: normalised innovation squared",
              highlight=False)
    out.print(start_sentence(tr), highlight=False)
    print_track_checks(tr, truth, dim)


def nis_verdict(nis: float, dof: int, level: float = 1e-3) -> str:
    """Say when the innovations contradict the filter's covariances (chi-square test)."""
    from ..core import chi2

    upper, lower = float(chi2.sf(nis, dof)), float(chi2.cdf(nis, dof))
    if upper < level:
        return (f"the innovations are larger than the track's covariances allow (NIS {nis:.1f} "
                f"on {dof} dof, p = {upper:.2g}): the track is overconfident or has diverged; "
                "its standard deviations understate the error")
    if lower < level:
        return (f"the innovations are smaller than the measurement sigmas imply (NIS {nis:.1f} "
                f"on {dof} dof, p = {lower:.2g}): the sigmas may be too large, and the "
                "standard deviations overstate the error")
    return ""


def print_track_checks(tr: Any, truth: Any, dim: int) -> None:
    """Print the mean NIS per degree of freedom and, with the truth, the final error."""
    import numpy as np

    used = tr.dof > 0
    if np.any(used):
        mean_nis = float(np.sum(tr.nis[used]) / np.sum(tr.dof[used]))
        out.print(f"{int(np.sum(used))} updates, mean NIS per degree of freedom "
                  f"{mean_nis:.3f} (1 when consistent), log-likelihood "
                  f"{tr.log_likelihood[-1]:.2f}", highlight=False)
        verdict = nis_verdict(float(np.sum(tr.nis[used])), int(np.sum(tr.dof[used])))
        if verdict:
            err.print(f"warning: {verdict}", highlight=False)
    if truth is not None:
        e = tr.states[-1, :dim] - truth[-1, :dim]
        cov = tr.covariances[-1, :dim, :dim]
        try:
            sigma = f"{float(np.sqrt(e @ np.linalg.solve(cov, e))):.2f} sigma (Mahalanobis, " \
                f"{dim}-D)"
        except np.linalg.LinAlgError:
            sigma = "the final covariance is singular (a collapsed cloud or track)"
        out.print(f"truth known (file metadata): final position error "
                  f"{np.linalg.norm(e):.1f} m, {sigma}", highlight=False)
