"""``tma track``: a recursive filter's state and covariance after every update; ``--follow``."""

from __future__ import annotations

import math
import queue
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Annotated, Any, BinaryIO

import typer

from .common import (
    DriftOption,
    FaultInWrittenLines,
    FilesArgument,
    ForceOption,
    FreeExponentOption,
    OriginOption,
    PropagationSpeedOption,
    check_dim,
    check_outputs,
    check_particles,
    err,
    fail,
    failing,
    model_options,
    note_unused_model_options,
    out,
    parse_assignments,
    parse_origin,
    print_wide,
    read_or_fail,
    read_window,
    reads_logs,
    select_window,
    window_help,
    window_times,
    write_picture,
)
from .estimate import (
    SPEED_UNITS,
    HtmlOption,
    SensorOption,
    SolutionOutputs,
    UnitsOption,
    answer_or_fail,
    check_solution_outputs,
    check_units,
    manoeuvre_warnings,
    print_answers,
    print_warnings,
    sides_for_filter,
    write_solution_outputs,
)

ParticlesOption = Annotated[int | None, typer.Option(
    help="number of particles (particle filter only)")]
SeedOption = Annotated[int | None, typer.Option(
    help="random seed (particle filter only; same seed, same track)")]
QDensityOption = Annotated[str, typer.Option(
    "--q-density", help="process noise as continuous white-noise acceleration: spectral "
                        "density (m^2/s^3), one value or per axis; Q = q~ [[T^3/3, T^2/2], "
                        "[T^2/2, T]] per axis, added to --q's")]
RangePriorOption = Annotated[str | None, typer.Option(
    "--range-prior", help="start at the first bearing: the emitter's range then lies in "
                          "MIN:MAX (m, within 1..1e9); default 500:50000 for --filter gsf")]
SpeedPriorOption = Annotated[float | None, typer.Option(
    "--speed-prior", help="start at the first bearing: the largest plausible speed (m/s, "
                          "0.001..10000; course unknown); default 20")]
HeightPriorOption = Annotated[str | None, typer.Option(
    "--height-prior", help="start at the first bearing, 3-D: the emitter's height interval "
                           "MIN:MAX (m, within +-1e9); default 0:12000")]
ComponentOption = Annotated[str, typer.Option(
    help="the component filter of gsf (the Gaussian sum) or imm: ekf, ukf or ckf "
         "(cubature)")]
ModelQOption = Annotated[str | None, typer.Option(
    "--model-q", help="--filter imm, mmpf: acceleration std (m/s^2) of the manoeuvre models, "
                      "one value per model (comma-separated) beside the --q model; default "
                      "none")]
TurnRateOption = Annotated[str | None, typer.Option(
    "--turn-rate", help="--filter imm, mmpf: turn rates (deg/s, comma-separated; counter-clockwise "
                        "positive, a right turn negative) of coordinated-turn models added "
                        "after the --model-q ones; default +-0.75,1.5,3 for imm, "
                        "+-0.375,0.75,1.5,3 for mmpf (a ship's turn to an aircraft's "
                        "standard-rate turn); none for no turn model")]
RateNoiseOption = Annotated[str | None, typer.Option(
    "--turn-rate-noise", help="--filter imm: add a coordinated turn whose rate is estimated "
                              "(Li & Jilkov 2003), its rate's random walk in deg/s per "
                              "sqrt(s); none (the default) for no such model")]
PriorTimeOption = Annotated[float | None, typer.Option(
    help="time of the prior (s); default: the first measurement time")]
NuisanceOption = Annotated[str | None, typer.Option(
    help="known nuisance values with --prior, e.g. carrier=9.4e9 (Hz, dBW)")]
TransitionOption = Annotated[str | None, typer.Option(
    "--transition", help="--filter imm, mmpf: the Markov matrix per step, rows (from) separated "
                         "by ';', e.g. 0.99,0.01;0.01,0.99 (default: each model held 1500 s (imm), "
                         "500 s (mmpf) on average, whatever the step)")]
SmoothOption = Annotated[bool, typer.Option(
    "--smooth", help="also give the smoothed track (Rauch-Tung-Striebel for the Gaussian "
                     "filters and the Gaussian sum; two-filter for imm; backward simulation for "
                     "pf and mmpf)")]
SumsOption = Annotated[bool, typer.Option(
    "--sums", help="--filter gsf with --json: each row's Gaussian sum (components' weights, "
                   "means, covariances), and with --smooth or --lag the smoothed sum's (it "
                   "makes the JSON ten times larger or more)")]
LagOption = Annotated[int | None, typer.Option(
    help="a fixed-lag smoother (implies --smooth): each state given the data up to N "
         "updates after it")]
FollowOption = Annotated[bool, typer.Option(
    "--follow", help="keep tracking as the file grows (REP, NMEA, CSV; FILE - reads standard "
                     "input, with --format): one line per update, the outputs rewritten; "
                     "Ctrl-C or SIGTERM stops it")]
IntervalOption = Annotated[float, typer.Option(
    metavar="SECONDS", help="--follow: seconds between looks at the file")]
MaxUpdatesOption = Annotated[int | None, typer.Option(
    metavar="N", help="--follow: stop after N updates")]
FromOption = Annotated[str | None, typer.Option(
    "--from", help=window_help("track one stretch", "first"))]
ToOption = Annotated[str | None, typer.Option(
    "--to", help=window_help("track one stretch", "last") + "; --follow stops once the data "
                                                             "pass it")]


