"""Speed of the layout bound: a CRLB from 10^4 sensor pairs x 10^3 times, a 100 x 100 GDOP map.

    python benchmarks/geolocation_speed.py [--pairs 10000] [--times 1000] [--grid 100]

1. A stationary emitter heard by 10,000 moving sensors, TDOA of each against one of 100
   reference sensors, at 1,000 times (10^7 rows, the noise shared through each reference at
   each time): the rows are made once (a :class:`tmakit.bounds.layout.LayoutRows`, timed
   apart), then the emitter's CRLB (:func:`tmakit.bounds.layout.layout_information`) is timed.
2. Ten fixed sensors, TDOA against the first: the CRLB and CEP50/CEP90 at every point of a
   100 x 100 grid (what ``tma gdop`` draws), timed.

Times are wall-clock, best of three, with the CPU time beside them (on a shared machine the
wall time is the CPU time stretched by the load).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tmakit.bounds.layout import LayoutRows, cep, layout_information
from tmakit.core.units import SPEED_OF_LIGHT
from tmakit.data import MeasurementSet
from tmakit.reproduce.chan_ho1994 import SENSORS


def rows(pairs: int, times: int, refs: int, rng: np.random.Generator) -> MeasurementSet:
    """Build the large layout's rows (noise-free values are not needed: zeros)."""
    n = pairs * times
    t = np.repeat(np.arange(times, dtype=float), pairs)
    sensor_idx = np.tile(np.arange(pairs), times)
    ref_idx = sensor_idx % refs
    start = rng.uniform(-50e3, 50e3, (pairs, 3)) * [1, 1, 0.1]
    vel = rng.uniform(-100, 100, (pairs, 3)) * [1, 1, 0]
    ref_start = rng.uniform(-50e3, 50e3, (refs, 3)) * [1, 1, 0.1]
    state = np.empty((n, 6))
    state[:, :3] = start[sensor_idx] + vel[sensor_idx] * t[:, None]
    state[:, 3:] = vel[sensor_idx]
    ref = np.zeros((n, 6))
    ref[:, :3] = ref_start[ref_idx]
    names = np.array([f"s{i}" for i in range(pairs)])[sensor_idx]
    return MeasurementSet.from_si(t, names, np.full(n, "tdoa"), np.zeros(n),
                                  np.full(n, 10.0 / SPEED_OF_LIGHT), state, t, ref, check=False)


def best_of(f: object, repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls (s); the best CPU time is printed beside it."""
    best, cpu = np.inf, np.inf
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        f()  # type: ignore[operator]
        best = min(best, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    print(f"  (best of {repeat}: wall {best:.3f} s, CPU {cpu:.3f} s)")
    return best


def main() -> None:
    """Print the two timings."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=10_000)
    parser.add_argument("--times", type=int, default=1000)
    parser.add_argument("--grid", type=int, default=100)
    args = parser.parse_args()
    rng = np.random.default_rng(1)

    t0 = time.perf_counter()
    big = rows(args.pairs, args.times, 100, rng)
    made = time.perf_counter() - t0
    t0 = time.perf_counter()
    layout = LayoutRows(big)
    prepared = time.perf_counter() - t0
    emitter = np.array([[1000.0, 2000.0, 0.0]])
    took = best_of(lambda: layout_information(layout, emitter, 3))
    std = np.sqrt(np.diag(np.linalg.inv(layout_information(layout, emitter, 3)[0])))
    print(f"CRLB, {args.pairs:,} pairs x {args.times:,} times = {len(big):,} rows: "
          f"{took:.3f} s (rows built {made:.1f} s, grouped {prepared:.1f} s once); "
          f"std east/north/up {std[0]:.3g} / {std[1]:.3g} / {std[2]:.3g} m")

    ten = np.zeros((9, 6))
    ten[:, :2] = SENSORS[1:]
    ref = np.zeros((9, 6))
    ref[:, :2] = SENSORS[0]
    small = MeasurementSet.from_si(np.zeros(9), [f"s{i}" for i in range(2, 11)],
                                   ["tdoa"] * 9, np.zeros(9), np.full(9, 10.0 / SPEED_OF_LIGHT),
                                   ten, np.zeros(9), ref, check=False)
    side = np.linspace(-40e3, 40e3, args.grid)
    east, north = np.meshgrid(side, side)
    grid = np.column_stack([east.ravel(), north.ravel(), np.zeros(east.size)])

    def gdop() -> None:
        info = layout_information(LayoutRows(small), grid, 2)
        cov = np.linalg.inv(info)
        cep(cov, 0.5)
        cep(cov, 0.9)

    took = best_of(gdop)
    print(f"GDOP map, {args.grid} x {args.grid} points, 10 sensors (CRLB, CEP50 and CEP90): "
          f"{took:.3f} s")


if __name__ == "__main__":
    main()
