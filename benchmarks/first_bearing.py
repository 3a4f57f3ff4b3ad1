"""Tracking from the first bearing: the two scenarios of Ristic et al. (2004, ch. 6).

The scenarios as Leong, Arulampalam, Lamahewa & Abhayapala (2014) coded them in their
published MATLAB script (``leong2014.py`` gives every number and how run i
of a scenario draws its target path and bearings: ``numpy.random.default_rng([seed, s, i])``).

The filters start **only from the priors** (never from the truth): range interval of Leong
et al.'s Gaussian sum (the true initial range ± 3 sigma_r, floored at a tenth of it: 499 m
to 10,990 m and 1,000 m to 22,010 m) and a largest speed (``--speed-max``, default 10 kn
and 25 kn, the targets doing 4 and 15 kn):

* ``gsf`` (cubature components, ``--component``) and ``pf`` (``--particles``), both from
  :class:`tmakit.BearingPrior` at the first bearing, and ``mpekf`` (the modified polar EKF,
  Aidala & Hammel 1983) from its moments;
* ``ekf batch``: today's default start, a batch estimate over the shortest good initial
  window (no estimate before it);
* ``stonesoup ekf``: Stone Soup's EKF started as its bearings-only example starts it, from
  the **true** initial state with covariance ``diag(1, 1, 1, 1)`` (m^2, m^2/s^2; the
  example's own numbers), its ``ConstantVelocity`` model having the same q~;
* ``bayes`` (not by default): the exact posterior mean and covariance from the same prior
  for q~ = 0 (resample-move over the initial state, ``--draws``; run with
  ``--q-density 0``), the best any filter from this prior can do: where the filters sit
  well above the PCRB and ``bayes`` sits with them, the bound is what is out of reach.

Printed per filter and scenario: RMS position error / PCRB averaged over the steps after
the own-ship manoeuvre has taken effect (from the first sample after the turn on: k >= 17
and k >= 16; a filter without an estimate at a step, the batch start before its window
ends, is averaged over the steps where it has one), the same over the last quarter of the
steps, tracks lost (final error > 5x the final bound), the share of (run, step) pairs
from the first bearing on with the truth inside the 95 % position ellipse (steps without an
estimate count as outside), and for ``gsf`` both smoothers' RMS against the filtered one
and their 95 %-ellipse coverage: the Gaussian-sum smoother (each component along its
lineage, :mod:`tmakit.filters.smoothing`) and the RTS smoother on the sum's moments.
The PCRB is the Tichavský recursion (:func:`tmakit.bounds.pcrb.deterministic_pcrb`) along
each run's true path, with ``J_0`` the inverse of the prior's covariance at the first bearing
(:meth:`tmakit.BearingPrior.gaussian`, its exact moments), the same continuous white-noise
``Q`` and bearing noise as the truth; its RMS over runs.  The prior the filters start from
has hard edges (the range interval, the speed disc), so it has no finite Fisher information
and the Van Trees inequality does not apply to it as it stands; any smooth prior of the same
covariance has at least ``P_0^-1`` of information (the Gaussian has the least), so a larger
``J_0`` would only lower the bound.  Printed beside it, the PCRB of Leong et al.'s own
coding (:func:`leong2014.gaussian_prior`: their CKF's Gaussian prior, drawn about the truth
in each run, ``J_0`` its exact information), which is below ours at every step: their
filters are told the speed to 2 kn and that the target closes.  With ``bayes`` among the
filters each filter's RMS is also given over the exact posterior's (RMS/exact), the part of
its distance to the bound that is the filter's and not the problem's
(``first_bearing_exact.py`` checks that reference independently).

    PYTHONPATH=src python benchmarks/first_bearing.py [--runs 100] [--seed 0]
        [--filters gsf pf mpekf ekf-batch stonesoup bayes] [--scenarios moderate high] [--speed]
        [--q-density Q] [--draws N]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
import warnings

import numpy as np
from leong2014 import Q_DENSITY, SCENARIOS, gaussian_prior, simulate

import tmakit as tk
from tmakit.bounds.pcrb import deterministic_pcrb
from tmakit.data import MeasurementSet
from tmakit.filters import first_bearing, smooth
from tmakit.tracking import BearingInitiator

CHI2_95_2DOF = 5.991464547107979


def bound(meas: MeasurementSet, truth: np.ndarray, prior: tk.BearingPrior,
          q_density: float = Q_DENSITY) -> np.ndarray:
    """PCRB position MSE (K+1,) from the first bearing on, along this run's truth."""
    first = first_bearing(meas)
    _, cov = prior.gaussian(first, 2)
    rest = meas.take(np.arange(1, len(meas)))
    b = deterministic_pcrb(rest, truth[0], cov, first.time, q_density=q_density)
    mse = np.empty(len(meas))
    mse[0] = cov[0, 0] + cov[1, 1]
    mse[1:] = b.position_rms**2
    return mse