class FollowEnded(Exception):
    """``--follow`` with ``--to``: the data have passed the window's end, which is tracked."""


@reads_logs(after="origin")
def track(
    files: FilesArgument,
    filter_name: Annotated[str, typer.Option(
        "--filter", help="ekf, ukf, ckf, mgekf, mpekf, pf, gsf, imm or mmpf "
                         "(tmakit.filters.FILTERS)")] = "ekf",
    q: Annotated[str, typer.Option(
        "--q", help="process noise: acceleration std (m/s^2), one value or per axis "
                    "qx,qy[,qz]; 0 = constant velocity")] = "0",
    q_density: QDensityOption = "0", range_prior: RangePriorOption = None,
    speed_prior: SpeedPriorOption = None, height_prior: HeightPriorOption = None,
    component: ComponentOption = "ekf", model_q: ModelQOption = None, transition:
    TransitionOption = None, turn_rate: TurnRateOption = None,
    turn_rate_noise: RateNoiseOption = None, smooth: SmoothOption = False,
    lag: LagOption = None, sums: SumsOption = False, particles: ParticlesOption = None,
    seed: SeedOption = None, prior: Annotated[str | None, typer.Option(
        help="start from this state instead of a batch estimate, e.g. "
             "x=4000,y=9000,vx=-6,vy=-3 (m, m/s); needs --prior-std")] = None,
    prior_std: Annotated[str | None, typer.Option(
        help="the prior's standard deviations, e.g. x=3000,y=3000,vx=10,vy=10")] = None,
    prior_time: PriorTimeOption = None, nuisance: NuisanceOption = None,
    init_window: Annotated[int | None, typer.Option(
        help="start from a batch estimate over this many first measurement times "
             "(default: the shortest window good enough, see --start-std)")] = None,
    start_std: Annotated[float | None, typer.Option(
        help="start quality: the batch start's position std must be below this fraction "
             "of the range (default 0.25; 0.1 for imm and mmpf)")] = None,
    dim: Annotated[int | None, typer.Option(
        help="2 or 3 (default: 3 when the data or the file's motion need it)")] = None,
    drift: DriftOption = False, free_exponent: FreeExponentOption = False,
    propagation_speed: PropagationSpeedOption = None,
    origin: OriginOption = None,
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
    start: FromOption = None, stop: ToOption = None,
    force: ForceOption = False, *, logs: dict[str, Any],
) -> None:
    """Track the emitter with a recursive filter: state and covariance after every update.

    No initial guess: a batch estimate over the shortest good initial window (or --prior);
    gsf, or --range-prior / --speed-prior, start at the first bearing from those intervals.
    With --html, the solution page of the batch estimate (constant velocity) of the data.

    Exit status 0: a track (trust ok or warning); 4: the track has diverged (trust none, no
    answer; the table, -o and --plot show where it went); 2: bad input (docs/reliability.md).
    """
    output, plot = check_track_options(output, plot, force, filter_name, particles, seed,
                                       ellipses, rows, (sums, as_json, follow, units))
    page = check_solution_outputs(html, None, force, [*files], taken=[plot]).html
    reading = (parse_origin(origin), check_dim(dim), logs)
    options = model_options(drift, free_exponent, propagation_speed)
    mean, sd, known = parse_prior(prior, prior_std, nuisance, init_window)
    keywords = dict(  # of tmakit.tracking.track
        particles=particles, prior=mean, prior_std=sd, prior_time=prior_time,
        init_window=init_window, max_relative_std=start_std, rng=seed, options=options,
        nuisance=known, bearing_prior=parse_bearing_prior(
            range_prior, speed_prior, height_prior, mean is not None or init_window is not None),
        settings=component_settings(filter_name, component, smooth or lag is not None or sums,
                                    model_q, transition, turn_rate, turn_rate_noise))
    tracked = partial(track_files, reading=reading, window=(start, stop), q=(q, q_density),
                      filter_name=filter_name, smooth=(smooth, lag, sums), keywords=keywords)
    update = Watch(tracked, Path(" + ".join(map(str, files))), output, plot, page, ellipses,
                   force, as_json, sensor, units, options)
    if follow:
        return watch(list(files), logs["format"], update, interval, max_updates, update.say)
    meas, tr, truth, _ = tracked(list(files))
    trust = report_track(tr, meas, truth, rows, as_json, answer_or_fail(tr, meas, sensor), units,
                         sums, options)
    update.write(meas, tr, truth, force)
    no_answer_exit(trust)


def no_answer_exit(trust: Any) -> None:
    """Exit with status 4 after a diverged track's outputs (they show where it went)."""
    from .guard import EXIT_NO_ANSWER

    if not trust.answer:
        raise typer.Exit(EXIT_NO_ANSWER)


