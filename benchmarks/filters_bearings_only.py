"""Consistency and accuracy of the EKF, UKF and particle filter on bearings-only-2d.

The scenario (``src/tmakit/scenario/builtin/bearings-only-2d.toml``): a constant-velocity target at
about 10 km, an observer zig-zagging in five legs, one bearing per second with 1° noise for
600 s — 600 updates.  Filters run with q = 0 (the target really moves at constant velocity).

**Starts** (``--start``, one or both, in the order given; default ``prior``):

* ``prior``: every run draws new measurement noise and a prior mean ``m0 ~ N(x_true(0), P0)``
  (the truth is used only to sample a prior that is consistent with ``P0``); all filters see
  the same data and priors, and update at every measurement time from 1 s on.
  ``P0 = diag(s_p^2, s_p^2, s_v^2, s_v^2)`` for each ``--position-std`` s_p (m, per axis;
  default 500 m and 2 km: 5 % and 20 % of the initial range) and ``--velocity-std`` s_v (m/s,
  default 5: course unknown, speed up to about 10 m/s).  Data and priors come from
  ``numpy.random.default_rng([seed, int(s_p)])``.
* ``batch``: every filter starts the way ``tma track`` does by default, with no guess:
  :func:`tmakit.track` without a prior — a batch ML estimate over the shortest initial window
  that converges with every state component observable, has a position std below 25 % of the
  range, and is confirmed by the innovations of the updates that follow it (a rejected start
  is replaced by a longer window; ``docs/tracking.md``).  The track begins with that estimate
  at the window's last time, which differs from run to run, and the filter updates at every
  later time.  All filters see the same data, drawn anew (``default_rng([seed, 0])``); the
  innovation test runs the filter itself, so a filter's start can differ from another's.  The
  iterated EKF is not a ``tma track`` filter and is skipped.

**Consistency.**  NEES per measurement time, averaged over the runs that are tracking then:
all of them with a prior; with a batch start those that have started (the start estimate's
own NEES included at its time).  For a consistent filter the mean of n independent NEES
values of a 4-state is distributed as chi2(4n)/n, so its 95 % band is
``[chi2.ppf(0.025, 4n), chi2.ppf(0.975, 4n)] / n`` ([3.46, 4.57] for n = 100), computed at
each time for the number of runs present.  The band holds per time; successive updates share
their errors (q = 0), so the fraction of times inside it varies much more from seed to seed
than the 95 % it has on average, and the overall mean (printed too) has no band of its own.
With a batch start the start times are summarised below the table, with the mean NEES of the
start estimates themselves (band as for n = runs).

**Accuracy.**  Final position RMSE over the runs (every track ends at 600 s) against a bound
on the final position error:

* prior start: the posterior CRB of the same data and prior along the true trajectory
  (:func:`tmakit.bounds.deterministic_pcrb`, the Tichavský recursion of
  Hurtado & Nehorai (2008), eqs. 10-11; with q = 0 it equals the batch CRLB of the bearings
  plus the prior's information — the bound for a fixed truth and a prior mean drawn around it);
* batch start: the batch CRLB of all of the run's bearings with no prior
  (:func:`tmakit.bounds.crlb` of the scenario at its truth, position covariance at 600 s).  The
  start estimate is made from the window's bearings, so giving the filter's bound its start
  covariance as a prior would count those data twice.  Every run has the same geometry, so
  one bound serves all runs.

Also the particle filter's count of runs ending more than 1 km off, over the first
``--outlier-runs`` runs.

The iterated EKF (``iekf``, 5 linearisations) is shown beside the EKF with a prior:
relinearising the update is the usual first remedy for an EKF that is inconsistent after a
wide prior; it does not fix it here (see the output).

    PYTHONPATH=src python benchmarks/filters_bearings_only.py --runs 100 --seed 0
        [--start prior batch] [--particles 10000] [--pf-runs N] [--position-std 500 2000]
        [--velocity-std 5] [--filters ekf,iekf,ukf,pf]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

import tmakit as tk
from tmakit.bounds import crlb, deterministic_pcrb
from tmakit.data import MeasurementSet
from tmakit.filters import (
    FILTERS,
    ExtendedKalmanFilter,
    ParticleFilter,
    Track,
    TrackingFilter,
)

#: Times (s) at which the mean NEES is printed.
SHOW_AT = (1, 10, 60, 120, 240, 300, 360, 480, 600)
#: The filter state [x, y, vx, vy] within the scenario's ENU 6-vector.
STATE = [0, 1, 3, 4]


@dataclass
class Start:
    """One way of starting the filters: a heading, the bound on the final position RMS error
    (m), the runs' data, and ``track(filter, run)``, the track of one filter on one run's data
    (``None``: the filter cannot start this way)."""

    heading: str
    bound_name: str
    bound: float
    data: list[MeasurementSet]
    track: Callable[[str, int], Track | None]


@dataclass
class Evaluation:
    """One filter over the runs: NEES per run and measurement time (R, K), NaN before the
    run's track begins; final position errors (R, 2) m; the first time of each track (R,) s
    and whether its first estimate is closer to the observer than the truth; how many batch
    starts the innovation test rejected; the wall time (s)."""

    nees: np.ndarray
    final: np.ndarray
    starts: np.ndarray
    short: np.ndarray
    rejected: int
    seconds: float


def num(value: float, width: int, decimals: int = 2) -> str:
    """A number in ``width`` characters: fixed-point, or 1.2e+07 when it does not fit; '-'
    for NaN (no run tracking yet)."""
    if np.isnan(value):
        return f"{'-':>{width}}"
    text = f"{value:{width}.{decimals}f}"
    return text if len(text) <= width else f"{value:{width}.1e}"


def band(n: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
    """95 % band of the mean of ``n`` independent NEES values of a 4-state (chi2(4n)/n)."""
    n = np.asarray(n, dtype=float)
    return (stats.chi2.ppf(0.025, 4 * n) / n, stats.chi2.ppf(0.975, 4 * n) / n)


def run_rng(seed: int, run: int) -> np.random.Generator:
    """The particle filter's generator for one run (the same with either start)."""
    return np.random.default_rng([seed, run])


