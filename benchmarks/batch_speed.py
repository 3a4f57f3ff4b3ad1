"""Speed of the batch layer at N = 10^2 ... 10^5 rows, each figure beside its peer.

* **CRLB** (``tmakit.bounds.crlb`` of a measurement set at the truth) against a hand-written
  NumPy Fisher matrix of the same bearings (``J^T R^-1 J`` with the bearing gradient chained
  through the constant-velocity model by hand), and the log-log slope of tmakit's time over
  10^3 ... 10^5;
* **no-guess estimate** (``tmakit.estimate``: grid start + Levenberg-Marquardt) at the same N,
  against the same hand-written Fisher matrix;
* **an estimate from a start** (``tmakit.estimate(..., init=start)``: the fit and its result,
  covariance, status and observability) at N = 100 against
  ``scipy.optimize.least_squares(method="lm")`` from the same start with a hand-written
  analytic Jacobian of the bearings (and with the Jacobian of tmakit's ``ObservationModel``;
  and, doing what tmakit's call also does, building its residuals from the set and forming
  the covariance ``inv(J'J)`` at the solution: ``least_squares`` returns no covariance);
* **batch LM from the same start**: tmakit's Levenberg-Marquardt (``levenberg_marquardt`` on
  the variable-projection problem) against ``scipy.optimize.least_squares(method="lm")`` with
  the analytic Jacobian of the same ``ObservationModel``, both from the truth shifted by three
  standard deviations, at equal accuracy: scipy with ``ftol = xtol = gtol = 1e-10``
  (``--tol``), tmakit with 100 times smaller tolerances and its absolute decrement floor
  ``dtol`` off.  tmakit's ``ftol`` bounds the decrement a Gauss-Newton step predicts, scipy's
  the reduction a step achieved: at the same 1e-10 tmakit stopped one step earlier, 3e-4
  standard deviations from the optimum (scipy 4e-7); at 1e-12 both are within 1e-5.  The
  printed agreement is between the two optima.  Process CPU time per solve (a sample repeats
  a fast solve, both sides the same number of times, to last about 20 ms).  On
  bearings-only-2d and gu2007 with their rows repeated at a higher rate (the same geometry
  and span, N rows).

The problems: the built-in scenarios with their measurement times replaced by N evenly spaced
times over the same span (bearings-only-2d: one sensor, bearings; gu2007: power and
frequency, carrier and power constant unknown).  Medians [interquartile range] of interleaved
repeats.

    PYTHONPATH=src python benchmarks/batch_speed.py [--sizes 100 1000 10000 100000]
        [--repeat 5] [--clock cpu|wall] [--only crlb|lm|init]
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from bench_problems import fmt

import tmakit as tk


def scaled(name, n, seed=0):
    """The scenario ``name`` with n rows in all (its plans share them), and one noisy set."""
    scn = tk.load_scenario(name)
    lo, hi = scn.time_span()
    per = max(1, n // len(scn.plans))
    plans = [dataclasses.replace(p, times=np.linspace(lo, hi, per)) for p in scn.plans]
    scn = dataclasses.replace(scn, plans=plans)
    return scn, scn.simulate(np.random.default_rng(seed))


def fisher_by_hand(meas, theta):
    """Hand-written Fisher matrix of bearings about (x, y, vx, vy) at ref time 0."""
    t = meas.time
    s = meas.sensor_state
    dx = theta[0] + theta[2] * t - s[:, 0]
    dy = theta[1] + theta[3] * t - s[:, 1]
    inv = 1.0 / (dx * dx + dy * dy)
    gx, gy = dy * inv, -dx * inv
    jac = np.stack([gx, gy, gx * t, gy * t], axis=1) / meas.sigma_si[:, None]
    return jac.T @ jac


def crlb_rows(sizes, repeat, clock="cpu"):
    """CRLB and no-guess estimate vs the hand Fisher matrix, and the log-log slopes."""
    rows, t_crlb, t_est = [], [], []
    unit = "ms CPU" if clock == "cpu" else "ms"
    for n in sizes:
        scn, meas = scaled("bearings-only-2d", n)
        theta = scn.theta
        stats = per_call({
            "crlb": lambda scn=scn, meas=meas: tk.crlb(meas, scn.motion, scn.truth),
            "fisher": lambda meas=meas, theta=theta: np.linalg.inv(fisher_by_hand(meas, theta)),
            "estimate": lambda scn=scn, meas=meas: tk.estimate(meas, scn.motion),
        }, repeat, clock)
        t_crlb.append(stats["crlb"][0])
        t_est.append(stats["estimate"][0])
        rows.append((f"CRLB, bearings-only, N = {n}", fmt(stats["crlb"], 1e3, unit),
                     f"NumPy Fisher {fmt(stats['fisher'], 1e3, unit)}",
                     stats["crlb"][0] / stats["fisher"][0], "tmakit/peer (goal <= 3)"))
        rows.append((f"no-guess estimate, bearings-only, N = {n}",
                     fmt(stats["estimate"], 1e3, unit),
                     f"NumPy Fisher {fmt(stats['fisher'], 1e3, unit)}",
                     stats["estimate"][0] / stats["fisher"][0],
                     "tmakit/peer (goal <= 3 at N = 10^5; fixed costs rule below)"))
    big = [i for i, n in enumerate(sizes) if n >= 1000]
    if len(big) >= 2:
        x = np.log([sizes[i] for i in big])
        for name, t in (("CRLB", t_crlb), ("no-guess estimate", t_est)):
            slope = np.polyfit(x, np.log([t[i] for i in big]), 1)[0]
            rows.append((f"{name} log-log slope over N = {sizes[big[0]]}..{sizes[big[-1]]}",
                         f"{slope:.2f}", "goal <= 1.2", slope, ""))
    return rows


def lm_problem(name, n):
    """Data, tmakit's VarPro problem and scipy's joint residual/Jacobian, same start."""
    from tmakit.batch import VarProProblem

    scn, meas = scaled(name, n)
    bound = tk.crlb(scn)
    k = len(scn.motion.param_names)
    signs = np.resize([1.0, -1.0], k)
    start = scn.theta + 3.0 * bound.std[:k] * signs
    obs = tk.ObservationModel(meas, scn.motion, scn.measurement_options)
    problem = VarProProblem(obs)
    y = obs.values
    nu0 = problem.initial_nuisance(start[None], problem.group(y))[0] if obs.n_nuisance \
        else np.zeros(0)
    x0 = np.concatenate([start, nu0])
    scale = bound.std[:x0.size]
    sig = obs.sigmas

    def fun(z):
        x = x0 + z * scale
        return obs.residuals(x[:k], x[k:]) / sig

    def jac(z):
        x = x0 + z * scale
        j_theta, j_nu = obs.jacobian(x[:k], x[k:])
        return -np.hstack([j_theta, j_nu]) / sig[:, None] * scale

    return problem, y, start, fun, jac, x0, scale, bound, k


SAMPLE_SECONDS = 0.02
"""Least duration of one timed sample: a fast solve is repeated within a sample (the same
number of times for both sides), so that a sample is not a single sub-millisecond call."""


def per_call(funcs, repeat, clock="cpu", seconds=SAMPLE_SECONDS):
    """``{name: (median, q1, q3)}`` seconds per call, interleaved.

    Each sample repeats every callable the same number of times (the slowest lasting about
    ``seconds``).  ``clock="cpu"`` (the default) times process CPU time: the machine is
    shared, and a process waiting for a core is not slower code; ``"wall"`` wall time.
    """
    import time

    now = time.process_time if clock == "cpu" else time.perf_counter
    slowest = 0.0
    for fn in funcs.values():
        fn()  # warm
        t0 = now()
        fn()
        slowest = max(slowest, now() - t0)
    calls = max(1, int(seconds / max(slowest, 1e-6)))
    times = {name: [] for name in funcs}
    for _ in range(repeat):
        for name, fn in funcs.items():
            t0 = now()
            for _ in range(calls):
                fn()
            times[name].append((now() - t0) / calls)
    return {name: (float(np.median(v)), float(np.percentile(v, 25)),
                   float(np.percentile(v, 75))) for name, v in times.items()}


def lm_rows(sizes, repeat, tol, clock="cpu"):
    """tmakit's LM vs scipy least_squares(method="lm") from the same start."""
    from scipy.optimize import least_squares

    from tmakit.batch import levenberg_marquardt

    rows, unit = [], "ms CPU" if clock == "cpu" else "ms"
    for name in ("bearings-only-2d", "gu2007"):
        for n in sizes:
            problem, y, start, fun, jac, x0, scale, bound, k = lm_problem(name, n)
            ours_tol = tol * 1e-2
            ours = levenberg_marquardt(problem, y, start[None], ftol=ours_tol, xtol=ours_tol,
                                       gtol=ours_tol, dtol=0.0).theta[0]
            ref = least_squares(fun, np.zeros(x0.size), jac=jac, method="lm", xtol=tol,
                                ftol=tol, gtol=tol)
            agree = np.max(np.abs(ours - (x0 + ref.x * scale)[:k]) / bound.std[:k])
            funcs = {
                "tmakit": lambda problem=problem, y=y, start=start, t=ours_tol:
                    levenberg_marquardt(problem, y, start[None], ftol=t, xtol=t, gtol=t,
                                        dtol=0.0),
                "scipy": lambda fun=fun, jac=jac, x0=x0: least_squares(
                    fun, np.zeros(x0.size), jac=jac, method="lm", xtol=tol, ftol=tol,
                    gtol=tol)}
            stats = per_call(funcs, repeat, clock)
            rows.append((f"batch LM same start, {name}, N = {n}",
                         fmt(stats["tmakit"], 1e3, unit),
                         f"scipy lm {fmt(stats['scipy'], 1e3, unit)}",
                         stats["scipy"][0] / stats["tmakit"][0],
                         f"peer/tmakit (goal >= 1); optima agree {agree:.1e} std"))
    return rows