def track_files(paths: list[Path], reading: tuple[Any, int | None, dict[str, Any]],
                window: tuple[str | None, str | None], q: tuple[str, str], filter_name: str,
                smooth: tuple[bool, int | None, bool], keywords: dict[str, Any],
                notes: bool = True,
                shown_as: dict[Path, Path] | None = None) -> tuple[Any, Any, Any, bool]:
    """Read the files and track the emitter: the command's work on the data.

    The last item says whether the data have passed ``--to`` (``--follow`` then stops).
    """
    from .. import tracking

    origin, dim, options = reading
    ended = False
    if shown_as is None:
        meas = read_window(paths, origin, window, dim=dim, notes=notes, **options)
    else:  # --follow: read all, so that the end of the window can be seen
        meas, ended = followed_window(read_or_fail(paths, origin, dim=dim, notes=notes,
                                                   shown_as=shown_as, **options), window)
    if notes:
        note_unused_model_options(meas, keywords["options"])
    try:
        d = tracking.filter_dim(meas, dim)
        meas = sides_for_filter(meas, d)
        start = keywords.get("bearing_prior")
        if d == 2 and start is not None and "height" in start.given:
            raise fail("--height-prior: the emitter's height belongs to a 3-D track, and this "
                       "track is 2-D (--dim 3 to track in 3-D)")
        q_axes = tracking.process_noise(parse_q(q[0], d), d)
        density = tracking.noise_density(parse_q(q[1], d, "--q-density"), d)
    except tracking.TrackingError as e:
        raise tracking_failure(e) from None
    try:
        tr = run_track(meas, filter_name,
                       {**keywords, "q": q_axes, "q_density": density, "dim": d}, *smooth)
    except typer.Exit:
        if notes:  # what the data show that may be why (angles in radians, sensors far away)
            from ..results import measurement_warnings

            print_warnings(measurement_warnings(meas))
        raise
    return meas, tr, tracking.truth_states(meas, tr.times, d), ended


def followed_window(meas: Any, window: tuple[str | None, str | None]) -> tuple[Any, bool]:
    """``--follow``: the snapshot's rows in the window, and whether the data have passed ``--to``.

    An empty window waits for more data unless the data have passed it; a bad ``--from`` or
    ``--to`` stops the watch (more lines cannot mend it).
    """
    try:
        t_to = window_times(meas, *window)[1]
    except typer.Exit:
        raise FaultInWrittenLines(2) from None
    ended = t_to is not None and len(meas) > 0 and float(meas.time.max()) > t_to
    try:
        return select_window(meas, *window), ended
    except typer.Exit:
        if ended:
            raise FaultInWrittenLines(2) from None
        raise


def write_track_page(meas: Any, tr: Any, path: Path, force: bool, options: dict[str, Any],
                     name: Path, say: Any) -> None:
    """``--html``: the solution page of the batch estimate (constant velocity) of the data."""
    from ..batch import estimate as run
    from ..motion import ConstantVelocity

    dim = len(tr.state_names) // 2
    try:
        result = run(meas, ConstantVelocity(dim, ref_time=float(meas.time.max())), options=options)
    except ValueError as e:
        say.print(f"--html: not written: the batch estimate failed ({e})")
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
        self.options, self.count, self.say = options, 0, err if as_json else out

    def write(self, meas: Any, tr: Any, truth: Any, force: bool) -> None:
        """Write the track table, picture and page asked for, and say so."""
        write_track_outputs(self.name, meas, tr, truth, self.output, self.plot, self.ellipses,
                            force, self.say)
        if self.page is not None:
            write_track_page(meas, tr, self.page, force, self.options, self.name, self.say)

    def __call__(self, shown_as: dict[Path, Path]) -> bool:
        """Make one update from the snapshots (keys) of the files followed (values).

        False (and why, on standard error) when the data give none yet; a fault in the lines
        already written stops the watch.
        """
        try:
            meas, tr, truth, ended = self.tracked(list(shown_as), notes=self.count == 0,
                                                  shown_as=shown_as)
        except FaultInWrittenLines:
            raise
        except typer.Exit as e:
            if e.exit_code != 2:
                raise
            err.print("waiting for more data")
            return False
        self.count += 1
        answer = answer_or_fail(tr, meas, self.sensor)
        from ..results import measurement_warnings

        trust = track_trust(tr, measurement_warnings(meas) + prior_range_warnings(tr, meas))
        if self.as_json:
            import json

            typer.echo(json.dumps({"update": self.count, "rows": len(meas),
                                   "answer": answer.as_dict() if trust.answer else None,
                                   **trust.as_dict()}))
        elif trust.answer:
            out.print(update_line(self.count, len(meas), answer, trust.level, self.units),
                      soft_wrap=True)
        else:
            out.print(f"update {self.count}: {len(meas)} rows, {trust.reasons[0].message}; "
                      f"trust {trust.level}", soft_wrap=True)
        self.write(meas, tr, truth, self.force or self.count > 1)
        if ended:
            raise FollowEnded("the data have passed --to: the window is tracked")
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
              lag: int | None, sums: bool = False) -> Any:
    """Track (:func:`tmakit.track`) and smooth (``--smooth``/``--lag``; ``--sums`` kept)."""
    from .. import tracking

    try:
        tr = tracking.track(meas, filter_name, **keywords)
        if smooth or lag is not None:
            tr = smoothed_track(tr, lag, keep_history=sums)
    except tracking.TrackingError as e:
        raise tracking_failure(e) from None
    except ValueError as e:
        raise fail(flagged(str(e))) from None
    return tr