def prior_filter(name: str, mean0: np.ndarray, p0: np.ndarray, particles: int,
                 rng: np.random.Generator) -> TrackingFilter:
    """A filter of :data:`tmakit.filters.FILTERS` (or ``iekf``, the EKF with 5 iterations)
    started from the prior N(mean0, p0) at t = 0."""
    if name == "pf":
        return ParticleFilter(mean0, p0, 0.0, particles=particles, rng=rng)
    if name == "iekf":
        return ExtendedKalmanFilter(mean0, p0, 0.0, iterations=5)
    return FILTERS[name](mean0, p0, 0.0)


def prior_start(scn, s_p: float, args: argparse.Namespace) -> Start:
    """Runs with a prior of position std ``s_p`` (m) per axis around the truth at t = 0."""
    x_true0 = scn.target_states([0.0])[0][STATE]
    p0 = np.diag([s_p**2, s_p**2, args.velocity_std**2, args.velocity_std**2])
    rng = np.random.default_rng([args.seed, int(s_p)])
    chol = np.linalg.cholesky(p0)
    data, means = [], []
    for _ in range(args.runs):
        data.append(scn.simulate(rng))
        means.append(x_true0 + chol @ rng.standard_normal(4))
    bound = deterministic_pcrb(scn, x_true0, p0, 0.0, q=0.0)

    def track(name: str, r: int) -> Track:
        return prior_filter(name, means[r], p0, args.particles,
                            run_rng(args.seed, r)).run(data[r])

    return Start(f"prior start: P0 = diag({s_p:g}^2, {s_p:g}^2, {args.velocity_std:g}^2, "
                 f"{args.velocity_std:g}^2) (m, m/s), mean ~ N(truth at t = 0, P0)",
                 "PCRB", float(bound.position_rms[-1]), data, track)


def batch_start(scn, args: argparse.Namespace) -> Start:
    """Runs started as ``tma track`` starts by default (:func:`tmakit.track`, no prior)."""
    rng = np.random.default_rng([args.seed, 0])
    data = [scn.simulate(rng) for _ in range(args.runs)]
    _, cov = crlb(scn).state_covariance(float(data[0].time.max()))

    def track(name: str, r: int) -> Track | None:
        if name not in FILTERS:
            return None
        return tk.track(data[r], name, q=0.0,
                        particles=args.particles if name == "pf" else None,
                        rng=run_rng(args.seed, r))

    return Start("batch start as `tma track` (no guess): tmakit.track, start std 25 %, "
                 "innovation test", "CRLB", float(np.sqrt(cov[0, 0] + cov[1, 1])), data, track)


