"""tmakit beside ewgeo (O'Donoughue's companion code) on the same TDOA and FDOA problems.

    python benchmarks/geolocation_ewgeo.py [--runs 200] [--seed 1]

ewgeo (PyPI ``ewgeo``, in the ``bench`` extra) needs Python 3.12 or newer.  Two problems, each
at several noise levels, the same seeded measurements given to both libraries:

1. TDOA, the ten sensors of ``tmakit.reproduce.chan_ho1994`` (2-D, one snapshot against the
   first sensor, noise shared through it): tmakit's ML (no guess, ``tk.estimate``) and closed
   form (Chan & Ho) beside ewgeo's ML (its grid search, zoomed level by level from a 80 km
   square about the sensors to a mesh finer than the noise), its Chan & Ho and its iterative
   least squares started at its Chan & Ho.
   tmakit's ML is timed one data set at a time (``tk.estimate``) and batched over the runs
   (``MaximumLikelihood.fit_many``, as its Monte Carlo runs it: the time per solve is the
   batch's over the runs).
2. TDOA + FDOA, a stationary emitter heard by Ho & Xu's five moving sensors
   (``tmakit.reproduce.ho_xu2004``; 3-D, carrier known, one snapshot against the first
   sensor): tmakit's ML beside ewgeo's hybrid system (its TDOA and FDOA systems joined), its
   ML (the zoomed grid, 21 points a dimension from a 16 km cube about the sensors) and its
   least squares started there.  ewgeo's range-rate differences are tmakit's negated.

Prints, per problem and noise level, each solver's position MSE over the CRLB's trace with
its Monte Carlo standard error, and its CPU time per solve: the median over the runs with
the quartiles (a batch: the median, and the range, over five passes of the whole batch);
then tmakit's ML speed-up over ewgeo's ML (ratio of the medians), one solve at a time and
batched.  The machine's load average is printed before and after.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import tmakit as tk
from tmakit.batch.hyperbolic import two_stage_wls
from tmakit.batch.ml import MaximumLikelihood
from tmakit.core.units import SPEED_OF_LIGHT
from tmakit.motion import Stationary
from tmakit.reproduce import chan_ho1994, ho_xu2004
from tmakit.scenario import MeasurementPlan, Scenario


def timed(f: object, *args: object, **kwargs: object) -> tuple[object, float]:
    """Call ``f(*args, **kwargs)``; give its value and the process's CPU time (s).

    CPU time, not wall time: on a shared machine the wall time of a millisecond call is
    mostly other processes' turns.
    """
    t0 = time.process_time()
    value = f(*args, **kwargs)  # type: ignore[operator]
    return value, time.process_time() - t0


Results = dict[str, tuple[list[float], list[float]]]


def batched(sets: list, motion: object, passes: int = 5) -> tuple[list, list[float]]:
    """Fit the runs in one batch ``passes`` times; give the fits and each pass's time a solve."""
    times = []
    for _ in range(passes):
        fits, took = timed(MaximumLikelihood().fit_many, sets, motion)
        times.append(took / len(sets))
    return fits, times  # type: ignore[return-value]


def report(out: Results, crlb_trace: float, prefix: str) -> None:
    """Print each solver's MSE / CRLB (± standard error) and time per solve, and the speed-ups."""
    cells = []
    for name, (err, t) in out.items():
        q = np.asarray(err) / crlb_trace
        spread = (f"{np.min(t) * 1e3:.3f}-{np.max(t) * 1e3:.3f}" if "batched" in name else
                  f"{np.percentile(t, 25) * 1e3:.3f}-{np.percentile(t, 75) * 1e3:.3f}")
        cells.append(f"{name} {q.mean():.3f}±{q.std(ddof=1) / np.sqrt(q.size):.3f} "
                     f"[{np.median(t) * 1e3:.3f} ms, {spread}]")
    ewgeo = np.median(out["ewgeo ML (zoomed grid)"][1])
    one, many = np.median(out["tmakit ML"][1]), np.median(out["tmakit ML batched (fit_many)"][1])
    print(f"  {prefix}: " + "; ".join(cells)
          + f"; ML speed-up over ewgeo's ML: {ewgeo / one:.1f}x one at a time, "
          f"{ewgeo / many:.1f}x batched")