def report_track(tr: Any, meas: Any, truth: Any, rows: int, as_json: bool, answer: Any,
                 units: str, sums: bool = False, options: dict[str, Any] | None = None) -> Any:
    """Print the track (table or one line of JSON), its final answers and the warnings.

    Returns its trust (``none``: no answer printed, ``answer`` null in the JSON).
    """
    import json

    from .. import tracking
    from ..results import measurement_warnings

    warnings = (measurement_warnings(meas) + start_manoeuvre_warnings(tr, meas, options)
                + prior_range_warnings(tr, meas))
    trust = track_trust(tr, warnings)
    if as_json:  # one line: the track is long, and rich's JSON printer slow on it
        typer.echo(json.dumps({**tracking.track_dict(tr, sums=sums),
                               "answer": answer.as_dict() if trust.answer else None,
                               **trust.as_dict()}))
    else:
        print_track(tr, truth, rows, meas, units)
        if trust.answer:
            print_answers(answer, units, meas)
        else:
            out.print(trust.reasons[0].message, soft_wrap=True)
        codes = ", ".join(r.code for r in trust.reasons)
        out.print(f"trust: {trust.level}" + (f" ({codes})" if codes else ""), soft_wrap=True)
    print_warnings([r for r in trust.reasons if r.code == "held-nuisance"] + warnings)
    return trust


def start_manoeuvre_warnings(tr: Any, meas: Any, options: dict[str, Any] | None) -> list[Any]:
    """Warn when the batch start's window hides a target manoeuvre (``target-manoeuvre``)."""
    from .. import tracking

    start = tracking.start_record(tr)
    if not isinstance(start, tracking.BatchStart):
        return []
    return manoeuvre_warnings(meas.take(meas.time <= start.time), start.estimate, options, subject=(
        f"the track's batch start (a constant-velocity fit over its first {start.window} "
        "measurement times, from which the filter goes on)"), advice=(
        "start inside one leg (--init-window with fewer times, or --prior) or let the "
        "filter follow manoeuvres (--q)"))


