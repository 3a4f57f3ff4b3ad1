"""Agreement of the no-guess fit of many rows with and without its subset machinery.

Above ``tmakit.batch.ml.PRESOLVE_ROWS`` rows the no-guess fit (``tmakit.estimate(meas,
motion)``) scores its grid and converges its start on an evenly spread subset of rows, takes
the first full-size Gauss-Newton step with the subset's ``J'J`` scaled to every row
(``ml.subset_step``) and ends with a step checked by its residuals alone (the solver's
``polish``).  None of that should move the result: this study fits each set twice in the same
process, by default and with ``PRESOLVE_ROWS`` raised above every size (grid and solve on
every row, plain Levenberg-Marquardt), and prints per case

* status of both (``=`` when equal),
* ``dchi2``: the difference of the chi2,
* ``dtheta``: the largest difference of an estimated quantity (motion parameters and fitted
  nuisance) in units of its reported standard deviation (the plain fit's),
* ``dcov``: the largest difference of a covariance entry over the product of the two standard
  deviations (the plain fit's), i.e. relative to the entry's own scale,

* ``dth nopol``, ``dcov nopol``: the same for the default fit without its final polishing
  step (``ml.POLISH_DECREMENT = 0``) against the plain fit,
* CPU ms of the default and the plain fit,

and flags (``!!``) a case beyond 0.01 std, 0.01 in chi2, 1 % in covariance or a different
status (status and chi2 alone where both are ``unobservable``).  The sets: built-in scenarios
with bearings with their rows repeated at a higher rate
(``benchmarks/batch_speed.py``'s ``scaled``) and variants of ``bearings-only-2d``: a
stationary target, a 3-D constant-velocity target (bearing and elevation), a target due south
of the observer (its bearings cross +-180 deg), per-row sigmas, a second (fixed) sensor,
bearings beside Doppler and power (``gu2007`` with bearings), an observer on one straight leg
(range unobservable: the estimate along the unseen direction is arbitrary, so only status and
chi2 can agree), an observer that turns once by 4 deg (at 1 and 5 deg noise) and a target at
60 km (range poorly determined).  ``hoerst2010`` (curvilinear, the manoeuvre fit: about 15 s a
fit at 30,000 rows) only when asked (``--only hoerst2010 --sizes 30000``).

    PYTHONPATH=src python benchmarks/large_fit_agreement.py [--sizes 20001 30000 100000 200000]
        [--seeds 3] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import importlib.resources
import time
import tomllib

import numpy as np

import tmakit as tk
from tmakit.batch import ml
from tmakit.scenario.files import scenario_from_dict

TOL_THETA, TOL_CHI2, TOL_COV = 0.01, 0.01, 0.01


def builtin(name):
    """The built-in scenario ``name`` as its parsed TOML dict (to be varied)."""
    text = (importlib.resources.files("tmakit.scenario") / "builtin" / f"{name}.toml").read_text()
    return tomllib.loads(text)


def spread(scn, n):
    """``scn`` with n rows in all, evenly spaced over its span (its plans share them)."""
    lo, hi = scn.time_span()
    per = max(1, n // len(scn.plans))
    plans = [dataclasses.replace(p, times=np.linspace(lo, hi, per)) for p in scn.plans]
    return dataclasses.replace(scn, plans=plans)


def from_dict(data):
    """Scenario of a (varied) TOML dict."""
    return scenario_from_dict(data, "<study>")


def _base():
    return builtin("bearings-only-2d")


def v_static():
    d = _base()
    d["target"]["motion"] = "static2d"
    d["target"]["truth"] = {"x": 4000.0, "y": 9000.0}
    return from_dict(d)


def v_cv3d():
    d = _base()
    d["target"]["motion"] = "cv3d"
    d["target"]["truth"] = {"x": 4000.0, "y": 9000.0, "z": 800.0,
                            "vx": -6.0, "vy": -3.0, "vz": 0.5}
    d["sensors"][0]["start"] = [0.0, 0.0, 0.0]
    elev = copy.deepcopy(d["measurements"][0])
    elev["kind"] = "elevation"
    d["measurements"].append(elev)
    return from_dict(d)


def v_south():
    # Relative east crosses zero while the target is south: bearings go through 180 deg.
    d = _base()
    d["target"]["truth"] = {"x": 2000.0, "y": -9000.0, "vx": -6.0, "vy": 3.0}
    return from_dict(d)


def v_two_sensors():
    d = _base()
    d["sensors"].append({"type": "fixed", "id": "buoy", "position": [12000.0, 2000.0]})
    second = copy.deepcopy(d["measurements"][0])
    second["sensor"] = "buoy"
    second["sigma"] = 2.0
    d["measurements"].append(second)
    return from_dict(d)


def v_straight():
    d = _base()
    d["sensors"][0]["legs"] = [{"duration": float("inf")}]
    return from_dict(d)


def v_weak_turn(sigma=1.0):
    # One 4-degree heading change in 600 s: range observable, barely.
    d = _base()
    d["sensors"][0]["legs"] = [{"duration": 290.0},
                               {"duration": 20.0, "turn_rate_deg_s": 0.2},
                               {"duration": float("inf")}]
    d["measurements"][0]["sigma"] = sigma
    return from_dict(d)


def v_far():
    # Target at about 60 km: the bearings sweep about a degree, the range poorly determined.
    d = _base()
    d["target"]["truth"] = {"x": 24000.0, "y": 54000.0, "vx": -6.0, "vy": -3.0}
    return from_dict(d)


def v_gu_bearing():
    d = builtin("gu2007")
    bearing = copy.deepcopy(d["measurements"][1])
    bearing.pop("sigma", None)
    bearing["kind"] = "bearing"
    bearing["sigma"] = 2.0
    d["measurements"].append(bearing)
    return from_dict(d)


def per_row_sigma(scn, rng):
    """Simulate ``scn`` with each row's sigma drawn from 0.3 ... 3 times its own."""
    clean = scn.simulate(rng, noise=False)
    factor = np.exp(rng.uniform(np.log(0.3), np.log(3.0), clean.time.size))
    sigma = clean.sigma * factor
    value = clean.value + rng.standard_normal(clean.time.size) * sigma
    angle = np.isin(clean.kind, ("bearing",))
    value = np.where(angle, (value + 180.0) % 360.0 - 180.0, value)
    return tk.MeasurementSet(clean.time, clean.sensor, clean.kind, value, sigma,
                             clean.sensor_state, clean.time_ref, clean.ref_sensor_state)