def ewgeo_tdoa(sensors: np.ndarray, sigma_m: float) -> object:
    """ewgeo's TDOA system: sensor 0 the reference, difference covariance sigma^2 (I+11')/2."""
    from ewgeo.tdoa import TDOAPassiveSurveillanceSystem

    n = sensors.shape[0]
    # per-sensor ranges of arrival with variance sigma^2 / 2: differences as tmakit's
    return TDOAPassiveSurveillanceSystem(x=sensors.T, cov=np.eye(n) * sigma_m**2 / 2,
                                         variance_is_toa=False, ref_idx=0, do_resample=True)


def zoomed_ml(pss: object, zeta: np.ndarray, centre: np.ndarray, half: float,
              finest: float, points: int = 41) -> np.ndarray:
    """ewgeo's grid ML, zoomed by 4 per level until the mesh is finer than ``finest``."""
    from ewgeo.utils.search_space import SearchSpace

    levels = 1
    while 2 * half / (points - 1) / 4 ** (levels - 1) > finest:
        levels += 1
    space = SearchSpace(x_ctr=centre, max_offset=np.full(centre.size, half),
                        points_per_dim=np.full(centre.size, points))
    est, _, _ = pss.max_likelihood(zeta, search_space=space,  # type: ignore[attr-defined]
                                   num_levels=levels, zoom_per_level=4.0)
    return np.asarray(est, dtype=float).ravel()


def tdoa_problem(runs: int, seed: int) -> None:
    """Problem 1: Chan & Ho's ten sensors, TDOA."""
    sensors = np.column_stack([chan_ho1994.SENSORS, np.zeros(10)])
    truth = np.array([chan_ho1994.SOURCE["x"], chan_ho1994.SOURCE["y"]])
    print(f"TDOA, 10 sensors (2-D), {runs} runs a level: MSE / CRLB ± SE  [time per solve: "
          "median, spread]")
    for k, sigma in enumerate((1.0, 10.0, 100.0, 1000.0)):
        scn = chan_ho1994.scenario_at(sigma)
        crlb = float(np.trace(tk.crlb(scn).covariance))
        pss = ewgeo_tdoa(sensors[:, :2], sigma)
        cov = sigma**2 * (np.eye(9) + np.ones((9, 9))) / 2
        out: Results = {}

        def add(name: str, est: object, took: float, out: Results = out) -> None:
            err, times = out.setdefault(name, ([], []))
            err.append(float(np.sum((np.asarray(est, dtype=float)[:2] - truth) ** 2)))
            times.append(took)

        for run in range(runs):
            meas = scn.simulate(rng=seed + 1000 * k + run)
            rd = SPEED_OF_LIGHT * meas.value_si  # the rows are s2..s10 against s1, in order
            fit, took = timed(tk.estimate, meas, scn.motion)
            add("tmakit ML", fit.estimate, took)  # type: ignore[attr-defined]
            pos, took = timed(two_stage_wls, sensors[1:], sensors[0], rd, cov, height=0.0)
            add("tmakit Chan-Ho", pos[0], took)  # type: ignore[index]
            ch, took = timed(pss.chan_ho, rd)  # type: ignore[attr-defined]
            add("ewgeo Chan-Ho", ch, took)
            ls, took = timed(pss.least_square, rd,  # type: ignore[attr-defined]
                             x_init=np.asarray(ch, dtype=float).ravel())
            add("ewgeo LS (from its Chan-Ho)", ls[0], took)  # type: ignore[index]
            ml, took = timed(zoomed_ml, pss, rd, sensors[:, :2].mean(axis=0), 40e3, sigma / 20)
            add("ewgeo ML (zoomed grid)", ml, took)
        sets = scn.simulate_many([seed + 1000 * k + run for run in range(runs)])
        fits, times = batched(sets, scn.motion)
        out["tmakit ML batched (fit_many)"] = (
            [float(np.sum((f.estimate - truth) ** 2)) for f in fits], times)
        report(out, crlb, f"sigma {sigma:g} m (CRLB {np.sqrt(crlb):.4g} m)")