def prior_range_warnings(tr: Any, meas: Any) -> list[Any]:
    """Warn (``range-from-prior``) when a track from a prior has a range the data leave open."""
    from .. import tracking
    from ..results import SanityWarning

    start = tracking.start_record(tr)
    if isinstance(start, tracking.BearingStart):
        prior = f"its prior ({start.prior.describe()})"
        advice = "give --range-prior and --speed-prior for this emitter"
    elif isinstance(start, tracking.PriorStart):
        prior, advice = "the given --prior and --prior-std", "check them"
    else:
        return []
    why = data_range_verdict(meas, len(tr.state_names) // 2)
    if not why:
        return []
    return [SanityWarning("range-from-prior", (
        f"the data alone do not determine the range ({why}): the track's range comes from "
        f"{prior}, so its ellipse holds the truth only if the emitter lies within that prior; "
        f"{advice}, or add data from an own-ship manoeuvre across the line of sight"))]


def data_range_verdict(meas: Any, dim: int) -> str:
    """Say how a constant-velocity fit of the rows leaves the range open ('' if it does not)."""
    import numpy as np

    from ..batch import estimate
    from ..motion import ConstantVelocity
    from ..results.answers import estimate_answer

    fit = "a constant-velocity fit of the same rows"
    try:
        result = estimate(meas, ConstantVelocity(dim, float(np.min(meas.time))))
        if result.status == "unobservable":
            return f"{fit} is unobservable"
        weak = estimate_answer(result, meas).undetermined if result.status == "converged" else ()
    except (ValueError, np.linalg.LinAlgError):  # (no verdict: the track's own checks stand)
        return ""
    ranged = [w for w in weak if w.startswith("range")]
    return f"{fit} leaves the {ranged[0]} undetermined" if ranged else ""


def track_trust(tr: Any, warnings: list[Any]) -> Any:
    """Return a track's trust: ``none`` diverged, ``warning`` inconsistent NIS or held nuisance."""
    from .. import tracking
    from ..results import TRUST_NONE, TRUST_OK, TRUST_WARNING, SanityWarning, Trust

    reasons = list(warnings)
    start = tracking.start_record(tr)
    if isinstance(start, tracking.BatchStart) and start.held_nuisance_note():
        reasons.insert(0, SanityWarning("held-nuisance", start.held_nuisance_note()))
    verdict = nis_verdict(tr)
    if verdict:
        reasons.insert(0, SanityWarning("inconsistent-innovations", verdict))
    if diverged := divergence_verdict(tr):
        return Trust(TRUST_NONE, [SanityWarning("diverged", diverged), *reasons])
    return Trust(TRUST_WARNING if reasons else TRUST_OK, reasons)


#: A track has diverged when the innovations of its last quarter of updates (at least
#: DIVERGED_UPDATES of them) exceed what its covariances allow (chi-square upper tail below
#: DIVERGED_P) by DIVERGED_NIS times or more on average (innovations twice their predicted std).
DIVERGED_UPDATES, DIVERGED_P, DIVERGED_NIS = 10, 1e-3, 4.0


def divergence_verdict(tr: Any) -> str:
    """Say when a track has diverged: its final updates' innovations far beyond its covariances."""
    import numpy as np

    from ..core import chi2

    used = np.flatnonzero(tr.dof > 0)
    last = used[-max(DIVERGED_UPDATES, used.size // 4):]
    if last.size == 0:
        return ""
    nis, dof = float(np.sum(tr.nis[last])), int(np.sum(tr.dof[last]))
    p = float(chi2.sf(nis, dof))
    if not (p < DIVERGED_P and nis >= DIVERGED_NIS * dof):
        return ""
    return (f"no answer: the track has diverged: over its last {last.size} updates (from t = "
            f"{float(tr.times[last[0]]):g} s) the innovations are {nis / dof:.1f} times the "
            f"variance its covariances allow (NIS {nis:.1f} on {dof} dof, p = {p:.2g}), so its "
            "final state and standard deviations are not to be trusted. A manoeuvring target "
            "(--filter imm, or --q)? Sigmas too small?")


def write_track_outputs(file: Path, meas: Any, tr: Any, truth: Any, output: Path | None,
                        plot: Path | None, ellipses: int, force: bool, say: Any) -> None:
    """Write the track table (``-o``) and picture (``--plot``), and say so."""
    from .. import tracking
    from ..io.track_files import write_track

    if output is not None:
        with failing(written=output, errors=()):
            write_track(tr, output, force=force)
        say.print(f"wrote {output}")
    if plot is not None:
        from ..plot.tracks import plot_track

        bound, note = (tracking.track_pcrb(meas, tr, truth) if truth is not None else (None, ""))
        title = f"{file}: {tr.filter_name} track"
        if "scenario" in meas.metadata:
            title += f" of scenario {meas.metadata['scenario']}"
        write_picture(plot, force, lambda tmp: plot_track(
            tr, meas, tmp, truth=truth, pcrb=bound, pcrb_note=note, ellipses=ellipses,
            title=title))
        say.print(f"wrote {plot}")


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
                   if s.get("rejected") else "")
                + (f"; {s['unused_rows']} row{'s' * (s['unused_rows'] != 1)} of other kinds "
                   "before it not used (a filter started at a bearing takes what follows it)"
                   if s.get("unused_rows") else ""))
    text = (f"start: batch ML estimate over the first {s['window']} measurement times "
            f"({s['rows']} rows, t <= {s['time']:g} s), {s['status']}, position std "
            f"{s['relative_position_std']:.1%} of the range")
    if s.get("max_relative_std") is not None:
        text += f" (needed < {s['max_relative_std']:.0%})"
    if s.get("nuisance"):
        text += ("; nuisance held at " + ", ".join(
            f"{k} = {v['value']:.10g} (std {v['std']:.3g})" for k, v in s["nuisance"].items())
            + " (the filter does not carry their uncertainty)")
    if s.get("widened"):
        text += ("; its covariance widened to the window's profile likelihood (the linearised "
                 "one is overconfident) along " + ", ".join(
                     f"the {w['axis']} axis x{w['factor']:.3g}"
                     + ("" if w.get("converged", True) else
                        " (its end not found to tolerance: widened beyond the limit instead)")
                     + (" (multi-modal)" if w.get("multimodal") else "")
                     for w in s["widened"]))
        if any(w.get("multimodal") for w in s["widened"]):
            text += ("; along the axes marked multi-modal the profile leaves the likelihood "
                     "region and comes back into it (the fit has another minimum there): the "
                     "widened Gaussian spans both valleys and the gap between them, which the "
                     "likelihood excludes, so the track may settle in either")
    check = s.get("confirmation")
    if check and check["dof"]:
        text += (f"; confirmed by the next {check['updates']} updates (NIS {check['nis']:.1f} "
                 f"on {check['dof']} dof, p = {check['p_value']:.2g})")
    for r in s.get("rejected", []):
        text += (f"; rejected first: the window of {r['window']} times (t <= {r['time']:g} s), "
                 + (f"position std {r['relative_position_std']:.1%} of the range by its "
                    "profile likelihood" if "nis" not in r else
                    f"NIS {r['nis']:.1f} on {r['dof']} dof over the next {r['updates']} updates "
                    f"(p = {r['p_value']:.2g})"))
    return text


def print_track(tr: Any, truth: Any, n_rows: int, meas: Any = None, units: str = "si") -> None:
    """Print the track's summary table (``n_rows`` rows spread over it) and its checks."""
    import numpy as np
    from rich.table import Table  # (loaded where a table is made: not for --help)

    from ..results.context import clock_time

    dim = len(tr.state_names) // 2
    k_sel = np.unique(np.linspace(0, len(tr) - 1, min(n_rows, len(tr))).round().astype(int))
    q = ", ".join(f"{v:g}" for v in tr.extra.q) + " m/s^2"
    if any(tr.extra.q_density or ()):
        q += ", q~ = " + ", ".join(f"{v:g}" for v in tr.extra.q_density) + " m^2/s^3"
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
    out.print("std: position RMS std sqrt(trace P); NIS: normalised innovation squared")
    out.print(start_sentence(tr))
    print_track_checks(tr, truth, dim)


def nis_verdict(tr: Any, level: float = 1e-3) -> str:
    """Say when the innovations contradict the filter's covariances (chi-square test)."""
    from ..core import chi2

    used = tr.dof > 0
    if not used.any():
        return ""
    nis, dof = float(tr.nis[used].sum()), int(tr.dof[used].sum())
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
                  f"{tr.log_likelihood[-1]:.2f}")
        if verdict := nis_verdict(tr):
            err.print(f"warning: {verdict}")
    if truth is not None:
        e = tr.states[-1, :dim] - truth[-1, :dim]
        cov = tr.covariances[-1, :dim, :dim]
        try:
            sigma = f"{float(np.sqrt(e @ np.linalg.solve(cov, e))):.2f} sigma (Mahalanobis, " \
                f"{dim}-D)"
        except np.linalg.LinAlgError:
            sigma = "the final covariance is singular (a collapsed cloud or track)"
        out.print(f"truth known (file metadata): final position error "
                  f"{np.linalg.norm(e):.1f} m, {sigma}")


def numbers(text: str, message: str, convert: Callable[[str], float] = float) -> list[float]:
    """Read numbers separated by commas; ``error: message`` when one is not a number."""
    try:
        return [convert(v) for v in text.split(",")]
    except ValueError:
        raise fail(message) from None