def evaluate(start: Start, name: str, runs: int, scn, grid: np.ndarray) -> Evaluation | None:
    """Run one filter over the first ``runs`` runs of ``start`` and collect its errors on the
    measurement times ``grid`` (s); ``None`` if the filter cannot start this way."""
    nees = np.full((runs, grid.size), np.nan)
    final = np.empty((runs, 2))
    starts = np.empty(runs)
    short = np.empty(runs, dtype=bool)
    rejected = 0
    began = time.perf_counter()
    for r in range(runs):
        tr = start.track(name, r)
        if tr is None:
            return None
        idx = np.searchsorted(grid, tr.times)
        if not np.allclose(grid[np.minimum(idx, grid.size - 1)], tr.times):
            raise RuntimeError(f"{name}, run {r}: track times off the measurement times")
        truth = scn.target_states(tr.times)[:, STATE]
        nees[r, idx] = tr.nees(truth)
        final[r] = tr.states[-1, :2] - truth[-1, :2]
        starts[r] = tr.times[0]
        meas = start.data[r]
        observer = meas.sensor_state[np.argmin(np.abs(meas.time - tr.times[0])), :2]
        short[r] = (np.linalg.norm(tr.states[0, :2] - observer)
                    < np.linalg.norm(truth[0, :2] - observer))
        rejected += len((tr.extra.get("start") or {}).get("rejected", ()))
    return Evaluation(nees, final, starts, short, rejected, time.perf_counter() - began)


def table_row(name: str, ev: Evaluation, grid: np.ndarray, bound: float,
              outlier_runs: int) -> str:
    """One line of the table: band, NEES (overall, share in band, at SHOW_AT), final error."""
    runs = ev.nees.shape[0]
    present = np.sum(~np.isnan(ev.nees), axis=0)
    tracking = present > 0
    with np.errstate(invalid="ignore"):
        avg = np.where(tracking, np.nansum(ev.nees, axis=0) / np.maximum(present, 1), np.nan)
    lo, hi = band(present[tracking])
    inside = float(np.mean((avg[tracking] >= lo) & (avg[tracking] <= hi)))
    all_lo, all_hi = band(runs)
    miss = np.linalg.norm(ev.final, axis=1)
    rmse = float(np.sqrt(np.mean(miss**2)))
    far = f"{int(np.sum(miss[:outlier_runs] > 1000.0))}/{min(outlier_runs, runs)}"
    at = [avg[int(np.argmin(np.abs(grid - t)))] for t in SHOW_AT]
    return (f"{name:<6} {runs:>4} [{float(all_lo):5.2f},{float(all_hi):5.2f}] "
            f"{num(float(np.nanmean(ev.nees)), 8)} {100 * inside:6.0f}%  "
            + " ".join(num(v, 6) for v in at)
            + f"  {num(rmse, 7, 1)} {num(rmse / bound, 6)} {far:>5} {ev.seconds:5.1f}")


