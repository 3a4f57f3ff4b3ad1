"""Issue 12 figure: a drone receiver log gives the transmitter's lat/lon with its ellipse.

Each seeded log (``tmakit.io.samples.drone_sample``: ISO-8601 UTC, lat/lon/alt with GPS
noise, north-east-down velocity, RSSI in dBm with 2 dB noise, frequency in Hz with 1 Hz
noise, one wide row per second for 180 s; a stationary 433.92 MHz transmitter 1.5-2.5 km
away) is read through its mapping TOML and fitted by maximum likelihood (static2d, carrier and
power constant unknown), exactly as

    tma estimate drone.csv --mapping drone.toml --motion static2d

does.  The transmitter's lat/lon and its 95 % ellipse (semi-axes in m, orientation of the
major axis in degrees true) are the answers that command prints (``EstimateResult.answer()``),
shown for the first log; over all logs, the share whose 2-D position error (the answer's
East/North against the truth) has a Mahalanobis distance <= 3 under the answer's covariance
(target: at least 97 %).

    python benchmarks/real_logs_drone.py --runs 100 --seed 0
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.geodesy import geodetic_to_enu
from tmakit.io.samples import drone_sample


def fit(folder: Path, seed: int):
    text, mapping, truth = drone_sample(seed)
    (folder / "drone.csv").write_text(text)
    (folder / "drone.toml").write_text(mapping)
    meas = tk.read_measurements(folder / "drone.csv", format="wide",
                                mapping=folder / "drone.toml")
    result = tk.estimate(meas, tk.motion_from_name("static2d"))
    origin = [float(meas.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(truth["lat"], truth["lon"], origin[2], origin)
    return meas, result, origin, np.array([float(e), float(n)]), truth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    args = parser.parse_args()
    distances, converged = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seed, args.seed + args.runs):
            meas, result, _, truth_en, truth = fit(Path(tmp), seed)
            answer = result.answer(meas)  # what tma estimate prints: position, ellipse
            err = np.array(answer.enu[:2], dtype=float) - truth_en
            cov = answer.covariance[:2, :2]
            distances.append(float(np.sqrt(err @ np.linalg.solve(cov, err))))
            converged.append(result.status == "converged")
            if seed == args.seed:
                lat, lon, _ = answer.geodetic
                e = answer.ellipse
                print(f"seed {seed}: transmitter at lat {lat:.6f} deg, lon {lon:.6f} deg "
                      f"(truth {truth['lat']:.6f}, {truth['lon']:.6f}); {e.level:.0%} ellipse "
                      f"{e.semi_major:.0f} m x {e.semi_minor:.0f} m, major axis "
                      f"{e.orientation_deg:.0f} deg true; error {np.hypot(*err):.0f} m, "
                      f"Mahalanobis {distances[-1]:.2f}")
    d = np.array(distances)
    print(f"{args.runs} seeded drone logs (seeds {args.seed}..{args.seed + args.runs - 1}): "
          f"{np.mean(converged):.0%} converged; Mahalanobis distance of the 2-D error: "
          f"median {np.median(d):.2f}, max {d.max():.2f}; within 3 sigma: {np.mean(d <= 3):.0%} "
          "(target >= 97 %)")


if __name__ == "__main__":
    main()
