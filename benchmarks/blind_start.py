"""Blind-start benchmark: does the batch ML estimator find the global optimum with no guess?

Requirement: at least 99.5 % of 1000 random observable geometries (target within 20 km,
speed ≤ 40 m/s, one manoeuvring sensor, random mixes of bearing, frequency and power; see
``benchmarks/geometries.py``) reach the global optimum without an initial guess.

For every geometry ``i`` the generator ``numpy.random.default_rng([seed, i])`` draws an
observable geometry (:func:`geometries.observable_geometry`) and then its noise
(``Scenario.simulate`` with the same generator), so any geometry can be rerun alone with
``--index i``.  The data are fitted twice: blind (``estimate(meas, motion)``, starting points
from the likelihood grid) and started at the truth (``init=truth``).  The blind fit *reaches
the global optimum* when ``chi2_blind <= chi2_truth * (1 + 1e-6)``.  The relative tolerance
1e-6 is the numerical floor, not a slack: frequencies of GHz carriers held in doubles
(~16 significant digits, residuals of a few Hz on 1e9-1e10 Hz) make the cost reproducible
only to about 1e-8 relative, so two fits at the same optimum can differ by that much; any
distinct local minimum costs far more than 1e-6 relative.

Run::

    PYTHONPATH=src python benchmarks/blind_start.py --geometries 1000 --seed 0

It prints the success rate with its 95 % Clopper–Pearson interval, how many grid starts were
used, the median and 95th-percentile time of the blind solve, the kind mixes of failures and,
for each failure, where it went wrong (the grid's best candidate, the outcome of every grid
start, and a rerun with a denser grid).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import beta

try:
    import tmakit  # noqa: F401
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))

from geometries import observable_geometry, position_std

from tmakit.batch import estimate
from tmakit.batch.init import GridSettings, best_starts
from tmakit.batch.solver import VarProProblem
from tmakit.data import MeasurementSet
from tmakit.observation import ObservationModel
from tmakit.scenario import Scenario

RELATIVE_TOLERANCE = 1e-6
"""chi2_blind may exceed chi2_truth by this fraction (the numerical floor of the cost)."""

DENSE_GRID = GridSettings(n_ranges=20, n_bearings=24, speeds=(0.0, 5.0, 10.0, 20.0, 40.0,
                                                              80.0, 150.0, 450.0),
                          n_courses=16, max_rows=60, starts=12)
"""A denser grid used to rerun failures."""


@dataclass
class Outcome:
    """One geometry's blind and truth-started fits."""

    index: int
    kinds: tuple[str, ...]
    range0: float
    closest: float
    speed: float
    position_std: float
    chi2_blind: float
    chi2_truth: float
    dof: int
    starts: int
    seconds: float
    status: str
    iterations: int
    position_error: float
    notes: list[str] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return bool(self.chi2_blind <= self.chi2_truth * (1.0 + RELATIVE_TOLERANCE))


def geometry(seed: int, index: int) -> tuple[Scenario, np.random.Generator]:
    """The ``index``-th observable geometry of ``seed`` and the generator for its noise."""
    rng = np.random.default_rng([seed, index])
    return observable_geometry(rng), rng