CASES = {
    "bearings-only-2d": lambda: tk.load_scenario("bearings-only-2d"),
    "hurtado2008": lambda: tk.load_scenario("hurtado2008"),
    "hoerst2010": lambda: tk.load_scenario("hoerst2010"),
    "gu2007": lambda: tk.load_scenario("gu2007"),
    "gu2007+bearing": v_gu_bearing,
    "static": v_static,
    "cv3d bearing+elev": v_cv3d,
    "south (+-180)": v_south,
    "sigma per row": lambda: tk.load_scenario("bearings-only-2d"),
    "two sensors": v_two_sensors,
    "straight leg": v_straight,
    "weak turn": v_weak_turn,
    "weak turn, 5 deg": lambda: v_weak_turn(5.0),
    "far (60 km)": v_far,
}


def fit(meas, motion, subset, polish=True):
    """One no-guess fit, with (default) or without the subset machinery, or without polish."""
    keep = ml.PRESOLVE_ROWS, ml.POLISH_DECREMENT
    if not subset:
        ml.PRESOLVE_ROWS = 1 << 62
    if not polish:
        ml.POLISH_DECREMENT = 0.0
    try:
        t0 = time.process_time()
        res = tk.estimate(meas, motion)
        return res, time.process_time() - t0
    finally:
        ml.PRESOLVE_ROWS, ml.POLISH_DECREMENT = keep


