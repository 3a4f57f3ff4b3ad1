"""The choices of the manoeuvre estimator on seeded hoerst2010 runs, saved or compared.

Every run simulates the ``hoerst2010`` scenario with its own seed (the seeds of
``benchmarks/montecarlo_hoerst2010.py``: ``SeedSequence(--seed).generate_state(--runs)``) and
estimates with no initial guess, orders ``0 .. --max-manoeuvres`` (default 3, BIC,
accelerations selected).  The choices recorded per run are the number of manoeuvres chosen,
the change-over times and the accelerations held at zero of the chosen fit, and for every
order its held set, change-over times and chi2; and the time the estimate took.

``--save FILE`` writes them (JSON lines, one run a line, flushed as it goes, so a partial file
is usable); ``--compare FILE`` runs the same seeds with the code on ``PYTHONPATH`` and prints
how many agree with the saved ones: the same order, the same held accelerations and
change-over times within ``--tol`` seconds (of the chosen fit, and of every order's fit), with
the time per run of both.  ``--runs`` with ``--compare`` limits the comparison to the first
runs of the file.

    PYTHONPATH=src python benchmarks/manoeuvre_choices.py --runs 200 --save base.jsonl
    PYTHONPATH=src python benchmarks/manoeuvre_choices.py --compare \
        benchmarks/data/manoeuvre_choices_main.jsonl --runs 200
"""

from __future__ import annotations

import os

# One BLAS thread: many small products, and the machine is shared.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import json
import time

import numpy as np

from tmakit.batch.curvilinear import estimate_manoeuvres
from tmakit.scenario.files import load_scenario


def choices(seed: int, max_m: int) -> dict:
    """Simulate hoerst2010 with ``seed``, estimate, and give the choices made."""
    scn = load_scenario("hoerst2010")
    meas = scn.simulate(rng=np.random.default_rng(seed))
    start = time.process_time()
    res = estimate_manoeuvres(meas, max_m)
    seconds = time.process_time() - start
    names = [f"{c}_{s}" for s in range(max_m + 1) for c in ("at", "an")]
    orders = []
    for f in res.fits:
        m = f.manoeuvres
        free = f.free_mask()
        orders.append({"manoeuvres": m, "chi2": float(f.chi2),
                       "times": [float(t) for t in f.theta[6 + 2 * m:]],
                       "held": [names[i - 4] for i in range(4, 6 + 2 * m) if not free[i]]})
    return {"seed": seed, "manoeuvres": res.manoeuvres,
            "times": [float(v) for v, _ in res.change_over_times()],
            "held": sorted(res.held), "orders": orders, "cpu_seconds": seconds}


def agree(a: dict, b: dict, tol: float) -> tuple[bool, str]:
    """Whether two runs made the same choices; and the first difference in words."""
    def same_times(x: list[float], y: list[float]) -> bool:
        return len(x) == len(y) and all(abs(p - q) <= tol for p, q in zip(x, y, strict=True))

    if a["manoeuvres"] != b["manoeuvres"]:
        return False, f"order {a['manoeuvres']} vs {b['manoeuvres']}"
    if a["held"] != b["held"]:
        return False, f"held {a['held']} vs {b['held']}"
    if not same_times(a["times"], b["times"]):
        return False, f"times {a['times']} vs {b['times']}"
    if len(a["orders"]) != len(b["orders"]):
        return False, "orders tried"
    for oa, ob in zip(a["orders"], b["orders"], strict=False):
        if oa["held"] != ob["held"] or not same_times(oa["times"], ob["times"]):
            return False, (f"order {oa['manoeuvres']} fit: held {oa['held']} vs {ob['held']}, "
                           f"times {oa['times']} vs {ob['times']}")
    return True, ""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip", type=int, default=0,
                    help="start at this run (to split the runs between processes)")
    ap.add_argument("--max-manoeuvres", type=int, default=3)
    ap.add_argument("--save", help="write the choices to this file (JSON lines)")
    ap.add_argument("--compare", help="compare with the choices saved in this file")
    ap.add_argument("--tol", type=float, default=0.5,
                    help="change-over times agree within this (s; default 0.5)")
    args = ap.parse_args()
    if bool(args.save) == bool(args.compare):
        ap.error("give one of --save and --compare")
    if args.save:
        seeds = np.random.SeedSequence(args.seed).generate_state(args.runs)
        with open(args.save, "w") as f:
            for i, s in enumerate(seeds):
                if i < args.skip:
                    continue
                f.write(json.dumps(choices(int(s), args.max_manoeuvres)) + "\n")
                f.flush()
                print(f"  {i + 1}/{args.runs}", flush=True)
        return
    with open(args.compare) as f:
        saved = [json.loads(line) for line in f if line.strip()][args.skip:args.runs]
    same, new_s, old_s, max_dt, max_dchi2 = 0, [], [], 0.0, 0.0
    for i, old in enumerate(saved):
        new = choices(old["seed"], args.max_manoeuvres)
        ok, why = agree(old, new, args.tol)
        same += ok
        new_s.append(new["cpu_seconds"])
        old_s.append(old["cpu_seconds"])
        for oa, ob in zip(old["orders"], new["orders"], strict=False):
            if len(oa["times"]) == len(ob["times"]):
                max_dt = max([max_dt, *(abs(p - q) for p, q in
                                        zip(oa["times"], ob["times"], strict=True))])
            max_dchi2 = max(max_dchi2, abs(oa["chi2"] - ob["chi2"]))
        print(f"  run {i + 1} (seed {old['seed']}): {'same' if ok else 'DIFFERENT: ' + why}; "
              f"{old['cpu_seconds']:.2f} s -> {new['cpu_seconds']:.2f} s", flush=True)
    n = len(saved)
    print(f"same choices in {same} of {n} runs (order, held accelerations, change-over times "
          f"within {args.tol:g} s, of the chosen fit and of every order's fit)")
    print(f"largest change-over time difference {max_dt:.3g} s, largest chi2 difference "
          f"{max_dchi2:.3g}")
    print(f"CPU time per run: saved median {np.median(old_s):.2f} s (IQR "
          f"{np.percentile(old_s, 25):.2f}..{np.percentile(old_s, 75):.2f}), now median "
          f"{np.median(new_s):.2f} s (IQR {np.percentile(new_s, 25):.2f}.."
          f"{np.percentile(new_s, 75):.2f})")


if __name__ == "__main__":
    main()