def bearings_by_hand(meas, ref_time):
    """Residual and analytic Jacobian of bearings about (x, y, vx, vy), whitened, by hand."""
    t = meas.time - ref_time
    s = meas.sensor_state
    y, sig = meas.value_si, meas.sigma_si

    def offsets(x):
        return x[0] + x[2] * t - s[:, 0], x[1] + x[3] * t - s[:, 1]

    def fun(x):
        dx, dy = offsets(x)
        return (np.mod(y - np.arctan2(dx, dy) + np.pi, 2 * np.pi) - np.pi) / sig

    def jac(x):
        dx, dy = offsets(x)
        inv = 1.0 / ((dx * dx + dy * dy) * sig)
        gx, gy = dy * inv, -dx * inv
        return -np.stack([gx, gy, gx * t, gy * t], axis=1)

    return fun, jac


def init_rows(n, repeat, tol=1e-10, clock="cpu"):
    """``tk.estimate(..., init=start)`` beside scipy's LM, with a hand-written Jacobian and with
    the ObservationModel's, from the same start (the truth shifted by three std)."""
    from scipy.optimize import least_squares

    _, _, start, obs_fun, obs_jac, x0, _, bound, k = lm_problem("bearings-only-2d", n)
    scn, meas = scaled("bearings-only-2d", n)
    fun, jac = bearings_by_hand(meas, scn.motion.ref_time)
    ours = tk.estimate(meas, scn.motion, init=start)
    hand = least_squares(fun, start, jac=jac, method="lm", xtol=tol, ftol=tol, gtol=tol)
    agree = np.max(np.abs(ours.estimate - hand.x) / bound.std[:k])
    unit = "ms CPU" if clock == "cpu" else "ms"

    def hand_as_tmakit():
        # what tmakit's call also does: the residuals built from the set, the covariance formed
        f, j = bearings_by_hand(meas, scn.motion.ref_time)
        res = least_squares(f, start, jac=j, method="lm", xtol=tol, ftol=tol, gtol=tol)
        return res.x, np.linalg.inv(res.jac.T @ res.jac)

    stats = per_call({
        "estimate": lambda: tk.estimate(meas, scn.motion, init=start),
        "hand": lambda: least_squares(fun, start, jac=jac, method="lm", xtol=tol, ftol=tol,
                                      gtol=tol),
        "model": lambda: least_squares(obs_fun, np.zeros(x0.size), jac=obs_jac, method="lm",
                                       xtol=tol, ftol=tol, gtol=tol),
        "hand+": hand_as_tmakit}, repeat, clock)
    return [(f"tk.estimate(init=) vs scipy lm, hand Jacobian, N = {n}",
             fmt(stats["estimate"], 1e3, unit), f"scipy lm {fmt(stats['hand'], 1e3, unit)}",
             stats["estimate"][0] / stats["hand"][0],
             f"tmakit/peer (goal <= 1); optima agree {agree:.1e} std"),
            (f"tk.estimate(init=) vs scipy lm, model's Jacobian, N = {n}",
             fmt(stats["estimate"], 1e3, unit), f"scipy lm {fmt(stats['model'], 1e3, unit)}",
             stats["estimate"][0] / stats["model"][0], "tmakit/peer"),
            (f"tk.estimate(init=) vs scipy lm + covariance, hand Jacobian, N = {n}",
             fmt(stats["estimate"], 1e3, unit), f"scipy lm {fmt(stats['hand+'], 1e3, unit)}",
             stats["estimate"][0] / stats["hand+"][0],
             "tmakit/peer; the peer also builds its residuals and inverts J'J")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000, 100000])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("--only", choices=["crlb", "lm", "init"], default=None)
    ap.add_argument("--clock", choices=["cpu", "wall"], default="cpu",
                    help="process CPU time (default) or wall time")
    args = ap.parse_args()
    rows = []
    if args.only in (None, "crlb"):
        rows += crlb_rows(args.sizes, args.repeat, args.clock)
    if args.only in (None, "lm"):
        rows += lm_rows(args.sizes, args.repeat, args.tol, args.clock)
    if args.only in (None, "init"):
        rows += init_rows(100, args.repeat, args.tol, args.clock)
    for what, ours, peer, ratio, note in rows:
        print(f"{what:50s} {ours:26s} {peer:36s} {ratio:7.2f}  {note}")


if __name__ == "__main__":
    main()