def gaussian_bound(meas: MeasurementSet, truth: np.ndarray, sc: object,
                   rng: np.random.Generator, q_density: float = Q_DENSITY) -> np.ndarray:
    """The same PCRB from Leong et al.'s Gaussian prior of this run (their coding)."""
    first = first_bearing(meas)
    _, cov = gaussian_prior(sc, first, rng)
    b = deterministic_pcrb(meas.take(np.arange(1, len(meas))), truth[0], cov, first.time,
                           q_density=q_density)
    return np.concatenate([[cov[0, 0] + cov[1, 1]], b.position_rms**2])


def stonesoup_ekf(meas: MeasurementSet, truth0: np.ndarray, q_density: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Stone Soup's EKF from the true initial state, covariance diag(1, 1, 1, 1)."""
    import datetime as dt

    from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.array import CovarianceMatrix, StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    epoch = dt.datetime(2000, 1, 1)
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(q_density),
                                                   ConstantVelocity(q_density)])
    predictor, updater = ExtendedKalmanPredictor(trans), ExtendedKalmanUpdater(None)
    x0 = truth0[[0, 2, 1, 3]]
    state = GaussianState(StateVector(x0), CovarianceMatrix(np.eye(4)), timestamp=epoch)
    means, covs = [], []
    for k in range(len(meas)):
        t = epoch + dt.timedelta(seconds=float(meas.time[k]))
        s = meas.sensor_state[k]
        model = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                     noise_covar=CovarianceMatrix([[meas.sigma_si[k] ** 2]]),
                                     translation_offset=StateVector([s[0], s[1]]))
        det = Detection(StateVector([[math.pi / 2 - meas.value_si[k]]]), timestamp=t,
                        measurement_model=model)
        if k:
            pred = predictor.predict(state, timestamp=t)
            state = updater.update(SingleHypothesis(pred, det))
        v = np.asarray(state.state_vector, dtype=float).ravel()[[0, 2, 1, 3]]
        p = np.asarray(state.covar, dtype=float)[np.ix_([0, 2, 1, 3], [0, 2, 1, 3])]
        means.append(v)
        covs.append(p)
    return np.array(means), np.array(covs)


def bayes_reference(meas: MeasurementSet, prior: tk.BearingPrior, draws: int,
                    rng: np.random.Generator, moves: int = 8) -> dict:
    """The exact posterior for q~ = 0 (a function of the initial state x0): resample-move.

    ``draws`` initial states from the prior at the first bearing, weighted by the likelihood
    of the bearings so far; when the effective sample size falls below half, resampled and
    moved by ``moves`` random-walk Metropolis steps on prior x likelihood (Gilks & Berzuini
    2001), so the cloud stays exact after the data collapse the prior.  Gives the weighted
    mean and covariance at each step and the effective sample size.
    """
    first = first_bearing(meas)
    sensor, z, sigma = meas.sensor_state[:, :2], meas.value_si, meas.sigma_si
    dt = meas.time - first.time
    rows = np.flatnonzero(np.arange(len(meas)) != first.row)

    def log_target(x0: np.ndarray, upto: int) -> np.ndarray:
        r = np.hypot(*(x0[:, :2] - first.sensor[:2]).T)
        b = np.arctan2(*(x0[:, :2] - first.sensor[:2]).T)
        out = -2.0 * np.log(r) - 0.5 * (np.angle(np.exp(1j * (b - first.bearing)))
                                        / first.sigma) ** 2
        out[(r < prior.range_min) | (r > prior.range_max)
            | (np.hypot(x0[:, 2], x0[:, 3]) > prior.speed_max)] = -np.inf
        for k in rows[rows <= upto]:
            rel = x0[:, :2] + dt[k] * x0[:, 2:] - sensor[k]
            d = np.angle(np.exp(1j * (z[k] - np.arctan2(rel[:, 0], rel[:, 1]))))
            out -= 0.5 * (d / sigma[k]) ** 2
        return out

    x0 = prior.sample(first, draws, rng)
    logw = np.zeros(draws)
    k_all = len(meas)
    est, cov, ess = np.zeros((k_all, 4)), np.zeros((k_all, 4, 4)), np.zeros(k_all)
    for k in range(k_all):
        if k != first.row:
            rel = x0[:, :2] + dt[k] * x0[:, 2:] - sensor[k]
            d = np.angle(np.exp(1j * (z[k] - np.arctan2(rel[:, 0], rel[:, 1]))))
            logw -= 0.5 * (d / sigma[k]) ** 2
        w = np.exp(logw - logw.max())
        w /= w.sum()
        x = x0.copy()
        x[:, :2] += dt[k] * x0[:, 2:]
        est[k] = w @ x
        dev = x - est[k]
        cov[k] = (dev * w[:, None]).T @ dev
        ess[k] = 1.0 / np.sum(w**2)
        if ess[k] < draws / 2:
            x0 = x0[np.minimum(np.searchsorted(np.cumsum(w), rng.random(draws)), draws - 1)]
            logw[:] = 0.0
            chol = np.linalg.cholesky(0.3 * np.cov(x0.T) + 1e-9 * np.eye(4))
            lt = log_target(x0, k)
            for _ in range(moves):
                prop = x0 + rng.standard_normal((draws, 4)) @ chol.T
                lp = log_target(prop, k)
                take = np.log(rng.random(draws)) < lp - lt
                x0[take], lt[take] = prop[take], lp[take]
    return {"est": est, "cov": cov, "smoothed": None, "ess": ess}