def quantities(res):
    """Estimate, std and covariance of everything fitted (motion and nuisance)."""
    est = np.asarray(res.estimate, dtype=float)
    std = np.asarray(res.std, dtype=float)
    nuis = [v for v in res.nuisance.values() if v[1] is not None]
    if nuis:
        est = np.concatenate([est, [v[0] for v in nuis]])
        std = np.concatenate([std, [v[1] for v in nuis]])
    return est, std, np.asarray(res.covariance, dtype=float)


def compare(a, b):
    """dchi2, dtheta (std of b), dcov (relative to b's std products) of fits a and b."""
    ea, _, ca = quantities(a)
    eb, sb, cb = quantities(b)
    dchi2 = abs(a.chi2 - b.chi2)
    with np.errstate(invalid="ignore", divide="ignore"):
        # (a quantity held fixed has std 0: compared as equal or not)
        off = np.where(sb > 0, np.abs(ea - eb) / sb, np.where(ea == eb, 0.0, np.inf))
        dtheta = float(np.max(off)) if ea.shape == eb.shape else np.inf
        if ca.shape == cb.shape and ca.size:
            scale = np.sqrt(np.outer(np.diag(cb), np.diag(cb)))
            off = np.where(scale > 0, np.abs(ca - cb) / scale, np.where(ca == cb, 0.0, np.inf))
            dcov = float(np.max(off))
        else:
            dcov = np.inf
    return dchi2, dtheta, dcov


def run(cases, sizes, seeds, label):
    """Fit every case both ways; print a row each; give the default fits by key."""
    print(f"\n== {label} ==")
    head = (f"{'case':20s} {'rows':>7s} {'seed':>4s} {'status (default/plain)':>26s} "
            f"{'dchi2':>9s} {'dtheta':>9s} {'dcov':>9s} {'dth nopol':>9s} {'dcov nopol':>9s} "
            f"{'ms def':>7s} {'ms plain':>8s}")
    print(head)
    fits, bad = {}, []
    for name in cases:
        base = CASES[name]()
        for n in sizes:
            scn = spread(base, n)
            for seed in range(seeds):
                rng = np.random.default_rng(1000 * seed + n % 997)
                meas = per_row_sigma(scn, rng) if name == "sigma per row" else scn.simulate(rng)
                d, td = fit(meas, scn.motion, True)
                p, tp = fit(meas, scn.motion, False)
                dchi2, dtheta, dcov = compare(d, p)
                _, dtheta_np, dcov_np = compare(fit(meas, scn.motion, True, False)[0], p)
                status = "=" + d.status if d.status == p.status else f"{d.status}/{p.status}"
                # (unobservable: the estimate along the unseen direction is arbitrary)
                seen = not (d.status == p.status == "unobservable")
                flag = (d.status != p.status or not dchi2 <= TOL_CHI2
                        or (seen and not (dtheta <= TOL_THETA and dcov <= TOL_COV)))
                line = (f"{name:20s} {meas.time.size:7d} {seed:4d} {status:>26s} "
                        f"{dchi2:9.2e} {dtheta:9.2e} {dcov:9.2e} {dtheta_np:9.2e} {dcov_np:9.2e}"
                        f" {1e3 * td:7.1f} {1e3 * tp:8.1f}")
                key = (name, n, seed)
                print(line + ("  !!" if flag else ""), flush=True)
                if flag:
                    bad.append(line)
                fits[key] = d
    print(f"{len(bad)} disagreement(s) beyond {TOL_THETA} std, {TOL_CHI2} chi2, "
          f"{TOL_COV:.0%} covariance or status")
    return fits


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20_001, 30_000, 100_000, 200_000])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--only", nargs="+", choices=sorted(CASES),
                    default=[c for c in CASES if c != "hoerst2010"])
    args = ap.parse_args()
    run(args.only, args.sizes, args.seeds, "default and plain fits")


if __name__ == "__main__":
    main()