def parse_q(text: str, dim: int, flag: str = "--q") -> list[float]:
    """Parse ``--q``: one number or per-axis numbers ``qx,qy[,qz]`` (m/s^2)."""
    unit = "m/s^2" if flag == "--q" else "m^2/s^3"
    return numbers(text, f"{flag} {text!r}: expected one number or {dim} numbers separated by "
                         f"commas ({unit} per axis, e.g. 0.01 or {','.join(['0.01'] * dim)})")


def _interval(text: str, flag: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(":"))
    except ValueError:
        lo = hi = math.nan
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise fail(f"{flag} {text!r}: expected MIN:MAX in metres (finite numbers), e.g. "
                   "1000:30000")
    return lo, hi


def parse_bearing_prior(range_prior: str | None, speed_prior: float | None,
                        height_prior: str | None, other_start: bool) -> Any:
    """``--range-prior``, ``--speed-prior`` and ``--height-prior`` as a bearing prior."""
    if range_prior is None and speed_prior is None and height_prior is None:
        return None
    if other_start:
        raise fail("--range-prior, --speed-prior and --height-prior start the track at the "
                   "first bearing; they cannot be used with --prior or --init-window")
    from ..filters import BearingPrior
    from ..filters.bearing_prior import (
        DEFAULT_HEIGHT,
        DEFAULT_RANGE,
        DEFAULT_SPEED,
        prior_problems,
    )

    texts = {"range": range_prior, "speed": speed_prior, "height": height_prior}
    given = tuple(n for n, v in texts.items() if v is not None)
    lo, hi = DEFAULT_RANGE if range_prior is None else _interval(range_prior, "--range-prior")
    height = DEFAULT_HEIGHT if height_prior is None else _interval(height_prior, "--height-prior")
    speed = DEFAULT_SPEED if speed_prior is None else float(speed_prior)
    for name, expected in prior_problems((lo, hi), speed, height).items():
        raise fail(f"--{name}-prior {texts[name]!r}: {expected}")
    return BearingPrior(lo, hi, speed, height, given)


def component_settings(filter_name: str, component: str, smooth: bool = False,
                       model_q: str | None = None, transition: str | None = None,
                       turn_rate: str | None = None, turn_rate_noise: str | None = None
                       ) -> dict[str, object]:
    """Give the filter's settings from ``--component``, ``--smooth`` and the IMM's options."""
    from ..filters.gaussian_sum import COMPONENTS

    if component not in COMPONENTS:
        raise fail(f"--component {component!r}: expected one of {', '.join(COMPONENTS)}")
    if filter_name not in ("imm", "mmpf") and (model_q, transition, turn_rate) != (None,) * 3:
        raise fail("--model-q, --transition and --turn-rate apply only to --filter imm and mmpf")
    if filter_name != "imm" and turn_rate_noise is not None:
        raise fail("--turn-rate-noise applies only to --filter imm")
    if filter_name not in ("gsf", "imm"):
        if component != "ekf":
            raise fail("--component applies only to --filter gsf and imm (their component filter)")
        if filter_name != "mmpf":
            return {"history": True} if smooth and filter_name == "pf" else {}
    out: dict[str, object] = {} if filter_name == "mmpf" else {"component": component}
    if smooth:  # (gsf, imm or mmpf here)
        out["history"] = True  # the sums, the models or the clouds, for the smoother
    if model_q is not None:
        out["model_q"] = numbers(model_q, f"--model-q {model_q!r}: expected accelerations "
                                          "(m/s^2) separated by commas")
    if turn_rate is not None:
        out["turn_rates"] = [] if turn_rate.strip().lower() == "none" else numbers(
            turn_rate, f"--turn-rate {turn_rate!r}: expected turn rates (deg/s) separated by "
                       "commas, or none", lambda v: math.radians(float(v)))
    if turn_rate_noise is not None:
        out["rate_noise"] = rate_noise_setting(turn_rate_noise)
    if transition is not None:
        out["transition"] = [numbers(row, f"--transition {transition!r}: expected rows of "
                                          "probabilities, e.g. 0.95,0.05;0.05,0.95")
                             for row in transition.split(";")]
    return out


def rate_noise_setting(text: str) -> float | None:
    """Give ``--turn-rate-noise`` in rad/s per sqrt(s) (``None``: no estimated-rate turn)."""
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise fail(f"--turn-rate-noise {text!r}: expected a turn rate's random walk >= 0 "
                   "(deg/s per sqrt(s)), or none")
    return math.radians(value)


def smoothed_track(tr: Any, lag: int | None, keep_history: bool = False) -> Any:
    """Attach the smoothed track (``--smooth``, ``--lag``) to ``tr.extra.smoothed``."""
    from ..filters import smooth

    if lag is not None and lag < 0:
        raise fail(f"--lag {lag}: expected a number of updates >= 0")
    if lag is not None and tr.filter_name in ("pf", "mmpf", "imm"):
        raise fail(f"--lag: --filter {tr.filter_name}'s smoother is fixed-interval (--smooth); "
                   "the fixed-lag smoother is for the Gaussian filters (ekf, ukf, ckf, gsf)")
    tr.extra.smoothed = smooth(tr, lag=lag)
    if not keep_history:
        tr.extra.history = None
    return tr


