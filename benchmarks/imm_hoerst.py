"""IMM and MM-PF against the constant-velocity EKF and the batch curvilinear ML on ``hoerst2010``.

Bearings only (the scenario's azimuth rows). Every filter starts from the same batch window,
that of ``tma track``'s start for the multiple-model filters (``--start-std``, default 0.1 of
the range, judged by the start's covariance widened to its profile likelihood; the IMM's window,
taken by the others as ``init_window``), so that the ratios compare the filters, not their
starts. Prints, over seeded runs,
the ratio of the IMM's RMS position error over the whole track to the CV EKF's (issue 28:
<= 0.5), the IMM smoother's RMS beside it, and at the final time the ratio of the IMM's RMS
error to the batch piecewise-curvilinear ML estimate's over all the data (issue 28: <= 1.5);
the same for the multiple-model particle filter (``mmpf``, the same models), started by the
batch window too or, with ``--range-prior``, from the first bearing (its RMS then over the
EKF's times only, the same span as the others'), and its smoother (backward simulation,
``--paths`` paths). For every filter and smoother, the share of (run, step) pairs whose truth
lies inside the 95 % position ellipse.

With ``--diagnose``, where the IMM's final-time error comes from: the final-time RMS of a CV
EKF (no process noise) started from the IMM's own estimate and covariance at the end of the
target's last manoeuvre and 50 and 100 s after it (the IMM's information there, had it known
the target ran straight from then on); of the IMM's straight-line model alone; and of the batch
constant-velocity ML fit of the last leg's bearings alone.

    python benchmarks/imm_hoerst.py --runs 100 --seed 1
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from typing import Any

import numpy as np

import tmakit as tk
from tmakit.cli.track import nis_verdict
from tmakit.filters import BearingPrior, ExtendedKalmanFilter, smooth
from tmakit.filters.imm import START_RELATIVE_STD
from tmakit.tracking import BatchInitiator, truth_states

LARGER = "the innovations are larger"
CHI2_95 = 5.991  # chi-square 95 % quantile, 2 dof


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--model-q", type=float, nargs="*", default=None,
                        help="the IMM's white-noise manoeuvre models (m/s^2; default none)")
    parser.add_argument("--turn-rate", type=float, nargs="*", default=None,
                        help="the IMM's coordinated-turn models (deg/s; default the filter's "
                             "bank)")
    parser.add_argument("--start-std", type=float, default=START_RELATIVE_STD,
                        help="the batch start's position std over range, for every filter")
    parser.add_argument("--linearised-start", action="store_true",
                        help="judge --start-std by the batch start's linearised covariance "
                             "alone (as before; default: by the covariance widened to its "
                             "profile likelihood, as tma track does for imm and mmpf)")
    parser.add_argument("--particles", type=int, default=5000, help="the MM-PF's particles")
    parser.add_argument("--range-prior", type=float, nargs=2, default=None,
                        metavar=("MIN", "MAX"), help="start the MM-PF at the first bearing (m)")
    parser.add_argument("--speed-prior", type=float, default=60.0,
                        help="with --range-prior: the largest speed (m/s)")
    parser.add_argument("--no-batch", action="store_true", help="skip the batch ML fits")
    parser.add_argument("--no-mmpf", action="store_true", help="skip the MM-PF")
    parser.add_argument("--paths", type=int, default=200,
                        help="the MM-PF smoother's paths (backward simulation)")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel processes")
    parser.add_argument("--diagnose", action="store_true",
                        help="the IMM's final-time error taken apart (see above)")
    args = parser.parse_args()
    settings: dict[str, object] = {}
    if args.turn_rate is not None:
        settings["turn_rates"] = np.radians(args.turn_rate).tolist()
    if args.model_q is not None:
        settings["model_q"] = args.model_q
    prior = None if args.range_prior is None else BearingPrior(*args.range_prior,
                                                               args.speed_prior)
    names = ("ekf", "imm", "smoothed imm") + (() if args.no_mmpf else ("mmpf", "smoothed mmpf"))
    seeds = np.random.SeedSequence(args.seed).spawn(args.runs)
    cpu = os.times()
    with ProcessPoolExecutor(args.jobs) as pool:
        runs = list(pool.map(partial(one_run, names=names, settings=settings, prior=prior,
                                     args=args), seeds))
    sq = {k: [r["sq"][k] for r in runs] for k in names}
    final = {k: [r["final"][k] for r in runs] for k in (*names, "batch") if runs[0]["final"].get(k)
             is not None}
    diverged = {k: sum(r["diverged"][k] for r in runs) for k in names}
    inside = {k: float(np.mean(np.concatenate([r["inside"][k] for r in runs]))) for k in names}
    starts = [r["start"] for r in runs]
    used = os.times()
    cpu_s = (used.user + used.children_user) - (cpu.user + cpu.children_user)
    rms = {k: float(np.sqrt(np.mean(np.concatenate(v)))) for k, v in sq.items()}
    fin = {k: float(np.sqrt(np.mean(v))) for k, v in final.items() if v}
    mmpf_start = "batch window" if prior is None else f"first bearing, {prior}"
    print(f"hoerst2010, bearings only, {args.runs} runs, seed {args.seed}, IMM settings "
          f"{settings or 'default'}; batch start at position std < {args.start_std:g} of the "
          f"range (first estimate at t = {np.median(starts):.0f} s median, "
          f"{np.min(starts):.0f}..{np.max(starts):.0f}); MM-PF start: {mmpf_start}")
    mm = "mmpf" in rms
    print(f"RMS position error over the track: CV EKF {rms['ekf']:.0f} m, IMM "
          f"{rms['imm']:.0f} m (smoothed {rms['smoothed imm']:.0f} m)"
          + (f", MM-PF ({args.particles} particles) {rms['mmpf']:.0f} m (smoothed, "
             f"{args.paths} paths, {rms['smoothed mmpf']:.0f} m)" if mm else "")
          + f"; ratio to the EKF: IMM {rms['imm'] / rms['ekf']:.3f}"
          + (f", MM-PF {rms['mmpf'] / rms['ekf']:.3f}" if mm else "") + " (target <= 0.5)")
    line = (f"final-time RMS: CV EKF {fin['ekf']:.0f} m, IMM {fin['imm']:.0f} m"
            + (f", MM-PF {fin['mmpf']:.0f} m" if mm else ""))
    if "batch" in fin:
        line += (f", batch curvilinear ML {fin['batch']:.0f} m; ratio to the batch: IMM "
                 f"{fin['imm'] / fin['batch']:.3f}"
                 + (f", MM-PF {fin['mmpf'] / fin['batch']:.3f}" if mm else "")
                 + " (target <= 1.5)")
    print(line)
    if args.diagnose:
        parts = {k: float(np.sqrt(np.mean([r["diagnose"][k] for r in runs])))
                 for k in runs[0]["diagnose"]}
        print("the IMM's final-time RMS taken apart: " + ", ".join(
            f"{k} {v:.0f} m" + (f" ({v / fin['batch']:.2f}x the batch)" if "batch" in fin
                                else "") for k, v in parts.items()))
    print(f"runs whose NIS says diverged (tma track's check): CV EKF {diverged['ekf']}, "
          f"IMM {diverged['imm']}" + (f", MM-PF {diverged['mmpf']}" if mm else ""))
    print("truth inside the 95 % position ellipse, share of (run, step) pairs: "
          + ", ".join(f"{k} {100 * v:.1f} %" for k, v in inside.items()))
    print(f"CPU {cpu_s:.0f} s ({args.jobs} processes); load average "
          f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}")


def one_run(ss: np.random.SeedSequence, names: tuple[str, ...], settings: dict[str, object],
            prior: BearingPrior | None, args: argparse.Namespace) -> dict[str, Any]:
    """Track one seeded run with every filter; give its squared errors and verdicts."""
    sim = tk.load_scenario("hoerst2010").simulate(np.random.default_rng(ss))
    meas = sim.take(np.flatnonzero(sim.kind == "bearing"))
    tracks: dict[str, tk.Track] = {}
    for name in sorted((k for k in names if not k.startswith("smoothed")),
                       key=lambda k: k != "imm"):  # the IMM's start window is every filter's
        start = {"bearing_prior": prior} if name == "mmpf" and prior is not None else {
            "initiator": BatchInitiator(max_relative_std=args.start_std,
                                        likelihood_quality=not args.linearised_start)
            if name == "imm" else BatchInitiator(init_window=tracks["imm"].extra.start["window"])}
        pf = {"particles": args.particles, "rng": ss} if name == "mmpf" else {}
        tracks[name] = tk.track(meas, name, settings=None if name == "ekf" else {
            **settings, "history": True}, **start, **pf)
    out_diagnose = diagnose(meas, tracks["imm"]) if args.diagnose else {}
    tracks["smoothed imm"] = smooth(tracks["imm"])
    if "mmpf" in tracks:
        tracks["smoothed mmpf"] = smooth(tracks["mmpf"], trajectories=args.paths,
                                         rng=np.random.default_rng(ss.spawn(1)[0]))
        tracks["mmpf"].extra.history = None  # the clouds are large
    t0 = tracks["ekf"].times[0]
    out: dict[str, Any] = {"sq": {}, "final": {}, "diverged": {}, "inside": {}, "start": t0,
                           "diagnose": out_diagnose}
    for name, tr in tracks.items():
        keep = tr.times >= t0
        truth = truth_states(meas, tr.times[keep], 2)
        d = tr.states[keep, :2] - truth[:, :2]
        e = np.linalg.norm(d, axis=1)
        out["sq"][name] = e**2
        out["inside"][name] = np.einsum("ki,kij,kj->k", d,
                                        np.linalg.inv(tr.covariances[keep, :2, :2]), d) < CHI2_95
        out["final"][name] = float(e[-1] ** 2)
        out["diverged"][name] = nis_verdict(tr).startswith(LARGER)
    if not args.no_batch:
        fit = tk.estimate(meas, "curvilinear:2")
        t_end = np.array([meas.time.max()])
        st = fit.motion.states(np.asarray(fit.estimate), t_end)[0]
        out["final"]["batch"] = float(np.sum((st[:2] - truth_states(meas, t_end, 2)[0, :2])
                                             ** 2))
    return out


def diagnose(meas: tk.MeasurementSet, imm: tk.Track) -> dict[str, float]:
    """Give the squared final-time errors that take the IMM's apart (``--diagnose``)."""
    truth = tk.load_scenario("hoerst2010").truth
    turn_end = float(max(v for k, v in truth.items() if k.startswith("t_")))
    t_end = np.array([meas.time.max()])
    final = truth_states(meas, t_end, 2)[0, :2]
    out = {}
    for delay in (0.0, 50.0, 100.0):
        k = int(np.flatnonzero(imm.times >= turn_end + delay)[0])
        ekf = ExtendedKalmanFilter(imm.states[k], imm.covariances[k], float(imm.times[k]))
        tr = ekf.run(meas.take(np.flatnonzero(meas.time > imm.times[k])))
        out[f"CV EKF from the IMM at {turn_end + delay:.0f} s"] = float(
            np.sum((tr.states[-1, :2] - final) ** 2))
    cv = imm.extra.history.steps[-1].means[0, :2]
    out["the IMM's straight model alone"] = float(np.sum((cv - final) ** 2))
    fit = tk.estimate(meas.take(np.flatnonzero(meas.time >= turn_end)), "cv")
    leg = fit.motion.states(np.asarray(fit.estimate), t_end)[0, :2]
    out["batch CV fit of the last leg alone"] = float(np.sum((leg - final) ** 2))
    return out


if __name__ == "__main__":
    main()
