"""Every speed figure of tmakit beside its peer, in one table, measured in one run.

Each row: what is measured, tmakit's median [interquartile range], the peer's, and the ratio
the goal is stated in (the machine may be shared: both sides are measured interleaved in the
same process, so the ratio is the figure; absolute times move with the load).

Sections (``--only`` picks some):

* ``filters``: the general EKF/UKF path per step (bearing + frequency from two sensors 2-D;
  bearing + elevation from two sensors 3-D) beside FilterPy's ``ExtendedKalmanFilter`` and
  ``UnscentedKalmanFilter`` and a minimal NumPy EKF loop, and the EKF's first run on a new
  set (compiling it) beside FilterPy; process CPU time (``filters_general_speed.py``);
* ``pf``: the particle filters at equal accuracy and at equal particle count on
  bearings-only-2d: tmakit's regularised SIR beside Stone Soup's SIR (and, without
  ``--quick``, Stone Soup's SIR with its ``MCMCRegulariser``); for each Stone Soup count, the
  tmakit count that reaches at least the same final position RMSE and the time per step at
  those two counts (``filters_pf_accuracy.py``);
* ``startup``: ``tma --help`` and ``tma scenarios`` beside ``python -c "import numpy"``, each a
  fresh interpreter, interleaved;
* ``crlb``: the CRLB and the no-guess estimate at N = 10^3 ... 10^5 bearings beside a
  hand-written NumPy Fisher matrix, and the log-log slopes (``batch_speed.py``);
* ``lm``: batch Levenberg-Marquardt from the same start beside
  ``scipy.optimize.least_squares(method="lm")`` at equal tolerance, N = 10^2 ... 10^5,
  bearings-only-2d and gu2007, and ``tk.estimate(..., init=)`` at N = 10^2 beside scipy's LM
  with a hand-written Jacobian (``batch_speed.py``);
* ``threads``: the particle filter with 10^5 particles, default BLAS threads beside one
  (``threads_speed.py``);
* ``montecarlo``: the no-guess Monte Carlo of gu2007 in one process, in two worker processes
  and on two local Dask workers, interleaved (10,000 runs; ``--quick``: 1,000;
  ``montecarlo_speed.py``);
* ``manoeuvre``: the hoerst2010 manoeuvre estimate (orders 0..3) on seeded data sets.

``--quick`` (about two minutes on an idle two-core machine) uses fewer repeats, sizes and
runs.

The first line reads the machine: its processor, a CPython loop of 10^7 additions and a NumPy
product of two 10^5 arrays (medians of 5).  The ratios are the figures; the two goals stated in
seconds (the Monte Carlo and the manoeuvre estimate) move with that line: on a 2.1 GHz Xeon
reading 0.63 s and 142 us (2026-12-05) they took 2.0 and 2.4 times as long as on the machine
they were set and met on (14.8 s against 7.24 s, 3.02 s against 1.26 s).

    PYTHONPATH=src python benchmarks/run_all.py [--quick] [--only filters startup ...]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from bench_problems import fmt

SECTIONS = ("filters", "pf", "startup", "crlb", "lm", "threads", "montecarlo", "manoeuvre")


def machine_line():
    """The processor and two speed readings: a CPython loop and a NumPy product."""
    import platform

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            info = {k.strip(): v.strip() for k, v in
                    (line.split(":", 1) for line in f if ":" in line)}
        model = f"{info['model name']}, {float(info['cpu MHz']):.0f} MHz"
    except (OSError, KeyError, ValueError):
        pass

    def loop():
        total = 0
        for i in range(10_000_000):
            total += i
        return total

    a, b, out = np.ones(100_000), np.ones(100_000), np.empty(100_000)
    python, product = [], []
    for _ in range(5):
        t0 = time.perf_counter()
        loop()
        python.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(100):
            np.multiply(a, b, out=out)
        product.append((time.perf_counter() - t0) / 100)
    return (f"machine: {model}; {os.cpu_count()} cores; CPython loop of 10^7 additions "
            f"{np.median(python):.2f} s; NumPy product of 10^5 {np.median(product) * 1e6:.0f} us")


def startup_rows(repeat):
    """``tma --help`` and ``tma scenarios`` beside ``python -c "import numpy"``."""
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    tma = [sys.executable, "-c", "import sys; from tmakit.cli import main; "
           "sys.argv[0] = 'tma'; sys.exit(main())"]
    commands = {"numpy": [sys.executable, "-c", "import numpy"],
                "tma --help": [*tma, "--help"], "tma scenarios": [*tma, "scenarios"]}
    times = {k: [] for k in commands}
    for _ in range(repeat):
        for name, cmd in commands.items():
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, check=True)
            times[name].append(time.perf_counter() - t0)
    stats = {k: (float(np.median(v)), float(np.percentile(v, 25)), float(np.percentile(v, 75)))
             for k, v in times.items()}
    goal = {"tma --help": 1.6, "tma scenarios": 2.0}
    return [(f"start-up, {name}", fmt(stats[name], 1e3),
             f"import numpy {fmt(stats['numpy'], 1e3)}", stats[name][0] / stats["numpy"][0],
             f"tmakit/peer (goal <= {goal[name]})") for name in goal]


def montecarlo_rows(runs, workers, repeat):
    """No-guess Monte Carlo of gu2007: one process, a process pool, a local Dask cluster."""
    from montecarlo_speed import rows

    try:
        import distributed  # noqa: F401
    except ImportError:
        return rows(runs, workers, repeat, dask=False)
    return rows(runs, workers, repeat)


def manoeuvre_rows(sets, repeat):
    """hoerst2010 manoeuvre estimate, orders 0..3, median over seeded data sets.

    CPU time of this process (the machine is shared; the estimate runs on one core), after
    one untimed order-0 estimate that imports numba and loads the compiled kernels (once per
    process).  That the choices are those of earlier code is checked by
    ``manoeuvre_choices.py --compare``.
    """
    import tmakit as tk

    scn = tk.load_scenario("hoerst2010")
    times, chosen = [], []
    tk.estimate(scn.simulate(np.random.default_rng(sets)), "curvilinear:0")
    for seed in range(sets):
        meas = scn.simulate(np.random.default_rng(seed))
        for _ in range(repeat):
            t0 = time.process_time()
            res = tk.estimate(meas, "curvilinear:3")
            times.append(time.process_time() - t0)
        chosen.append(getattr(res.motion, "name", "?"))
    fast = (float(np.median(times)), float(np.percentile(times, 25)),
            float(np.percentile(times, 75)))
    return [(f"manoeuvre estimate hoerst2010 ({len(meas)} rows), orders 0..3",
             fmt(fast, 1.0, "s") + " CPU", "goal <= 1.5 s", fast[0],
             f"{sets} data sets; chosen {', '.join(chosen)}")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="about two minutes")
    ap.add_argument("--only", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    args = ap.parse_args()
    q = args.quick
    rows = []
    print(machine_line(), flush=True)

    def section(name, fn):
        if name in args.only:
            t0 = time.perf_counter()
            got = fn()
            rows.extend(got)
            for row in got:
                print_row(row)
            print(f"  ({name}: {time.perf_counter() - t0:.0f} s)", flush=True)

    section("filters", lambda: _filters(3 if q else 7, 200 if q else 600))
    section("pf", lambda: _pf(q))
    section("startup", lambda: startup_rows(5 if q else 15))
    section("crlb", lambda: _crlb([1000, 10000, 100000], 3 if q else 7))
    section("lm", lambda: _lm([100, 1000, 10000, 100000] if not q else [100, 10000, 100000],
                              3 if q else 7))
    section("threads", lambda: _threads(10 if q else 20, 3 if q else 7))
    section("montecarlo", lambda: montecarlo_rows(1000 if q else 10_000, 2, 3))
    section("manoeuvre", lambda: manoeuvre_rows(1 if q else 3, 1))


def print_row(row):
    what, ours, peer, ratio, note = row
    print(f"{what:58s} {ours:26s} {peer:38s} {ratio:8.2f}  {note}", flush=True)


def _filters(repeat, steps):
    from filters_general_speed import measure

    return measure("bf2", steps, repeat) + measure("be3", steps, repeat)


def _pf(quick):
    from filters_pf_accuracy import measure

    try:
        import stonesoup  # noqa: F401
    except ImportError:
        return [("PF equal accuracy", "-", "Stone Soup not installed", float("nan"),
                 "pip install 'tmakit[bench]'")]
    if quick:
        return measure(3, 0, [50, 100, 250, 1000], [250, 1000], False)[0]
    return measure(8, 0, [50, 100, 250, 1000, 4000], [250, 1000, 4000], True)[0]


def _crlb(sizes, repeat):
    from batch_speed import crlb_rows

    return crlb_rows(sizes, repeat)


def _lm(sizes, repeat):
    from batch_speed import init_rows, lm_rows

    return lm_rows(sizes, repeat, 1e-10) + init_rows(100, repeat)


def _threads(steps, repeat):
    from threads_speed import pf_rows

    return pf_rows(100_000, steps, repeat)


if __name__ == "__main__":
    main()
