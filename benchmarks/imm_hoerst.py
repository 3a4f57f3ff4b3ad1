"""IMM and MM-PF against the constant-velocity EKF and the batch curvilinear ML on ``hoerst2010``.

Bearings only (the scenario's azimuth rows), each filter started by ``tma track``'s batch
window.  Prints, over seeded runs, the ratio of the IMM's RMS position error over the whole
track to the CV EKF's (issue 28: <= 0.5) and, at the final time, the ratio of the IMM's RMS
error to the batch piecewise-curvilinear ML estimate's (issue 28: <= 1.5); the same for the
multiple-model particle filter (``mmpf``, the same models) beside them, started by the batch
window too or, with ``--range-prior``, from the first bearing (its RMS then over the EKF's
times only, the same span as the others').

    python benchmarks/imm_hoerst.py --runs 100 --seed 1
"""

from __future__ import annotations

import argparse

import numpy as np

import tmakit as tk
from tmakit.cli.track import nis_verdict
from tmakit.filters import BearingPrior
from tmakit.tracking import truth_states

LARGER = "the innovations are larger"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--model-q", type=float, nargs="*", default=None,
                        help="the IMM's manoeuvre models (m/s^2; default the filter's)")
    parser.add_argument("--turn-rate", type=float, nargs="*", default=(),
                        help="the IMM's coordinated-turn models (deg/s)")
    parser.add_argument("--particles", type=int, default=5000, help="the MM-PF's particles")
    parser.add_argument("--range-prior", type=float, nargs=2, default=None,
                        metavar=("MIN", "MAX"), help="start the MM-PF at the first bearing (m)")
    parser.add_argument("--speed-prior", type=float, default=60.0,
                        help="with --range-prior: the largest speed (m/s)")
    parser.add_argument("--no-batch", action="store_true", help="skip the batch ML fits")
    args = parser.parse_args()
    settings: dict[str, object] = {"turn_rates": np.radians(args.turn_rate).tolist()}
    if args.model_q is not None:
        settings["model_q"] = args.model_q
    prior = None if args.range_prior is None else BearingPrior(*args.range_prior,
                                                               args.speed_prior)
    scn = tk.load_scenario("hoerst2010")
    seeds = np.random.SeedSequence(args.seed).spawn(args.runs)
    names = ("ekf", "imm", "mmpf")
    sq: dict[str, list[np.ndarray]] = {k: [] for k in names}
    final: dict[str, list[float]] = {"batch": [], **{k: [] for k in names}}
    diverged = dict.fromkeys(names, 0)
    for ss in seeds:
        sim = scn.simulate(np.random.default_rng(ss))
        meas = sim.take(np.flatnonzero(sim.kind == "bearing"))
        for name in names:
            pf = ({"particles": args.particles, "rng": ss, "bearing_prior": prior}
                  if name == "mmpf" else {})
            tr = tk.track(meas, name, settings=None if name == "ekf" else settings, **pf)
            if name == "ekf":
                t0 = tr.times[0]
            keep = tr.times >= t0
            truth = truth_states(meas, tr.times[keep], 2)
            e = np.linalg.norm(tr.states[keep, :2] - truth[:, :2], axis=1)
            sq[name].append(e**2)
            final[name].append(e[-1] ** 2)
            ok = np.isfinite(tr.nis)
            diverged[name] += nis_verdict(float(np.sum(tr.nis[ok])),
                                          int(np.sum(tr.dof[ok]))).startswith(LARGER)
        if not args.no_batch:
            fit = tk.estimate(meas, "curvilinear:2")
            t_end = np.array([meas.time.max()])
            st = fit.motion.states(np.asarray(fit.estimate), t_end)[0]
            final["batch"].append(float(np.sum((st[:2] - truth_states(meas, t_end, 2)[0, :2])
                                               ** 2)))
    rms = {k: float(np.sqrt(np.mean(np.concatenate(v)))) for k, v in sq.items()}
    fin = {k: float(np.sqrt(np.mean(v))) for k, v in final.items() if v}
    start = "batch window" if prior is None else f"first bearing, {prior}"
    print(f"hoerst2010, bearings only, {args.runs} runs, seed {args.seed}, IMM {settings}; "
          f"MM-PF start: {start}")
    print(f"RMS position error over the track: CV EKF {rms['ekf']:.0f} m, IMM "
          f"{rms['imm']:.0f} m, MM-PF ({args.particles} particles) {rms['mmpf']:.0f} m; ratio "
          f"to the EKF: IMM {rms['imm'] / rms['ekf']:.3f}, MM-PF {rms['mmpf'] / rms['ekf']:.3f}"
          " (target <= 0.5)")
    line = (f"final-time RMS: CV EKF {fin['ekf']:.0f} m, IMM {fin['imm']:.0f} m, MM-PF "
            f"{fin['mmpf']:.0f} m")
    if "batch" in fin:
        line += (f", batch curvilinear ML {fin['batch']:.0f} m; ratio to the batch: IMM "
                 f"{fin['imm'] / fin['batch']:.3f}, MM-PF {fin['mmpf'] / fin['batch']:.3f} "
                 "(target <= 1.5)")
    print(line)
    print(f"runs whose NIS says diverged (tma track's check): CV EKF {diverged['ekf']}, "
          f"IMM {diverged['imm']}, MM-PF {diverged['mmpf']}")


if __name__ == "__main__":
    main()
