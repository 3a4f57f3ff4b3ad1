"""Where ``tk.estimate(meas, motion, init=start)`` spends its time at N = 100 bearings.

The problem of ``batch_speed.py --only init`` (bearings-only-2d with 100 evenly spaced rows,
the truth shifted by three std), timed in one process, interleaved, process CPU time:

* the estimate and ``scipy.optimize.least_squares(method="lm")`` with the hand-written
  Jacobian (the figure ``batch_speed.py`` reports);
* the Levenberg-Marquardt solve alone on a problem built once, and on one built each time;
* the solve with its five evaluations, or its five Gauss-Newton models, replayed from a
  recorded solve: what each costs *inside* the loop, where it runs colder than alone.

    PYTHONPATH=src python benchmarks/estimate_breakdown.py [--repeat 15]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from batch_speed import bearings_by_hand, lm_problem, scaled
from scipy.optimize import least_squares

import tmakit as tk
from tmakit.batch import solver, varpro
from tmakit.observation import ObservationModel


def replaying(owner, name, record):
    """Give a call that runs ``fn`` with ``owner.name`` replaying ``record`` in turn."""
    real = owner.__dict__[name]
    turn = [0]

    def replay(*args, **kwargs):
        turn[0] += 1
        return record[(turn[0] - 1) % len(record)]

    def call(fn):
        turn[0] = 0
        setattr(owner, name, classmethod(replay) if isinstance(real, classmethod) else replay)
        try:
            return fn()
        finally:
            setattr(owner, name, real)

    return call


def recorded(owner, name, fn):
    """Run ``fn`` once, recording what ``owner.name`` returns."""
    real = owner.__dict__[name]
    inner = real.__func__ if isinstance(real, classmethod) else real
    out = []

    def record(*args, **kwargs):
        out.append(inner(*args, **kwargs))
        return out[-1]

    setattr(owner, name, classmethod(record) if isinstance(real, classmethod) else record)
    try:
        fn()
    finally:
        setattr(owner, name, real)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    _, _, start, *_ = lm_problem("bearings-only-2d", 100)
    scn, meas = scaled("bearings-only-2d", 100)
    motion = scn.motion
    fun, jac = bearings_by_hand(meas, motion.ref_time)
    ys, th = np.array([meas.value_si]), start[None]

    def build():
        return varpro.VarProProblem(ObservationModel(meas, motion))

    problem = build()

    def solve():
        return solver.levenberg_marquardt(problem, ys, th)

    evals = recorded(varpro.VarProProblem, "evaluate_part", solve)
    models = recorded(solver.GaussNewtonModel, "at", solve)
    no_evals = replaying(varpro.VarProProblem, "evaluate_part", evals)
    no_models = replaying(solver.GaussNewtonModel, "at", models)
    funcs = {
        "estimate": lambda: tk.estimate(meas, motion, init=start),
        "scipy hand": lambda: least_squares(fun, start, jac=jac, method="lm", xtol=1e-10,
                                            ftol=1e-10, gtol=1e-10),
        "build + LM": lambda: solver.levenberg_marquardt(build(), np.array([meas.value_si]), th),
        "LM": solve,
        "LM, evaluations replayed": lambda: no_evals(solve),
        "LM, models replayed": lambda: no_models(solve),
        "build alone": build,
    }
    for fn in funcs.values():
        fn()
    times = {name: [] for name in funcs}
    for _ in range(args.repeat):
        for name, fn in funcs.items():
            t0 = time.process_time()
            for _ in range(20):
                fn()
            times[name].append((time.process_time() - t0) / 20 * 1e6)
    med = {name: float(np.median(v)) for name, v in times.items()}
    for name, v in times.items():
        print(f"{name:26s} {med[name]:7.1f} us CPU [{np.percentile(v, 25):.1f}-"
              f"{np.percentile(v, 75):.1f}]")
    lm, ev, gn = med["LM"], med["LM"] - med["LM, evaluations replayed"], \
        med["LM"] - med["LM, models replayed"]
    print(f"estimate / scipy hand: {med['estimate'] / med['scipy hand']:.2f}")
    print(f"in the loop: {len(evals)} evaluations {ev:.0f} us, {len(models)} Gauss-Newton models "
          f"{gn:.0f} us, the rest of the LM {lm - ev - gn:.0f} us; building the problem "
          f"{med['build + LM'] - lm:.0f} us (alone, hot: {med['build alone']:.0f}); the result "
          f"and the calls around the fit {med['estimate'] - med['build + LM']:.0f} us")


if __name__ == "__main__":
    main()
