"""How close can any estimator come to the PCRB from the first bearing? The exact posterior.

For a target without process noise (q~ = 0) the posterior is a density over the initial
state alone, ``p(x_0 | z_0..k) ∝ p(x_0) prod_j p(z_j | x_0)``, so its mean at every step
can be computed to any accuracy.  Here by adaptive importance sampling (population Monte
Carlo, Cappé, Guillin, Marin & Robert 2004), independently of the resample-move sampler of
``first_bearing.py --filters bayes``: at each step the proposal is a defensive mixture of
the prior (``--alpha``) and a multivariate t (4 dof) fitted to the previous iteration's
weighted cloud, refitted ``--iterations`` times, the last with ``--draws`` draws whose
self-normalised weights give the mean; the effective sample size says how good it is.
For the range-interval prior the sampler works in (log-range, bearing, vx, vy) at the first
bearing, where the log-uniform range is flat.

Two priors, on the scenarios of ``leong2014.py``:

* ``interval`` — tmakit's start (:class:`tmakit.BearingPrior`: log-uniform range over the
  interval, bearing from the first measurement, velocity uniform over the disc of the largest
  speed), the PCRB's ``J_0`` the inverse of its covariance, as ``first_bearing.py`` has it;
* ``gaussian`` — Leong et al.'s (:func:`leong2014.gaussian_prior`: their CKF's Gaussian,
  drawn about the truth in each run), the PCRB's ``J_0`` its exact Fisher information.

Printed: the exact posterior's RMS position error / PCRB averaged over the steps after the
own ship's turn (as ``first_bearing.py`` prints it for the filters), per step, and the
smallest effective sample size; with ``--compare`` (``interval`` only) the largest
distance between this mean and the resample-move one at each step after the turn.

    PYTHONPATH=src python benchmarks/first_bearing_exact.py [--runs 20] [--seed 0]
        [--scenarios moderate high] [--priors interval gaussian] [--draws N] [--compare]
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from first_bearing import bayes_reference, bound
from leong2014 import SCENARIOS, Scenario, gaussian_prior, simulate
from scipy.special import gammaln

import tmakit as tk
from tmakit.bounds.pcrb import deterministic_pcrb
from tmakit.data import MeasurementSet
from tmakit.filters import FirstBearing, first_bearing

DOF = 4.0  # the t proposal's degrees of freedom


@dataclass
class Target:
    """A posterior over the sampler's coordinates ``u``: its prior, and ``x_0`` from ``u``."""

    sample_prior: Callable[[int, np.random.Generator], np.ndarray]
    log_prior: Callable[[np.ndarray], np.ndarray]  # normalised; -inf outside the support
    state: Callable[[np.ndarray], np.ndarray]


def interval_target(prior: tk.BearingPrior, first: FirstBearing) -> Target:
    """The range-interval prior in u = (log-range, bearing, vx, vy) about the first sensor."""
    la, lb = math.log(prior.range_min), math.log(prior.range_max)
    vmax, b0, sb = prior.speed_max, first.bearing, first.sigma
    const = -math.log(lb - la) - math.log(math.pi * vmax**2) - 0.5 * math.log(2 * math.pi
                                                                              * sb**2)

    def sample(n: int, rng: np.random.Generator) -> np.ndarray:
        u = np.empty((n, 4))
        u[:, 0] = la + (lb - la) * rng.random(n)
        u[:, 1] = b0 + sb * rng.standard_normal(n)
        speed, course = vmax * np.sqrt(rng.random(n)), 2 * math.pi * rng.random(n)
        u[:, 2], u[:, 3] = speed * np.sin(course), speed * np.cos(course)
        return u

    def log_prior(u: np.ndarray) -> np.ndarray:
        out = const - 0.5 * ((u[:, 1] - b0) / sb) ** 2
        out[(u[:, 0] < la) | (u[:, 0] > lb) | (np.hypot(u[:, 2], u[:, 3]) > vmax)] = -np.inf
        return out

    def state(u: np.ndarray) -> np.ndarray:
        r = np.exp(u[:, 0])
        return np.column_stack([first.sensor[0] + r * np.sin(u[:, 1]),
                                first.sensor[1] + r * np.cos(u[:, 1]), u[:, 2], u[:, 3]])

    return Target(sample, log_prior, state)