def run_filter(name: str, meas: MeasurementSet, truth: np.ndarray, prior: tk.BearingPrior,
               args: argparse.Namespace, i: int) -> dict:
    """Estimates (K+1, 4) (NaN before a start), covariances, and the smoothed tracks."""
    k_all = len(meas)
    est = np.full((k_all, 4), np.nan)
    cov = np.full((k_all, 4, 4), np.nan)
    sm = None
    if name == "stonesoup":
        e, c = stonesoup_ekf(meas, truth[0], args.q_density)
        return {"est": e, "cov": c, "smoothed": None}
    if name == "bayes":
        return bayes_reference(meas, prior, args.draws, np.random.default_rng([args.seed, 8, i]))
    if name == "ekf-batch":
        try:
            tr = tk.track(meas, "ekf", q_density=args.q_density)
        except tk.tracking.TrackingError:
            return {"est": est, "cov": cov, "smoothed": None}
    else:
        kw = {"particles": args.particles, "rng": [args.seed, 7, i]} if name == "pf" else {}
        if name != "pf":
            kw = {"settings": {"component": args.component, "iterations": args.iterations,
                               "history": name == "gsf"}}
        if name == "mpekf":
            kw = {}
        tr = tk.track(meas, name, q_density=args.q_density,
                      initiator=BearingInitiator(prior), **kw)
        if name == "gsf":
            moments = dataclasses.replace(tr, extra=dataclasses.replace(tr.extra, history=None))
            sm = {"sum": smooth(tr), "moments": smooth(moments)}
    idx = np.searchsorted(meas.time, tr.times)
    est[idx], cov[idx] = tr.states, tr.covariances
    return {"est": est, "cov": cov, "smoothed": sm}