def check_sums(sums: bool, filter_name: str, as_json: bool, follow: bool) -> None:
    """Refuse ``--sums`` where there is no Gaussian sum or no track JSON to put it in."""
    if not sums:
        return
    if filter_name != "gsf":
        raise fail(f"--sums: --filter {filter_name} keeps no Gaussian sum; it applies to "
                   "--filter gsf")
    if not as_json or follow:
        raise fail("--sums adds the Gaussian sums to the track's JSON: give --json (without "
                   "--follow, whose lines carry the latest answer only)")


#: Fewest particles ``tma track`` takes: one more than a 3-D state's six values, the fewest
#: whose cloud can have a non-singular covariance.
MIN_PARTICLES = 7
#: The flags of `tma track` for the library parameters its errors name.
TRACK_FLAGS = {"q": "--q", "dim": "--dim", "prior": "--prior", "prior_std": "--prior-std",
               "prior_time": "--prior-time", "max_relative_std": "--start-std",
               "tracker": "--filter",
               "q_density": "--q-density", "bearing_prior": "--range-prior",
               "init_window": "--init-window", "model_q": "--model-q", "turn_rates": "--turn-rate",
               "rate_noise": "--turn-rate-noise", "transition": "--transition"}


def flagged(message: str) -> str:
    """Name the flag in a library message that starts with its keyword (``model_q must ...``)."""
    keyword, _, rest = message.partition(" ")
    return f"{TRACK_FLAGS[keyword]}: {rest}" if keyword in TRACK_FLAGS and rest else message


def tracking_failure(e: Any) -> typer.Exit:
    """Translate a :class:`tmakit.tracking.TrackingError` into `tma track`'s words (its flags)."""
    from ..tracking import MissingNuisanceError

    names = dict(TRACK_FLAGS)
    if isinstance(e, MissingNuisanceError):
        names["nuisance"] = ("nuisance={...}; --nuisance " + ",".join(f"{n}=..." for n in e.names))
    message = e.render(names)
    if e.parameter in names and message.startswith(e.parameter):  # "init_window: expected ..."
        message = names[e.parameter] + message.removeprefix(e.parameter)
    return fail(message)


def check_track_options(output: Path | None, plot: Path | None, force: bool,
                        filter_name: str, particles: int | None, seed: int | None,
                        ellipses: int, rows: int, shown: tuple[bool, bool, bool, str]
                        ) -> tuple[Path | None, Path | None]:
    """Refuse bad ``tma track`` options before reading (``shown``: sums, json, follow, units)."""
    from .. import tracking
    from ..filters import FILTERS

    check_particles(particles)
    if particles is not None and particles < MIN_PARTICLES:
        raise fail(f"--particles {particles}: a cloud of fewer than {MIN_PARTICLES} particles "
                   "cannot span the target's state (4 or 6 values), so its covariance is "
                   "singular; use hundreds or more")
    output, plot = check_outputs([("-o", output, "table"), ("--plot", plot, "picture")], force)
    if filter_name not in FILTERS:
        raise fail(f"--filter {filter_name!r}: expected one of {', '.join(sorted(FILTERS))}")
    random_filters = tracking.random_filters()
    for option, value in (("--particles", particles), ("--seed", seed)):
        if value is not None and filter_name not in random_filters:
            raise fail(f"{option} applies only to the particle filter"
                       f"{'s' if len(random_filters) > 1 else ''} "
                       f"({', '.join(random_filters) or 'none registered'}), not to "
                       f"{filter_name}")
    if ellipses < 0 or rows < 1:
        raise fail("--ellipses must be 0 or more and --rows 1 or more")
    if seed is not None and seed < 0:  # numpy's words would not name the option
        raise fail(f"--seed {seed}: expected a whole number >= 0")
    check_sums(shown[0], filter_name, shown[1], shown[2])
    check_units(shown[3])
    return output, plot


def parse_prior(prior: str | None, prior_std: str | None, nuisance: str | None,
                init_window: int | None) -> tuple[dict[str, float] | None, ...]:
    """``--prior``, ``--prior-std`` and ``--nuisance`` by name, checked to go together."""
    prior_mean = parse_assignments(prior, "--prior") or None
    prior_sd = parse_assignments(prior_std, "--prior-std") or None
    known = parse_assignments(nuisance, "--nuisance") or None
    if (prior_mean is None) != (prior_sd is None):
        raise fail("--prior and --prior-std go together (the state and its standard "
                   "deviations, by name)")
    if known is not None and prior_mean is None:
        raise fail("--nuisance goes with --prior; a batch start estimates the nuisance "
                   "values itself")
    if prior_mean is not None and init_window is not None:
        raise fail("--init-window chooses the batch start; it cannot be used with --prior")
    return prior_mean, prior_sd, known


#: ``--format`` of standard input, and the suffix its snapshot gets.
STDIN_SUFFIXES = {"rep": ".rep", "csv": ".csv", "nmea": ".nmea", "wide": ".csv"}
_BINARY = (".parquet", ".pq")