def gaussian_target(mean: np.ndarray, cov: np.ndarray) -> Target:
    """A Gaussian prior over the Cartesian initial state."""
    chol = np.linalg.cholesky(cov)
    const = -np.sum(np.log(np.diag(chol))) - 2 * math.log(2 * math.pi)

    def log_prior(u: np.ndarray) -> np.ndarray:
        y = np.linalg.solve(chol, (u - mean).T)
        return const - 0.5 * np.sum(y**2, axis=0)

    return Target(lambda n, rng: mean + rng.standard_normal((n, 4)) @ chol.T, log_prior,
                  lambda u: u)


def _t_logpdf(u: np.ndarray, mean: np.ndarray, chol: np.ndarray) -> np.ndarray:
    q = np.sum(np.linalg.solve(chol, (u - mean).T) ** 2, axis=0)
    return (gammaln((DOF + 4) / 2) - gammaln(DOF / 2) - 2 * math.log(DOF * math.pi)
            - np.sum(np.log(np.diag(chol))) - (DOF + 4) / 2 * np.log1p(q / DOF))


def exact_posterior(meas: MeasurementSet, target: Target, draws: int, iterations: int,
                    alpha: float, rng: np.random.Generator
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Posterior mean positions (K, 2) for q~ = 0, their RMS spread (K,), and each step's
    effective sample size."""
    first = first_bearing(meas)
    sensor, z, sigma = meas.sensor_state[:, :2], meas.value_si, meas.sigma_si
    dt = meas.time - first.time
    rows = np.flatnonzero(np.arange(len(meas)) != first.row)

    def log_lik(x0: np.ndarray, upto: int) -> np.ndarray:
        out = np.zeros(len(x0))
        for j in rows[rows <= upto]:
            rel = x0[:, :2] + dt[j] * x0[:, 2:] - sensor[j]
            d = np.angle(np.exp(1j * (z[j] - np.arctan2(rel[:, 0], rel[:, 1]))))
            out -= 0.5 * (d / sigma[j]) ** 2
        return out

    mean, spread, ess = np.zeros((len(meas), 2)), np.zeros(len(meas)), np.zeros(len(meas))
    fit: tuple[np.ndarray, np.ndarray] | None = None
    for k in range(len(meas)):
        for it in range(iterations):
            n = draws if it == iterations - 1 else draws // 4
            if fit is None:
                u = target.sample_prior(n, rng)
                log_q = target.log_prior(u)
            else:
                m, chol = fit
                from_prior = rng.binomial(n, alpha)
                g = np.sqrt(rng.chisquare(DOF, n - from_prior) / DOF)
                u = np.vstack([target.sample_prior(from_prior, rng),
                               m + (rng.standard_normal((n - from_prior, 4)) @ chol.T)
                               / g[:, None]])
                log_q = np.logaddexp(math.log(alpha) + target.log_prior(u),
                                     math.log(1 - alpha) + _t_logpdf(u, m, chol))
            log_p = target.log_prior(u)
            keep = np.isfinite(log_p)
            u, x0 = u[keep], target.state(u[keep])
            log_w = log_p[keep] + log_lik(x0, k) - log_q[keep]
            w = np.exp(log_w - log_w.max())
            w /= w.sum()
            mu = w @ u
            dev = u - mu
            fit = mu, np.linalg.cholesky(1.5 * (dev * w[:, None]).T @ dev + 1e-12 * np.eye(4))
        pos = x0[:, :2] + dt[k] * x0[:, 2:]
        mean[k] = w @ pos
        spread[k] = math.sqrt(w @ np.sum((pos - mean[k]) ** 2, axis=1))
        ess[k] = 1.0 / np.sum(w**2)
    return mean, spread, ess


def evaluate(name: str, sc: Scenario, kind: str, args: argparse.Namespace) -> None:
    prior = sc.prior()
    k_all, after = sc.steps + 1, sc.after
    s_index = list(SCENARIOS).index(name)
    err2, mse = np.zeros((args.runs, k_all)), np.zeros((args.runs, k_all))
    ess = np.full(k_all, np.inf)
    gap = np.zeros(k_all)
    for i in range(args.runs):
        meas, truth = simulate(sc, np.random.default_rng([args.seed, s_index, i]), 0.0)
        first = first_bearing(meas)
        if kind == "interval":
            target = interval_target(prior, first)
            mse[i] = bound(meas, truth, prior, 0.0)
        else:
            m0, p0 = gaussian_prior(sc, first, np.random.default_rng([args.seed, 5, i]))
            target = gaussian_target(m0, p0)
            b = deterministic_pcrb(meas.take(np.arange(1, len(meas))), truth[0], p0,
                                   first.time)
            mse[i] = np.concatenate([[p0[0, 0] + p0[1, 1]], b.position_rms**2])
        mean, _, e = exact_posterior(meas, target, args.draws, args.iterations, args.alpha,
                                  np.random.default_rng([args.seed, 99, i]))
        err2[i] = np.sum((mean - truth[:, :2]) ** 2, axis=1)
        ess = np.minimum(ess, e)
        if args.compare and kind == "interval":
            ref = bayes_reference(meas, prior, args.compare,
                                  np.random.default_rng([args.seed, 8, i]))
            gap = np.maximum(gap, np.hypot(*(mean - ref["est"][:, :2]).T))
    rms, pcrb = np.sqrt(err2.mean(axis=0)), np.sqrt(mse.mean(axis=0))
    ratio = rms / pcrb
    print(f"\n== {name}, {kind} prior: {args.runs} runs, seed {args.seed}, q~ = 0; "
          f"{args.draws} draws x {args.iterations} iterations")
    print(f"exact posterior RMS/PCRB after the turn (k >= {after}): "
          f"{np.mean(ratio[after:]):.3f}; over the last quarter "
          f"{np.mean(ratio[-(k_all // 4):]):.3f}; final RMS / PCRB {rms[-1]:.0f} / "
          f"{pcrb[-1]:.0f} m")
    print("  per step after the turn (k: RMS/PCRB, m): " + ", ".join(
        f"{k}: {rms[k]:.0f}/{pcrb[k]:.0f}" for k in range(after, k_all)))
    print(f"  smallest effective sample size, k >= {after}: {ess[after:].min():.0f} "
          f"(all steps: {ess.min():.0f})")
    if args.compare and kind == "interval":
        print(f"  largest distance to the resample-move mean ({args.compare} draws), "
              f"k >= {after}: {gap[after:].max():.0f} m (RMS there "
              f"{rms[after + int(np.argmax(gap[after:]))]:.0f} m)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    ap.add_argument("--priors", nargs="+", default=["interval", "gaussian"],
                    choices=["interval", "gaussian"])
    ap.add_argument("--draws", type=int, default=100_000, help="draws of the last iteration")
    ap.add_argument("--iterations", type=int, default=3, help="proposal fits per step")
    ap.add_argument("--alpha", type=float, default=0.1, help="the prior's share of a proposal")
    ap.add_argument("--compare", type=int, default=0, metavar="DRAWS",
                    help="also run first_bearing.py's resample-move reference with DRAWS")
    args = ap.parse_args()
    for name in args.scenarios:
        for kind in args.priors:
            evaluate(name, SCENARIOS[name], kind, args)


if __name__ == "__main__":
    main()
