"""Chen & Sun §3, Fig. 2: EKF and modified-gain EKF with multi-lag
vectors on the three paths, RMS errors in x, y, z and range over time, NEES, and the
observability of each path (batch CRLB).  Same numbers as ``tma reproduce chen-sun``.

    python benchmarks/chen_sun.py                       # 30 runs, seed 1, default lags
    python benchmarks/chen_sun.py --runs 30 --seed 1 --plot fig2.png
    python benchmarks/chen_sun.py --lags 4,8,12,16,20,24,28
    python benchmarks/chen_sun.py --gains 30            # + the two MGEKF gain forms
    python benchmarks/chen_sun.py --bearings-only 20    # + the gain forms on bearings-only-2d

``--gains N`` compares, on the three paths (N runs, multi-lag vectors as in the paper), the
MGEKF as Chen & Sun (§2.5) print it (modified rows in the gain) with Song & Speyer's form
(EKF rows in the gain, modified rows in the covariance).  ``--bearings-only N`` does the
same on the 2-D bearings-only scenario (one bearing per update, prior N(truth + error,
diag(3 km, 3 km, 10 m/s, 10 m/s)^2), q = 0).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tmakit.filters.multilag import DEFAULT_LAGS
from tmakit.reproduce import chen_sun


def print_section(section) -> None:
    print(f"\n{section.title}")
    widths = [max(len(str(h)), *(len(str(r[i])) for r in section.rows)) + 2
              for i, h in enumerate(section.header)]
    print("".join(f"{h!s:>{w}}" for h, w in zip(section.header, widths, strict=True)))
    for row in section.rows:
        print("".join(f"{v!s:>{w}}" for v, w in zip(row, widths, strict=True)))
    if section.note:
        print(section.note)


def gain_forms(runs: int, seed: int, lags: tuple[int, ...]) -> None:
    """The MGEKF as printed vs Song & Speyer's form on the three paths."""
    from tmakit.filters.mgekf import ModifiedGainEKF
    from tmakit.filters.multilag import multilag_groups
    from tmakit.scenario.files import load_scenario

    print(f"\nMGEKF gain forms on the three paths ({runs} runs, multi-lag vectors, no "
          "reuse inflation): final RMS (m) and mean NEES over t >= 10 s")
    print(f"{'path':>5} {'gain':>12} {'x':>7} {'y':>7} {'z':>7} {'R':>7} {'NEES':>8}")
    for p in chen_sun.PATHS:
        scn = load_scenario(f"chen-sun-{p}")
        for gain in ("paper", "song-speyer"):
            errs, nees = [], []
            for i in range(runs):
                meas = scn.simulate(rng=np.random.default_rng([seed, p, i]))
                mean, cov, t0 = chen_sun.initial_state(meas)
                f = ModifiedGainEKF(mean, cov, t0, q=chen_sun.Q, reflect=True, gain=gain)
                tr = f.run_groups(multilag_groups(meas, lags))
                truth = scn.target_states(tr.times)
                errs.append(chen_sun._errors(tr.states, truth)[-1])
                nees.append(tr.nees(truth)[tr.times >= 10.0].mean())
            rms = np.sqrt(np.mean(np.square(errs), axis=0))
            print(f"{p:>5} {gain:>12} {rms[0]:7.0f} {rms[1]:7.0f} {rms[2]:7.0f} "
                  f"{rms[3]:7.0f} {np.mean(nees):8.1f}")


def bearings_only(runs: int, seed: int) -> None:
    """EKF and both MGEKF gain forms on bearings-only-2d from a wide prior."""
    import tmakit as tk
    from tmakit.filters import ExtendedKalmanFilter
    from tmakit.filters.mgekf import ModifiedGainEKF

    scn = tk.load_scenario("bearings-only-2d")
    out: dict[str, tuple[list[float], list[float]]] = {k: ([], []) for k in
                                                       ("ekf", "paper", "song-speyer")}
    for i in range(runs):
        rng = np.random.default_rng([seed, i])
        meas = scn.simulate(rng=rng)
        t0 = float(meas.time.min())
        cov = np.diag([3000.0**2, 3000.0**2, 10.0**2, 10.0**2])
        mean = scn.target_states([t0])[0][[0, 1, 3, 4]] + rng.multivariate_normal(
            np.zeros(4), cov)
        for key in out:
            f = (ExtendedKalmanFilter(mean, cov, t0) if key == "ekf"
                 else ModifiedGainEKF(mean, cov, t0, gain=key))
            tr = f.run(meas)
            truth = scn.target_states(tr.times)[:, [0, 1, 3, 4]]
            e = tr.errors(truth)[-1]
            out[key][0].append(float(np.hypot(e[0], e[1])))
            out[key][1].append(float(tr.nees(truth)[-1]))
    print(f"\nbearings-only-2d, {runs} runs, prior std 3 km / 10 m/s, q = 0: final position "
          "RMS (m), median and mean final NEES (4 dof)")
    for key, (err, nees) in out.items():
        print(f"  {key:>12}: RMS {np.sqrt(np.mean(np.square(err))):10.1f}   NEES median "
              f"{np.median(nees):10.3g}   mean {np.mean(nees):10.3g}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=chen_sun.RUNS)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--lags", default=",".join(map(str, DEFAULT_LAGS)),
                    help="multi-lag lags in samples, comma-separated")
    ap.add_argument("--plot", default=None, help="write Fig. 2 to this PNG")
    ap.add_argument("--gains", type=int, default=0, metavar="N",
                    help="also compare the two MGEKF gain forms (N runs per path)")
    ap.add_argument("--bearings-only", type=int, default=0, metavar="N",
                    help="also compare the gain forms on bearings-only-2d (N runs)")
    args = ap.parse_args()
    lags = tuple(int(v) for v in args.lags.split(","))
    t = time.perf_counter()
    rep = chen_sun.run(runs=args.runs, seed=args.seed, progress=False, lags=lags)
    for section in rep.sections:
        print_section(section)
    print()
    for key, value in rep.figures.items():
        print(f"{key}: {value}")
    print(f"({time.perf_counter() - t:.1f} s)")
    if args.plot:
        print(f"wrote {chen_sun.plot(rep, args.plot)}")
    if args.gains:
        gain_forms(args.gains, args.seed, lags)
    if args.bearings_only:
        bearings_only(args.bearings_only, args.seed)


if __name__ == "__main__":
    main()