def scores(est: np.ndarray, cov: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Squared position errors (K+1,) and whether the truth is inside the 95 % ellipse."""
    d = est[:, :2] - truth[:, :2]
    ok = np.all(np.isfinite(d), axis=1)
    m2 = np.full(len(d), np.inf)
    m2[ok] = np.einsum("ki,ki->k", d[ok], np.linalg.solve(cov[ok, :2, :2],
                                                          d[ok, :, None])[..., 0])
    return np.sum(d**2, axis=1), m2 <= CHI2_95_2DOF


def evaluate(scenario: str, filters: list[str], args: argparse.Namespace) -> None:
    sc = SCENARIOS[scenario]
    prior = sc.prior()
    after = sc.after
    k_all = sc.steps + 1
    err2 = {f: np.full((args.runs, k_all), np.nan) for f in filters}
    inside = {f: np.zeros((args.runs, k_all), dtype=bool) for f in filters}
    serr2: dict[str, dict[str, np.ndarray]] = {f: {} for f in filters}
    sinside: dict[str, dict[str, np.ndarray]] = {f: {} for f in filters}
    clock = dict.fromkeys(filters, 0.0)
    ess = {f: np.full(k_all, np.inf) for f in filters}
    mse = np.zeros((args.runs, k_all))
    mse_gaussian = np.zeros((args.runs, k_all))
    s_index = list(SCENARIOS).index(scenario)
    for i in range(args.runs):
        meas, truth = simulate(sc, np.random.default_rng([args.seed, s_index, i]),
                               args.q_density)
        mse[i] = bound(meas, truth, prior, args.q_density)
        mse_gaussian[i] = gaussian_bound(meas, truth, sc, np.random.default_rng([args.seed, 5, i]),
                                         args.q_density)
        for f in filters:
            t0 = time.process_time()
            out = run_filter(f, meas, truth, prior, args, i)
            clock[f] += time.process_time() - t0
            err2[f][i], inside[f][i] = scores(out["est"], out["cov"], truth)
            if "ess" in out:
                ess[f] = np.minimum(ess[f], out["ess"])
            for kind, sm in (out["smoothed"] or {}).items():
                e2, hit = scores(sm.states, sm.covariances, truth)
                serr2[f].setdefault(kind, np.full((args.runs, k_all), np.nan))[i] = e2
                sinside[f].setdefault(kind, np.zeros((args.runs, k_all), dtype=bool))[i] = hit
    pcrb = np.sqrt(mse.mean(axis=0))
    print(f"\n== {scenario}: {args.runs} runs, seed {args.seed}; prior {prior.describe()}; "
          f"q~ = {args.q_density:g} m^2/s^3; after the manoeuvre: k >= {after}")
    print(f"PCRB position RMS (m) at k = 0, {after}, {k_all - 1}: {pcrb[0]:.0f}, "
          f"{pcrb[after]:.0f}, {pcrb[-1]:.0f}")
    pcrb_g = np.sqrt(mse_gaussian.mean(axis=0))
    share = pcrb[after:] / pcrb_g[after:]
    print(f"the same from Leong et al.'s Gaussian prior (sigma_r {sc.sigma_r:g} m, speed to 2 kn, "
          f"course the reciprocal bearing): {pcrb_g[0]:.0f}, {pcrb_g[after]:.0f}, "
          f"{pcrb_g[-1]:.0f}; ours / theirs after the turn "
          f"{np.min(share):.2f}..{np.max(share):.2f}")
    exact = np.sqrt(np.nanmean(err2["bayes"], axis=0)) if "bayes" in filters else None
    extra = " RMS/exact after manoeuvre |" if exact is not None else ""
    print("| filter | RMS/PCRB after manoeuvre | RMS/PCRB, last quarter | final RMS (m) | final "
          "PCRB (m) | lost (> 5x bound) | truth in 95 % ellipse | runs with an estimate at k=0 "
          "| CPU s/run |" + extra)
    print("|---|---|---|---|---|---|---|---|---|" + ("---|" if extra else ""))
    for f in filters:
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # steps without any estimate
            rms = np.sqrt(np.nanmean(err2[f], axis=0))
        steps = rms[after:] / pcrb[after:]
        ratio = float(np.nanmean(steps)) if np.any(np.isfinite(steps)) else math.nan
        missing = int(np.sum(~np.isfinite(steps)))
        late = float(np.nanmean((rms / pcrb)[-(k_all // 4):]))
        final_err = np.sqrt(err2[f][:, -1])
        lost = int(np.sum(~(final_err <= 5 * np.sqrt(mse[:, -1]))))
        cover = float(np.mean(inside[f]))
        started = int(np.sum(np.isfinite(err2[f][:, 0])))
        note = f" ({missing} steps without any estimate left out)" if missing else ""
        print(f"| {f} | {ratio:.3f}{note} | {late:.3f} | {rms[-1]:.0f} | {pcrb[-1]:.0f} | "
              f"{lost} / {args.runs} | {100 * cover:.1f} % | {started} | "
              f"{clock[f] / args.runs:.3f} |"
              + (f" {np.nanmean(rms[after:] / exact[after:]):.3f} |" if exact is not None else ""))
        if np.isfinite(ess[f][0]):
            print(f"  smallest effective sample size over the runs, k = 0..{k_all - 1}: "
                  + ", ".join(f"{e:.0f}" for e in ess[f]))
        if args.per_step:
            print("  per step (k: RMS / PCRB, m): " + ", ".join(
                f"{k}: {rms[k]:.0f}/{pcrb[k]:.0f}" for k in range(k_all)))
    for f in (f for f in filters if serr2[f]):
        rms = np.sqrt(np.nanmean(err2[f], axis=0))
        for kind, e2 in serr2[f].items():
            srms = np.sqrt(np.nanmean(e2, axis=0))
            label = {"sum": "Gaussian-sum smoother (per component)",
                     "moments": "RTS on the sum's moments"}[kind]
            print(f"{f} {label}: smoothed <= filtered RMS (to 1e-9) at "
                  f"{int(np.sum(srms <= rms * (1 + 1e-9)))} of "
                  f"{k_all} steps; first step {srms[0]:.0f} m against {rms[0]:.0f} m "
                  f"(ratio {srms[0] / rms[0]:.3f}); worst ratio {np.max(srms / rms):.3f}; "
                  f"truth in the smoothed 95 % ellipse {100 * np.mean(sinside[f][kind]):.1f} %")
            print("  per step (k: filtered / smoothed RMS, m): " + ", ".join(
                f"{k}: {rms[k]:.0f}/{srms[k]:.0f}" for k in range(0, k_all, 4)))


def speed(args: argparse.Namespace) -> None:
    """Per-step CPU time: EKF, the Gaussian sum with 8 components, the first-bearing PF."""
    sc = SCENARIOS["moderate"]
    meas, _ = simulate(sc, np.random.default_rng([args.seed, 9, 0]))
    prior = sc.prior()
    first = first_bearing(meas)
    rest = meas.take(np.arange(1, len(meas)))
    steps = len(rest)
    from tmakit.filters import ExtendedKalmanFilter, GaussianSumFilter, ParticleFilter
    from tmakit.motion.dynamics import NearlyConstantVelocity

    dyn = NearlyConstantVelocity(2, 0.0, args.q_density)
    mean, cov = prior.gaussian(first)

    def ekf() -> object:
        return ExtendedKalmanFilter(mean, cov, first.time, dynamics=dyn).run(rest)

    def gsf8() -> object:  # 8 components throughout: no split, prune or merge
        w, m, p = prior.mixture(first, 2, components=8)
        return GaussianSumFilter.from_mixture(w, m, p, first.time, dynamics=dyn,
                                              component="ekf", split_threshold=0.0,
                                              prune=0.0, merge=0.0).run(rest)

    def gsf8_ckf() -> object:
        w, m, p = prior.mixture(first, 2, components=8)
        return GaussianSumFilter.from_mixture(w, m, p, first.time, dynamics=dyn,
                                              component="ckf", split_threshold=0.0,
                                              prune=0.0, merge=0.0).run(rest)

    def pf() -> object:
        return ParticleFilter.from_first_bearing(prior, first, particles=10_000, rng=1,
                                                 dynamics=dyn).run(rest)

    cases = {"ekf": ekf, "gsf 8 ekf components": gsf8, "gsf 8 cubature components": gsf8_ckf,
             "pf 10,000 from the first bearing": pf}
    for f in cases.values():
        f()  # compile, warm caches
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(args.repeat):
        for name, f in cases.items():  # alternating, on a shared machine
            t0 = time.process_time()
            f()
            times[name].append((time.process_time() - t0) / steps * 1e6)
    print(f"\n== speed: per-step CPU time (us), {steps} steps of the moderate scenario, "
          f"{args.repeat} alternating repetitions: median [25 %, 75 %]")
    base = float(np.median(times["ekf"]))
    for name, t in times.items():
        q1, med, q3 = np.percentile(t, [25, 50, 75])
        print(f"| {name} | {med:.1f} [{q1:.1f}, {q3:.1f}] | {med / base:.2f}x ekf |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--particles", type=int, default=10_000)
    ap.add_argument("--component", default="ekf", help="the Gaussian sum's: ekf, ukf, ckf")
    ap.add_argument("--iterations", type=int, default=None,
                    help="linearisations per update of EKF components (default the filter's)")
    ap.add_argument("--filters", nargs="+", default=["gsf", "pf", "mpekf", "ekf-batch",
                                                         "stonesoup"])
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    ap.add_argument("--speed", action="store_true", help="only the speed comparison")
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--per-step", action="store_true", help="print RMS and PCRB per step")
    ap.add_argument("--q-density", type=float, default=Q_DENSITY,
                    help="the target's q~ (m^2/s^3): truth, filters and bound")
    ap.add_argument("--draws", type=int, default=100_000,
                    help="prior draws of the bayes reference")
    args = ap.parse_args()
    if args.speed:
        speed(args)
        return
    for s in args.scenarios:
        evaluate(s, args.filters, args)


if __name__ == "__main__":
    main()