def run_one(seed: int, index: int) -> tuple[Outcome, Scenario, MeasurementSet]:
    """Draw, simulate and fit geometry ``index``; the outcome, scenario and measurements."""
    scn, rng = geometry(seed, index)
    meas = scn.simulate(rng)
    opts = scn.measurement_options
    t0 = time.perf_counter()
    blind = estimate(meas, scn.motion, options=opts)
    seconds = time.perf_counter() - t0
    truth = estimate(meas, scn.motion, init=scn.truth, options=opts)
    t_mid = 0.5 * sum(scn.time_span())
    times = np.linspace(*scn.time_span(), 200)
    rel = scn.target_states(times)[:, :2] - scn.sensors["sensor"].states(times)[:, :2]
    est_pos = scn.motion.states(blind.estimate, np.array([t_mid]))[0, :2]
    true_pos = scn.target_states([t_mid])[0, :2]
    return Outcome(index, tuple(scn.kinds), float(np.hypot(scn.truth["x"], scn.truth["y"])),
                   float(np.linalg.norm(rel, axis=1).min()),
                   float(np.hypot(scn.truth["vx"], scn.truth["vy"])),
                   position_std(scn), blind.chi2, truth.chi2, blind.dof,
                   blind.starts, seconds, blind.status, blind.iterations,
                   float(np.linalg.norm(est_pos - true_pos))), scn, meas


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper–Pearson) confidence interval for a binomial proportion ``k / n``."""
    a = 1.0 - level
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def analyse_failure(scn: Scenario, meas: MeasurementSet, out: Outcome) -> list[str]:
    """Where a blind fit went wrong: every grid start fitted on its own (through the public
    ``estimate(..., init=start)``), and a rerun with a denser grid."""
    opts = scn.measurement_options
    problem = VarProProblem(ObservationModel(meas, scn.motion, opts))
    t_mid = float(np.median(meas.time))
    true_state = scn.target_states([t_mid])[0]
    limit = out.chi2_truth * (1 + RELATIVE_TOLERANCE)
    lines = []
    for j, th in enumerate(best_starts(problem, meas.value_si)):
        st = scn.motion.states(th, np.array([t_mid]))[0]
        fit = estimate(meas, scn.motion, init=th, options=opts)
        lines.append(f"    grid start {j}: {np.linalg.norm(st[:2] - true_state[:2]) / 1000:7.2f} "
                     f"km / {np.linalg.norm(st[3:5] - true_state[3:5]):5.1f} m/s from the "
                     f"truth at t_mid -> chi2 {fit.chi2:12.4f} after {fit.iterations} "
                     f"iterations ({fit.status})" + ("  [global]" if fit.chi2 <= limit else ""))
    dense = estimate(meas, scn.motion, options=opts, grid=DENSE_GRID)
    lines.append(f"    dense grid ({DENSE_GRID.n_ranges} ranges, {DENSE_GRID.n_bearings} "
                 f"bearings, {len(DENSE_GRID.speeds)} speeds x {DENSE_GRID.n_courses} courses, "
                 f"{DENSE_GRID.starts} starts): chi2 {dense.chi2:.4f} from {dense.starts} "
                 f"starts -> {'global optimum' if dense.chi2 <= limit else 'local minimum'}")
    return lines


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; returns 0 when the success rate meets 99.5 %."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--geometries", type=int, default=1000,
                        help="number of random observable geometries (default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    parser.add_argument("--index", type=int, nargs="*", default=None,
                        help="rerun only these geometry indices (verbose)")
    parser.add_argument("--no-analysis", action="store_true",
                        help="do not analyse failures (grid starts, denser grid)")
    args = parser.parse_args(argv)
    indices = args.index if args.index else list(range(args.geometries))
    outcomes: list[Outcome] = []
    failures: list[tuple[Outcome, Scenario, MeasurementSet]] = []
    wall = time.perf_counter()
    for i in indices:
        out, scn, meas = run_one(args.seed, i)
        outcomes.append(out)
        if not out.success:
            failures.append((out, scn, meas))
        if args.index:
            print(f"geometry {i}: {scn.description}")
            print(f"  chi2 blind {out.chi2_blind:.6f}, truth-started {out.chi2_truth:.6f} "
                  f"({out.dof} dof), {out.starts} starts, {out.seconds * 1000:.1f} ms, "
                  f"{out.status}, success {out.success}")
    wall = time.perf_counter() - wall
    n = len(outcomes)
    k = sum(o.success for o in outcomes)
    lo, hi = clopper_pearson(k, n)
    secs = np.array([o.seconds for o in outcomes])
    print(f"blind start, seed {args.seed}: {n} observable geometries, {wall:.1f} s in all "
          f"({wall / n * 1000:.1f} ms per geometry with both fits, the CRLB and the draws)")
    print(f"reached the global optimum: {k}/{n} = {100 * k / n:.2f} % "
          f"(95 % Clopper–Pearson interval {100 * lo:.2f}–{100 * hi:.2f} %); "
          f"requirement >= 99.5 %")
    starts = Counter(o.starts for o in outcomes)
    print("grid starts used: " + ", ".join(f"{s}: {c} ({100 * c / n:.1f} %)"
                                            for s, c in sorted(starts.items())))
    print(f"blind solve time: median {1000 * np.median(secs):.1f} ms, 95th percentile "
          f"{1000 * np.percentile(secs, 95):.1f} ms, max {1000 * secs.max():.1f} ms")
    status = Counter(o.status for o in outcomes)
    print("blind status: " + ", ".join(f"{s}: {c}" for s, c in status.most_common()))
    mixes = Counter("+".join(o.kinds) for o in outcomes)
    fail_mix = Counter("+".join(o.kinds) for o, _, _ in failures)
    print("failures by kind mix: " + (", ".join(
        f"{m}: {fail_mix[m]}/{mixes[m]}" for m in sorted(mixes)) if failures else "none"))
    for out, scn, meas in failures:
        print(f"FAIL seed {args.seed} index {out.index}: {'+'.join(out.kinds)}; range "
              f"{out.range0 / 1000:.2f} km at t=0 (closest {out.closest / 1000:.2f} km), "
              f"speed {out.speed:.1f} m/s, CRLB position std {out.position_std:.0f} m; "
              f"chi2 blind {out.chi2_blind:.4f} vs truth {out.chi2_truth:.4f} ({out.dof} dof),"
              f" {out.starts} starts, {out.status}, blind position error "
              f"{out.position_error / 1000:.2f} km")
        print(f"    {scn.description}")
        if not args.no_analysis:
            for line in analyse_failure(scn, meas, out):
                print(line)
    return 0 if n and k / n >= 0.995 else 1


if __name__ == "__main__":
    sys.exit(main())
