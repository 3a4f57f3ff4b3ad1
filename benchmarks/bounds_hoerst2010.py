"""The Cramér–Rao analysis of Hörst & Oispuu (2010), §4 (Fig. 2) on the hoerst2010 scenario:
the bound on the current target position from the data so far, every STEP seconds, for
azimuth only and azimuth + azimuth rate, with the manoeuvres (accelerations, change-over
times) unknown and known.

Prints one line per reference time and checks the figures the issue asks for:

* azimuth + rate gives a smaller position bound than azimuth only at every reference time;
* the bound grows right after each manoeuvre starts (t_1 = 400 s, t_2 = 600 s): just after
  (t_m + 1 s ... t_m + STEP) against just before (t_m);
* the bound with the manoeuvres known is never above the bound with them unknown.

Where the information is singular at the library's rank tolerance the bound is reported as
unobservable; for those reference times the script also prints the plain inverse of the
information (normalised), flagged as ill-conditioned and indicative only.

The bound is deterministic: there is no --runs or --seed.

    python benchmarks/bounds_hoerst2010.py [--step 10] [--plot fig2.png]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tmakit.bounds.manoeuvre import CrbPoint, curvilinear_crb_sequence
from tmakit.core.linalg import normalise
from tmakit.reproduce import hoerst2010
from tmakit.scenario.files import load_scenario


def plain_rms(p: CrbPoint) -> float:
    """sqrt(var x + var y) from the plain inverse of the (normalised) information."""
    norm, scale = normalise(p.bound.information)
    with np.errstate(all="ignore"):
        inv = np.linalg.inv(norm) * scale[:, None] * scale[None, :]
        return float(np.sqrt(inv[0, 0] + inv[1, 1]))


def fmt(v: float) -> str:
    return f"{v:12.1f}" if np.isfinite(v) else f"{'unobs.':>12}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=float, default=10.0,
                        help="seconds between reference times (default 10, as Fig. 2)")
    parser.add_argument("--plot", default=None, help="also draw Fig. 2 to this file")
    args = parser.parse_args()

    scn = load_scenario("hoerst2010")
    start = time.perf_counter()
    seqs = hoerst2010.sequences(args.step, scn)
    elapsed = time.perf_counter() - start
    keys = list(hoerst2010.CASES)
    az, azr = seqs["azimuth"], seqs["azimuth+rate"]
    refs = az.ref_times
    print(f"hoerst2010: position RMS bound sqrt(var x + var y) (m) at t_ref from the data up to "
          f"t_ref; {len(refs)} reference times x {len(keys)} cases in {elapsed:.1f} s")
    print(f"{'t_ref':>6} {'man.':>4} " + " ".join(f"{k:>22}" for k in keys))
    for i, t in enumerate(refs):
        print(f"{t:6.0f} {az.points[i].manoeuvres:4d} "
              + " ".join(f"{fmt(seqs[k].rms[i]):>22}" for k in keys))

    print("\n1. azimuth + rate below azimuth only at every reference time")
    either = np.isfinite(az.rms) | np.isfinite(azr.rms)
    smaller = azr.rms[either] < az.rms[either]
    print(f"   finite for at least one: {int(either.sum())} of {len(refs)}; azimuth + rate "
          f"smaller at {int(smaller.sum())} of them -> {'HOLDS' if smaller.all() else 'FAILS'}")
    if smaller.size:
        ratio = azr.rms[either] / az.rms[either]
        fin = np.isfinite(ratio)
        print(f"   ratio (azimuth + rate) / (azimuth only) where both finite: "
              f"max {ratio[fin].max():.3f}, median {np.median(ratio[fin]):.3f}")
    for i in np.flatnonzero(~either):
        a, b = plain_rms(az.points[i]), plain_rms(azr.points[i])
        print(f"   {refs[i]:g} s: both unobservable at the rank tolerance; plain inverse "
              f"(ill-conditioned, indicative): azimuth only {a:.3g} m, azimuth + rate "
              f"{b:.3g} m -> {'smaller' if b < a else 'NOT smaller'}")

    print("\n2. the bound grows right after each manoeuvre starts")
    cot = [scn.truth[f"t_{m}"] for m in range(1, scn.motion.manoeuvres + 1)]
    for m, tm in enumerate(cot, start=1):
        offsets = [o for o in (0.0, 1.0, 2.0, 5.0, args.step, 2 * args.step, 3 * args.step)
                   if o <= args.step * 3]
        times = [tm + o for o in dict.fromkeys(offsets)]
        for key, kinds in (("azimuth", ("bearing",)),
                           ("azimuth+rate", ("bearing", "azimuth_rate"))):
            s = curvilinear_crb_sequence(scn, times, kinds)
            before = s.rms[0]
            cells = ", ".join(f"{t:g} s: {v:.1f}" if np.isfinite(v) else f"{t:g} s: unobs."
                              for t, v in zip(times, s.rms, strict=True))
            grows = all(v > before for v in s.rms[1:])
            print(f"   t_{m} = {tm:g} s, {key:<13} {cells} -> just after > just before: "
                  f"{'HOLDS' if grows else 'FAILS'}")

    print("\n3. manoeuvres known never above manoeuvres unknown")
    for unknown, known in (("azimuth", "azimuth, known"),
                           ("azimuth+rate", "azimuth+rate, known")):
        u, k = seqs[unknown].rms, seqs[known].rms
        ok = np.all(k <= u * (1 + 1e-9))
        print(f"   {known:<22} <= {unknown:<14}: {'HOLDS' if ok else 'FAILS'} "
              f"(largest ratio {np.max(k / u):.3f})")

    if args.plot:
        rep = hoerst2010.run(step=args.step)
        hoerst2010.plot(rep, args.plot)
        print(f"\nwrote {args.plot}")


if __name__ == "__main__":
    main()