def start_line(name: str, ev: Evaluation, grid: np.ndarray) -> str:
    """When the tracks began and how consistent they were: the start estimates (by whether
    their range is short or long), the runs once all are tracking, the per-run means."""
    runs = ev.nees.shape[0]
    at_start = ev.nees[np.arange(runs), np.searchsorted(grid, ev.starts)]
    lo, hi = band(runs)
    latest = float(np.max(ev.starts))
    avg = np.mean(ev.nees[:, grid >= latest], axis=0)
    inside = float(np.mean((avg >= lo) & (avg <= hi)))
    per_run = np.sort(np.nanmean(ev.nees, axis=1))
    top = min(5, runs - 1)  # the largest per-run means, and the mean of the others
    q10, q50, q90 = np.percentile(ev.starts, [10, 50, 90])
    split = "; ".join(f"{what} in {int(np.sum(sel))} runs (their start NEES "
                      f"{np.mean(at_start[sel]):.2f})"
                      for what, sel in (("short", ev.short), ("long", ~ev.short)) if np.any(sel))
    return (f"{name:<6} start t (s): min {np.min(ev.starts):.0f}, 10 % {q10:.0f}, median "
            f"{q50:.0f}, mean {np.mean(ev.starts):.1f}, 90 % {q90:.0f}, max {latest:.0f}; "
            f"rejected starts {ev.rejected}; NEES of the start estimates {np.mean(at_start):.2f}"
            f" (band [{float(lo):.2f}, {float(hi):.2f}]); all runs tracking from {latest:.0f} s "
            f"on: mean NEES {np.mean(avg):.2f}, {100 * inside:.0f}% of times in band\n"
            f"{'':<6} start range {split}; per-run mean NEES: median {np.median(per_run):.2f}, "
            f"largest {', '.join(f'{v:.1f}' for v in per_run[-top:][::-1])}, mean of the "
            f"others {np.mean(per_run[:-top]):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100, help="Monte Carlo runs per filter")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--start", nargs="+", choices=("prior", "batch"), default=["prior"],
                        help="how the filters start: a prior around the truth (one "
                             "configuration per --position-std), or tma track's batch start")
    parser.add_argument("--particles", type=int, default=10000)
    parser.add_argument("--pf-runs", type=int, default=None,
                        help="runs for the particle filter (default: --runs)")
    parser.add_argument("--outlier-runs", type=int, default=50,
                        help="runs over which the PF's > 1 km endings are counted")
    parser.add_argument("--position-std", type=float, nargs="+", default=[500.0, 2000.0],
                        help="prior position std per axis (m), one configuration each")
    parser.add_argument("--velocity-std", type=float, default=5.0,
                        help="prior velocity std per axis (m/s)")
    parser.add_argument("--filters", default="ekf,iekf,ukf,pf")
    args = parser.parse_args()
    if args.runs < 2:
        parser.error("--runs must be at least 2")
    names = args.filters.split(",")
    unknown = sorted(set(names) - set(FILTERS) - {"iekf"})
    if unknown:
        parser.error(f"--filters: unknown {', '.join(unknown)}; expected names from "
                     f"{', '.join(sorted(FILTERS))}, iekf")
    pf_runs = args.runs if args.pf_runs is None else min(args.pf_runs, args.runs)

    scn = tk.load_scenario("bearings-only-2d")
    grid = np.unique(scn.simulate(0, noise=False).time)
    print(f"bearings-only-2d: {scn.description}")
    print(f"runs {args.runs} (particle filter {pf_runs}, {args.particles} particles), seed "
          f"{args.seed}, q = 0; see --help")
    starts = [s for mode in dict.fromkeys(args.start)
              for s in ([prior_start(scn, s_p, args) for s_p in args.position_std]
                        if mode == "prior" else [batch_start(scn, args)])]
    for start in starts:
        print(f"\n{start.heading}; final position {start.bound_name} at {grid[-1]:g} s "
              f"{start.bound:.1f} m")
        print(f"{'filter':<6} {'runs':>4} {'band 95%':>13} {'NEES avg':>8} {'in band':>7}  "
              + " ".join(f"{'t=' + str(t):>6}" for t in SHOW_AT)
              + f"  {'RMSE m':>7} {'/' + start.bound_name:>6} {'>1km':>5} {'s':>5}")
        varying = []
        for name in names:
            ev = evaluate(start, name, pf_runs if name == "pf" else args.runs, scn, grid)
            if ev is None:
                print(f"{name:<6} (not a `tma track` filter: prior start only)")
                continue
            print(table_row(name, ev, grid, start.bound, args.outlier_runs))
            if np.any(ev.starts > grid[0]):
                varying.append(start_line(name, ev, grid))
        if varying:
            print("\n".join(varying))
    print("\nNEES avg: mean NEES over all runs and times tracked; in band: share of the "
          "measurement times at which the mean NEES of the runs tracking lies in the band for "
          "that number of runs (band 95%: for all runs); t=...: mean NEES at t s ('-': no run "
          "tracking yet); RMSE: final position RMSE; >1km: runs ending more than 1 km off "
          f"(first {args.outlier_runs} runs); s: wall time of the runs (batch start included).")


if __name__ == "__main__":
    main()
