"""The options of ``tma track``: parsed and checked before the file is read.

Its library errors are translated here into the flags that would fix them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

from .common import fail, parse_assignments

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
                          "MIN:MAX (m); default 500:50000 for --filter gsf")]
SpeedPriorOption = Annotated[float | None, typer.Option(
    "--speed-prior", help="start at the first bearing: the largest plausible speed (m/s, "
                          "course unknown); default 20")]
HeightPriorOption = Annotated[str | None, typer.Option(
    "--height-prior", help="start at the first bearing, 3-D: the emitter's height interval "
                           "MIN:MAX (m); default 0:12000")]
ComponentOption = Annotated[str, typer.Option(
    help="the component filter of gsf (the Gaussian sum) or imm: ekf, ukf or ckf "
         "(cubature)")]
ModelQOption = Annotated[str | None, typer.Option(
    "--model-q", help="--filter imm: acceleration std (m/s^2) of the manoeuvre models, "
                      "one value per model (comma-separated) beside the --q model; default "
                      "1.0")]
TurnRateOption = Annotated[str | None, typer.Option(
    "--turn-rate", help="--filter imm: turn rates (deg/s, comma-separated; counter-clockwise "
                        "positive, a right turn negative) of coordinated-turn models added "
                        "after the --model-q ones")]
PriorTimeOption = Annotated[float | None, typer.Option(
    help="time of the prior (s); default: the first measurement time")]
NuisanceOption = Annotated[str | None, typer.Option(
    help="known nuisance values with --prior, e.g. carrier=9.4e9 (Hz, dBW)")]
TransitionOption = Annotated[str | None, typer.Option(
    "--transition", help="--filter imm: the Markov matrix per step, rows (from) separated "
                         "by ';', e.g. 0.99,0.01;0.01,0.99 (the default for two models)")]
SmoothOption = Annotated[bool, typer.Option(
    "--smooth", help="also give the smoothed track (Rauch-Tung-Striebel for the Gaussian "
                     "filters and the Gaussian sum; backward simulation for pf)")]
LagOption = Annotated[int | None, typer.Option(
    help="a fixed-lag smoother (implies --smooth): each state given the data up to N "
         "updates after it")]

__all__ = ["TRACK_FLAGS", "FollowOption", "IntervalOption", "MaxUpdatesOption",
           "check_track_options", "component_settings", "parse_bearing_prior", "parse_prior",
           "parse_q", "smoothed_track", "tracking_failure"]

FollowOption = Annotated[bool, typer.Option(
    "--follow", help="keep tracking as the file grows (REP, NMEA, CSV; FILE - reads standard "
                     "input, with --format): one line per update, the outputs rewritten; "
                     "Ctrl-C or SIGTERM stops it")]
IntervalOption = Annotated[float, typer.Option(
    metavar="SECONDS", help="--follow: seconds between looks at the file")]
MaxUpdatesOption = Annotated[int | None, typer.Option(
    metavar="N", help="--follow: stop after N updates")]


def parse_q(text: str, dim: int, flag: str = "--q") -> list[float]:
    """Parse ``--q``: one number or per-axis numbers ``qx,qy[,qz]`` (m/s^2)."""
    try:
        return [float(p.strip()) for p in text.split(",")]
    except ValueError:
        unit = "m/s^2" if flag == "--q" else "m^2/s^3"
        raise fail(f"{flag} {text!r}: expected one number or {dim} numbers separated by "
                   f"commas ({unit} per axis, e.g. 0.01 or "
                   f"{','.join(['0.01'] * dim)})") from None


def _interval(text: str, flag: str) -> tuple[float, float]:
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise fail(f"{flag} {text!r}: expected MIN:MAX in metres, e.g. 1000:30000") from None
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
    from ..filters.bearing_prior import DEFAULT_HEIGHT, DEFAULT_RANGE, DEFAULT_SPEED

    given = tuple(n for n, v in (("range", range_prior), ("speed", speed_prior),
                                 ("height", height_prior)) if v is not None)
    lo, hi = DEFAULT_RANGE if range_prior is None else _interval(range_prior, "--range-prior")
    height = DEFAULT_HEIGHT if height_prior is None else _interval(height_prior,
                                                                   "--height-prior")
    if not (0 < lo < hi):
        raise fail(f"--range-prior {range_prior!r}: expected 0 < MIN < MAX (m)")
    if height[0] > height[1]:
        raise fail(f"--height-prior {height_prior!r}: expected MIN <= MAX (m)")
    speed = DEFAULT_SPEED if speed_prior is None else float(speed_prior)
    if not (speed > 0 and speed < 1e4):
        raise fail(f"--speed-prior {speed_prior}: expected a speed > 0 m/s (and below "
                   "10 km/s)")
    return BearingPrior(lo, hi, speed, height, given)


def component_settings(filter_name: str, component: str, smooth: bool = False,
                       model_q: str | None = None, transition: str | None = None,
                       turn_rate: str | None = None) -> dict[str, object]:
    """Give the filter's settings from ``--component``, ``--smooth`` and the IMM's options."""
    from ..filters.gaussian_sum import COMPONENTS

    if component not in COMPONENTS:
        raise fail(f"--component {component!r}: expected one of {', '.join(COMPONENTS)}")
    if filter_name != "imm" and (model_q, transition, turn_rate) != (None, None, None):
        raise fail("--model-q, --transition and --turn-rate apply only to --filter imm")
    if filter_name not in ("gsf", "imm"):
        if component != "ekf":
            raise fail("--component applies only to --filter gsf and imm (their component "
                       "filter)")
        return {"history": True} if smooth and filter_name == "pf" else {}
    out: dict[str, object] = {"component": component}
    if model_q is not None:
        try:
            out["model_q"] = [float(v) for v in model_q.split(",")]
        except ValueError:
            raise fail(f"--model-q {model_q!r}: expected accelerations (m/s^2) separated by "
                       "commas") from None
    if turn_rate is not None:
        try:
            out["turn_rates"] = [math.radians(float(v)) for v in turn_rate.split(",")]
        except ValueError:
            raise fail(f"--turn-rate {turn_rate!r}: expected turn rates (deg/s) separated by "
                       "commas") from None
    if transition is not None:
        try:
            out["transition"] = [[float(v) for v in row.split(",")]
                                 for row in transition.split(";")]
        except ValueError:
            raise fail(f"--transition {transition!r}: expected rows of probabilities, "
                       "e.g. 0.95,0.05;0.05,0.95") from None
    return out


def smoothed_track(tr: Any, lag: int | None) -> Any:
    """Attach the smoothed track (``--smooth``, ``--lag``) to ``tr.extra.smoothed``."""
    from ..filters import smooth

    if lag is not None and lag < 0:
        raise fail(f"--lag {lag}: expected a number of updates >= 0")
    if lag is not None and tr.filter_name == "pf":
        raise fail("--lag: the particle filter's smoother is fixed-interval (--smooth); the "
                   "fixed-lag smoother is for the Gaussian filters (ekf, ukf, ckf, gsf)")
    if tr.filter_name == "imm":
        raise fail("--smooth/--lag: there is no smoother for --filter imm (its combined "
                   "estimate is not one Gaussian model's); smooth ekf, ukf, ckf, gsf or pf")
    tr.extra.smoothed = smooth(tr, lag=lag)
    tr.extra.history = None
    return tr


#: The flags of `tma track` for the library parameters its errors name.
#: Fewest particles ``tma track`` takes: one more than a 3-D state's six values, the fewest
#: whose cloud can have a non-singular covariance.
MIN_PARTICLES = 7

TRACK_FLAGS = {"q": "--q", "dim": "--dim", "prior": "--prior", "prior_std": "--prior-std",
               "max_relative_std": "--start-std", "tracker": "--filter",
               "q_density": "--q-density", "bearing_prior": "--range-prior"}


def tracking_failure(e: Any) -> typer.Exit:
    """Translate a :class:`tmakit.tracking.TrackingError` into `tma track`'s words (its flags)."""
    from ..tracking import MissingNuisanceError

    names = dict(TRACK_FLAGS)
    if isinstance(e, MissingNuisanceError):
        names["nuisance"] = ("nuisance={...}; --nuisance "
                             + ",".join(f"{n}=..." for n in e.names))
    return fail(e.render(names))


def check_track_options(output: Path | None, plot: Path | None, force: bool,
                        filter_name: str, particles: int | None, seed: int | None,
                        ellipses: int, rows: int, inputs: Sequence[object] = ()
                        ) -> tuple[Path | None, Path | None]:
    """Refuse bad ``tma track`` options before reading the file."""
    from .. import tracking
    from ..filters import FILTERS
    from .outputs import check_outputs, check_particles

    check_particles(particles)
    if particles is not None and particles < MIN_PARTICLES:
        raise fail(f"--particles {particles}: a cloud of fewer than {MIN_PARTICLES} particles "
                   "cannot span the target's state (4 or 6 values), so its covariance is "
                   "singular; use hundreds or more")
    output, plot = check_outputs([("-o", output, "table"), ("--plot", plot, "picture")], force,
                                 [p for p in inputs if isinstance(p, Path)])
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
