"""Sensor position errors (Ho, Lu & Kovavisaruch (2007)): the ML that accounts for them against
the bound that includes them, the one that ignores them beside it.

    python benchmarks/sensor_errors_ho2007.py [--layout ho-xu|chan-ho] [--runs 500] [--seed 1]
        [--sigma-p 300 ...]

Ho & Xu's five moving sensors (tmakit.reproduce.ho_xu2004), TDOA + FDOA at one time with
range-difference noise 0.1 m (range-rate 0.01 m/s), sigma_p from 0.03 m to 3 m; or the ten
sensors of tmakit.reproduce.chan_ho1994 (TDOA, 2-D, noise 10 m, sigma_p 3 m to 300 m).
Each run draws the sensors' reported positions off their true ones by N(0, sigma_p^2) per
axis (one draw per sensor, shared by its rows and by the rows that take it as reference).
Prints, per sigma_p, the position and velocity MSE over the trace of the CRLB with the errors
(bounds.fim) for the accounting ML (batch.ml) and the ignoring ML (the
ordinary fit of the reported positions), each with its mean NEES per parameter (its error
against the covariance it reports: 1 when that covariance is honest), and the bound's loss
against known positions.  With TDOA alone and equal isotropic errors the effective noise is a
multiple of R (each row's own sensor adds sigma_p^2, the shared reference sigma_p^2 to every
pair), so the two fits coincide: the difference is the covariance they claim.  Each ratio is
followed by its Monte Carlo standard error (± one).
"""

from __future__ import annotations

import argparse

import numpy as np

from tmakit.batch.ml import estimate_with_sensor_errors
from tmakit.bounds.fim import crlb_with_sensor_errors
from tmakit.data import MeasurementSet
from tmakit.reproduce import chan_ho1994, ho_xu2004


def reported(meas: MeasurementSet, sigma: float, rng: np.random.Generator) -> MeasurementSet:
    """The set with every distinct sensor position off by one draw of N(0, sigma^2 I)."""
    keys, label = np.unique(np.concatenate([meas.sensor_state[:, :3],
                                            meas.ref_sensor_state[:, :3]]), axis=0,
                            return_inverse=True)
    err = rng.standard_normal((keys.shape[0], 3)) * sigma
    label = label.ravel()
    own, ref = meas.sensor_state.copy(), meas.ref_sensor_state.copy()
    own[:, :3] += err[label[:len(meas)]]
    ref[:, :3] += err[label[len(meas):]]
    return MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                  meas.sigma_si, own, meas.time_ref, ref, meas.metadata)


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layout", choices=("ho-xu", "chan-ho"), default="ho-xu")
    parser.add_argument("--runs", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--sigma-p", type=float, nargs="+", default=None,
                        help="only these of the layout's levels (m; each keeps its seeds)")
    args = parser.parse_args()
    if args.layout == "ho-xu":
        scenario, levels = ho_xu2004.scenario_at(0.1), (0.03, 0.1, 0.3, 1.0, 3.0)
        blocks = (slice(0, 3), slice(3, 6))
        print(f"Ho & Xu's 5 moving sensors, TDOA + FDOA, sigma_rd 0.1 m, {args.runs} runs")
    else:
        scenario, levels = chan_ho1994.scenario_at(10.0), (3.0, 10.0, 30.0, 100.0, 300.0)
        blocks = (slice(0, 2),)
        print(f"Chan & Ho's 10 sensors, TDOA, sigma_rd 10 m, {args.runs} runs")
    motion, truth = scenario.motion, scenario.theta
    print("sigma_p (m) | bound loss (pos, vel) | accounting ML / CRLB (pos, vel) | "
          "ignoring ML / CRLB (pos, vel)")
    for k, sigma in enumerate(levels):
        if args.sigma_p is not None and not any(np.isclose(sigma, args.sigma_p)):
            continue
        rng = np.random.default_rng(args.seed + 1000 * k)
        bound, known = crlb_with_sensor_errors(scenario.simulate(rng=0, noise=False), motion,
                                               truth, sigma)
        err_a, err_i, nees_a, nees_i = [], [], [], []
        for run in range(args.runs):
            meas = reported(scenario.simulate(rng=args.seed + 1000 * k + run), sigma, rng)
            accounting, ignoring = estimate_with_sensor_errors(meas, motion, sigma)
            for fit, errs, nees in ((accounting, err_a, nees_a), (ignoring, err_i, nees_i)):
                e = fit.estimate - truth
                errs.append(e)
                nees.append(float(e @ np.linalg.solve(fit.covariance, e)) / e.size)
        cov, base = bound.covariance, known.covariance
        row = [f"{sigma:11.3g}", " ".join(
            f"{np.sqrt(np.trace(cov[b, b]) / np.trace(base[b, b])):.3g}x" for b in blocks)]
        for errs, nees in ((np.array(err_a), nees_a), (np.array(err_i), nees_i)):
            sq = [np.sum(errs[:, b] ** 2, 1) / np.trace(cov[b, b]) for b in blocks]
            row.append(" ".join(f"{q.mean():.3f}±{q.std(ddof=1) / np.sqrt(q.size):.3f}"
                                for q in sq) + f" (NEES/dim {np.mean(nees):.3g})")
        print(" | ".join(row))


if __name__ == "__main__":
    main()
