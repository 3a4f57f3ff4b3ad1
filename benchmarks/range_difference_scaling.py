"""Time and peak memory of an ML fit of a long range-difference log (its noise held as blocks).

    python benchmarks/range_difference_scaling.py [--seconds 1400] [--step 0.1] [--overlap]

A UAV 300 m up flies East at 40 m/s over a fixed emitter at (3000, 4000) m; every ``step``
seconds a bearing (1 deg) and a range difference against the previous sample (0.7 m), and with
``--overlap`` one more against the sample half a step back (its span overlaps the first's, so
each pair is correlated).  Noise-free values: the figure is the cost, not the accuracy.
Prints the rows, the fit's wall time and this process's peak resident memory; before the
noise was split into blocks, ``--overlap`` at 14,000 steps (42,000 rows) passed 12 GB.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import tmakit as tk
from tmakit.batch import estimate
from tmakit.data import MeasurementSet


def log(steps: int, step: float, overlap: bool) -> MeasurementSet:
    """Build the set: bearings and range differences from the moving UAV (SI)."""
    def rng(t: np.ndarray) -> np.ndarray:
        return np.sqrt((3000.0 - 40.0 * t) ** 2 + 4000.0**2 + 300.0**2)

    t = np.arange(steps) * step
    rows = [("bearing", t, np.arctan2(3000.0 - 40.0 * t, 4000.0), np.radians(1.0), t * np.nan)]
    lags = (step, step / 2) if overlap else (step,)
    rows += [("range_difference", t[1:], rng(t[1:]) - rng(t[1:] - lag), 0.7, t[1:] - lag)
             for lag in lags]
    order = np.argsort(np.concatenate([r[1] for r in rows]), kind="stable")  # time order
    kinds = np.concatenate([np.full(r[1].shape[0], r[0]) for r in rows])[order]
    times = np.concatenate([r[1] for r in rows])[order]
    refs = np.concatenate([r[4] for r in rows])[order]

    def state(tt: np.ndarray) -> np.ndarray:
        return np.column_stack([40.0 * tt, 0 * tt, 300.0 + 0 * tt, 40.0 + 0 * tt, 0 * tt,
                                0 * tt])

    ref_state = np.where(np.isnan(refs)[:, None], np.nan, state(np.nan_to_num(refs)))
    return MeasurementSet.from_si(
        time=times, sensor=np.full(times.shape[0], "uav"), kind=kinds,
        value_si=np.concatenate([r[2] for r in rows])[order],
        sigma_si=np.concatenate([np.broadcast_to(r[3], r[1].shape) for r in rows])[order],
        sensor_state=state(times), time_ref=refs, ref_sensor_state=ref_state)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1400.0)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--overlap", action="store_true")
    a = ap.parse_args()
    meas = log(int(a.seconds / a.step), a.step, a.overlap)
    start = time.perf_counter()
    res = estimate(meas, tk.ConstantVelocity(dim=3, ref_time=0.0))
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{len(meas):,} rows ({'overlapping pairs' if a.overlap else 'consecutive'}): "
          f"fit {wall:.1f} s, status {res.status}, peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
