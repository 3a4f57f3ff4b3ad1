"""Speed of the batch solver on gu2007 (240 measurements), side by side with scipy.

1. Same start: tmakit's variable-projection Levenberg-Marquardt (nuisance eliminated) against
   ``scipy.optimize.least_squares(method="lm")`` with the analytic Jacobian on the joint problem
   (4 motion + 2 nuisance parameters, scaled), both started from the same point (the truth
   shifted by 3 standard deviations), on the same simulated data sets.
2. The full no-guess solve (``tk.batch.estimate`` with the grid initialisation), median time.

    python benchmarks/speed_gu2007.py [--sets 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.optimize import least_squares

import tmakit as tk
from tmakit.batch import VarProProblem, estimate, levenberg_marquardt
from tmakit.bounds import crlb


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", type=int, default=200, help="simulated data sets")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    scn = tk.load_scenario("gu2007")
    bound = crlb(scn)
    start = scn.theta + 3.0 * bound.std[:4] * np.array([1, -1, 1, -1])
    ours, theirs, blind, agree = [], [], [], []
    rng = np.random.default_rng(args.seed)
    for _ in range(args.sets):
        meas = scn.simulate(rng)
        obs = tk.ObservationModel(meas, scn.motion, scn.measurement_options)
        problem = VarProProblem(obs)
        y = obs.values

        t0 = time.perf_counter()
        sol = levenberg_marquardt(problem, y, start[None])
        ours.append(time.perf_counter() - t0)

        # scipy on the joint problem, analytic Jacobian, same start (nuisance from the data).
        nu0 = problem.initial_nuisance(start[None], problem.group(y))[0]
        x0 = np.concatenate([start, nu0])
        scale = np.concatenate([bound.std[:4], bound.std[4:]])
        sig = obs.sigmas

        def fun(z, x0=x0, scale=scale, obs=obs, sig=sig):
            x = x0 + z * scale
            return obs.residuals(x[:4], x[4:]) / sig

        def jac(z, x0=x0, scale=scale, obs=obs, sig=sig):
            x = x0 + z * scale
            j_theta, j_nu = obs.jacobian(x[:4], x[4:])
            return -np.hstack([j_theta, j_nu]) / sig[:, None] * scale

        t0 = time.perf_counter()
        ref = least_squares(fun, np.zeros(6), jac=jac, method="lm")
        theirs.append(time.perf_counter() - t0)
        joint = x0 + ref.x * scale
        agree.append(np.max(np.abs(sol.theta[0] - joint[:4]) / bound.std[:4]))

        t0 = time.perf_counter()
        estimate(meas, scn.motion, options=scn.measurement_options)
        blind.append(time.perf_counter() - t0)

    ms = 1e3
    print(f"gu2007, {args.sets} data sets, 240 measurements, C and f_s unknown")
    print(f"same start, tmakit VarPro-LM      : median {np.median(ours) * ms:7.2f} ms, "
          f"p95 {np.percentile(ours, 95) * ms:7.2f} ms")
    print(f"same start, scipy least_squares lm: median {np.median(theirs) * ms:7.2f} ms, "
          f"p95 {np.percentile(theirs, 95) * ms:7.2f} ms")
    print(f"speed-up (scipy median / tmakit median): {np.median(theirs) / np.median(ours):.2f}")
    print(f"largest difference between the two optima: {max(agree):.2e} standard deviations")
    print(f"full no-guess solve (grid + LM)    : median {np.median(blind) * ms:7.2f} ms, "
          f"p95 {np.percentile(blind, 95) * ms:7.2f} ms")


if __name__ == "__main__":
    main()