def fdoa_scenario(sigma: float) -> Scenario:
    """Ho & Xu's five moving sensors, TDOA + FDOA, a stationary emitter."""
    moving = ho_xu2004.scenario_at(sigma)
    plans = [MeasurementPlan(p.kind, p.sensor, p.times, p.sigma, ref_sensor=p.ref_sensor,
                             known_carrier=p.kind == "fdoa") for p in moving.plans]
    return Scenario("fdoa-static", Stationary(3), {"x": 2000.0, "y": 2500.0, "z": 3000.0},
                    moving.sensors, plans, {"carrier": ho_xu2004.CARRIER_HZ})


def ewgeo_hybrid(sigma_m: float) -> object:
    """ewgeo's TDOA + FDOA system on Ho & Xu's sensors, the noise as tmakit's."""
    from ewgeo.fdoa import FDOAPassiveSurveillanceSystem
    from ewgeo.hybrid import HybridPassiveSurveillanceSystem

    x, v = ho_xu2004.SENSORS.T, ho_xu2004.VELOCITIES.T
    rate = ho_xu2004.RATE_RATIO * sigma_m
    fdoa = FDOAPassiveSurveillanceSystem(x=x, vel=v, cov=np.eye(5) * rate**2 / 2, ref_idx=0,
                                         do_resample=True)
    return HybridPassiveSurveillanceSystem(tdoa=ewgeo_tdoa(x.T, sigma_m), fdoa=fdoa)


def fdoa_problem(runs: int, seed: int) -> None:
    """Problem 2: TDOA + FDOA, five moving sensors, a stationary emitter (3-D)."""
    print(f"TDOA + FDOA, 5 moving sensors (3-D), {runs} runs a level: MSE / CRLB ± SE "
          "[time per solve: median, spread]")
    centre = ho_xu2004.SENSORS.mean(axis=0)
    for k, sigma in enumerate((0.1, 1.0, 10.0)):
        scn = fdoa_scenario(sigma)
        crlb = float(np.trace(tk.crlb(scn).covariance))
        pss = ewgeo_hybrid(sigma)
        out: Results = {}
        failed = 0
        for run in range(runs):
            meas = scn.simulate(rng=seed + 1000 * k + run)
            tdoa, fdoa = meas.kind_mask("tdoa"), meas.kind_mask("fdoa")
            zeta = np.concatenate([SPEED_OF_LIGHT * meas.value_si[tdoa],  # rows s2..s5, in order
                                   SPEED_OF_LIGHT / ho_xu2004.CARRIER_HZ * meas.value_si[fdoa]])
            fit, t_ml = timed(tk.estimate, meas, scn.motion)
            failed += fit.status != "converged"  # type: ignore[attr-defined]
            ml, t_eml = timed(zoomed_ml, pss, zeta, centre, 8e3, sigma / 20, 21)
            ls, t_ls = timed(pss.least_square, zeta, x_init=ml)  # type: ignore[attr-defined]
            for name, est, took in (("tmakit ML", fit.estimate, t_ml),  # type: ignore[attr-defined]
                                    ("ewgeo ML (zoomed grid)", ml, t_eml),
                                    ("ewgeo LS (from its ML)", np.ravel(ls[0]), t_ls)):  # type: ignore[index]
                err, times = out.setdefault(name, ([], []))
                err.append(float(np.sum((np.asarray(est, dtype=float) - scn.theta) ** 2)))
                times.append(took)
        sets = scn.simulate_many([seed + 1000 * k + run for run in range(runs)])
        fits, times = batched(sets, scn.motion)
        out["tmakit ML batched (fit_many)"] = (
            [float(np.sum((f.estimate - scn.theta) ** 2)) for f in fits], times)
        report(out, crlb, f"sigma {sigma:g} m (CRLB {np.sqrt(crlb):.4g} m)")
        print(f"    tmakit ML runs reported not converged: {failed}")


def main() -> None:
    """Run both problems."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    print("load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    tdoa_problem(args.runs, args.seed)
    fdoa_problem(args.runs, args.seed)
    print("load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
