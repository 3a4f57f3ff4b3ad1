"""How often the leg-change test warns on targets that hold one leg (its false-alarm rate).

Seeded runs of the two-array own ship of ``benchmarks/two_sensors.py`` (a cv2d target, 240
bearings over 480 s), each fitted by ``tk.estimate(meas, "cv2d")`` and tested by
:func:`tmakit.batch.leg_change.leg_change_test`. Printed: the runs tested, how many reached the
F test's level alone (``p < LEG_CHANGE_P``), and how many were warned (the F test and the
one-manoeuvre fit outside the cv2d fit's 95 % region). docs/estimation.md states the rate.

    python benchmarks/leg_change_false_alarms.py --runs 100 --seed 20261207
"""

from __future__ import annotations

import argparse

import numpy as np
from two_sensors import scenario

import tmakit as tk
from tmakit.batch.leg_change import LEG_CHANGE_P, leg_change_test


def false_alarms(runs: int, seed: int) -> tuple[int, int, int]:
    """Seeded cv2d targets of the two-array own ship: (tested, F test alone, warnings)."""
    sc = scenario()
    rng = np.random.default_rng(seed)
    tested = f_only = warned = 0
    for _ in range(runs):
        meas = sc.simulate(rng=rng)
        test = leg_change_test(meas, tk.estimate(meas, "cv2d"))
        if test is None:
            continue
        tested += 1
        f_only += test.p_value < LEG_CHANGE_P
        warned += test.manoeuvred
    return tested, f_only, warned


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=20261207)
    args = parser.parse_args()
    tested, f_only, warned = false_alarms(args.runs, args.seed)
    print(f"{args.runs} runs (seed {args.seed}): {tested} tested, F test alone at "
          f"p < {LEG_CHANGE_P:g} in {f_only}, warned {warned} ({warned / max(tested, 1):.1%})")


if __name__ == "__main__":
    main()