class _Source:
    """One growing source: a file read from an offset, or standard input by a reader thread."""

    def __init__(self, path: Path, snapshot: Path) -> None:
        self.path, self.snapshot = path, snapshot
        self.offset = 0
        self.tail = b""
        self.ended = False
        self.lines: queue.Queue[bytes | None] | None = None
        if str(path) == "-":
            self.lines = queue.Queue()
            threading.Thread(target=self._read_stdin, args=(sys.stdin.buffer,), daemon=True).start()
        snapshot.write_bytes(b"")

    def _read_stdin(self, stream: BinaryIO) -> None:
        assert self.lines is not None
        for line in iter(stream.readline, b""):
            self.lines.put(line)
        self.lines.put(None)  # end of input

    def new_bytes(self) -> bytes:
        """Give the bytes that arrived since the last look (whole lines and a partial tail)."""
        if self.lines is not None:
            got = []
            while not self.ended and not self.lines.empty():  # (this thread alone takes)
                item = self.lines.get_nowait()
                self.ended = item is None  # the end of input
                got.append(item or b"")
            return b"".join(got)
        try:
            size = self.path.stat().st_size
        except FileNotFoundError:
            return b""
        if size < self.offset:  # rewritten or rotated: start again
            self.offset, self.tail = 0, b""
            self.snapshot.write_bytes(b"")
        if size == self.offset:
            return b""
        with open(self.path, "rb") as f:
            f.seek(self.offset)
            data = f.read(size - self.offset)
        self.offset += len(data)
        return data

    def poll(self) -> bool:
        """Copy the complete lines that arrived into the snapshot; whether there were any."""
        data = self.tail + self.new_bytes()
        cut = data.rfind(b"\n") + 1
        if self.ended and cut < len(data):  # the last line of an input that ended
            data, cut = data + b"\n", len(data) + 1
        whole, self.tail = data[:cut], data[cut:]
        if not whole:
            return False
        with open(self.snapshot, "ab") as f:
            f.write(whole)
        return True


def own_track_only(path: Path, fmt: str | None) -> bool:
    """Whether a file is read as a GPX or NMEA own track (no measurements of its own)."""
    from ..io.formats import find_format

    found = find_format(path, fmt, reading=True)
    return found is not None and found.name in ("gpx", "nmea")


class GrowingFiles:
    """Snapshots of growing text files (their complete lines), in a folder."""

    def __init__(self, paths: list[Path], fmt: str | None, folder: Path) -> None:
        names: set[str] = set()
        self.sources = []
        for k, path in enumerate(paths):
            if str(path) == "-":
                if fmt not in STDIN_SUFFIXES:
                    raise fail("--follow -: standard input needs --format, one of "
                               + ", ".join(STDIN_SUFFIXES))
                name = f"stdin{STDIN_SUFFIXES[fmt]}"
            else:
                if path.is_dir():
                    raise fail(f"{path}: is a folder, not a measurement file")
                if path.suffix.lower() in _BINARY or fmt == "parquet":
                    raise fail(f"--follow {path}: follows text files (REP/DSF, NMEA, CSV), "
                               "not Parquet")
                name = path.name
            if own_track_only(path if str(path) != "-" else Path(name), fmt):
                raise fail(f"--follow {path}: a GPX or NMEA own track gives the sensor's "
                           "positions only; follow the measurement log, whose mapping names "
                           "the track (tma track --follow LOG.csv --mapping MAP.toml, the "
                           "mapping's track = \"own.nmea\" read anew at each look)")
            if name in names:
                name = f"{k}-{name}"
            names.add(name)
            self.sources.append(_Source(path, folder / name))

    @property
    def snapshots(self) -> dict[Path, Path]:
        """The snapshot files, in the order of the files given, and the names given."""
        return {s.snapshot: Path("standard input") if str(s.path) == "-" else s.path
                for s in self.sources}

    @property
    def ended(self) -> bool:
        """Whether standard input (when read) has ended: nothing more will come."""
        return any(s.ended for s in self.sources if s.lines is not None)

    def poll(self) -> bool:
        """Take in what arrived; whether any snapshot gained complete lines."""
        return any([s.poll() for s in self.sources])  # (every source polled)


#: The shortest and longest wait between looks at a followed file (s): more often is a busy
#: loop, less often than a day is no following (and beyond time_t, an internal error).
FOLLOW_INTERVAL_S = (0.01, 86_400.0)


def watch(paths: list[Path], fmt: str | None, update: Callable[[dict[Path, Path]], bool],
           interval: float, max_updates: int | None, say: Any) -> None:
    """Run ``update`` on the snapshots each time the files grow, until told to stop."""
    from .guard import Terminated

    if not FOLLOW_INTERVAL_S[0] <= interval <= FOLLOW_INTERVAL_S[1]:
        raise fail(f"--interval {interval:g}: expected seconds within [{FOLLOW_INTERVAL_S[0]:g}, "
                   f"{FOLLOW_INTERVAL_S[1]:g}] (a day)")
    if max_updates is not None and max_updates < 1:
        raise fail(f"--max-updates {max_updates}: expected 1 or more")
    for p in paths:
        if str(p) != "-" and not p.exists():
            raise fail(f"{p}: no such file (--follow waits for a file to grow, not to appear)")
    updates = 0
    with tempfile.TemporaryDirectory(prefix="tma-follow-") as folder:
        growing = GrowingFiles(paths, fmt, Path(folder))
        try:
            while max_updates is None or updates < max_updates:
                if growing.poll():
                    try:
                        updates += bool(update(growing.snapshots))
                    except FollowEnded as e:
                        say.print(f"{e}: {updates + 1} update(s)")
                        break
                elif growing.ended:
                    say.print(f"standard input ended: {updates} update(s)")
                    break
                else:
                    time.sleep(interval)
        except (KeyboardInterrupt, Terminated):
            say.print(f"stopped after {updates} complete update(s); the files written are kept")
            raise
