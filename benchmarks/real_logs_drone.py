"""Issues 12 and 26 figures: a drone receiver log gives the transmitter's lat/lon with its ellipse.

Each seeded log (``sample_logs.drone_sample``: ISO-8601 UTC, lat/lon/alt with GPS
noise, north-east-down velocity, RSSI in dBm with 2 dB noise, frequency in Hz with 1 Hz
noise, one wide row per second for 180 s; the drone flies at 120 m, a stationary 433.92 MHz
transmitter stands on the ground 90 m below it, inside the circle the drone flies) is read
through its mapping TOML and fitted exactly as

    tma estimate drone.csv --mapping drone.toml --motion static2d

does with its defaults: the log is read in 2-D (the drone's altitudes stay within 25 m), the
2-D fit and its 3-D counterpart are compared and the 3-D one is kept when the data need the
height (``tmakit.batch.height.choose_height``).  Printed: the shipped log
(``src/tmakit/examples/drone.csv``, truth in ``truth.json``) with the defaults and with the
2-D fit alone (``--dim 2``), then over all seeded logs the share whose 2-D position error
(the answer's East/North against the truth) lies inside the reported 95 % ellipse
(Mahalanobis squared <= 5.99; target: about 95 %), for the defaults and for 2-D alone.

    python benchmarks/real_logs_drone.py --runs 100 --seed 0
"""

from __future__ import annotations

import argparse
import json
import tempfile
from importlib import resources
from pathlib import Path

import numpy as np
from sample_logs import drone_sample

import tmakit as tk
from tmakit.batch.height import choose_height
from tmakit.core.geodesy import geodetic_to_enu

INSIDE_95 = 5.991  # chi-square, 2 dof, 0.95


def fits(log: Path, mapping: Path, truth: dict[str, float]):
    """Fit a log: the defaults' choice and the truth's East/North."""
    meas = tk.read_measurements(log, format="wide", mapping=mapping)
    flat = tk.estimate(meas, tk.motion_from_name("static2d"))
    chosen = choose_height(meas, flat)
    origin = [float(meas.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(truth["lat"], truth["lon"], origin[2], origin)
    return meas, chosen, np.array([float(e), float(n)])


def error(meas, result, truth_en):
    """Horizontal error (m), Mahalanobis squared under the answer's covariance, the answer."""
    answer = result.answer(meas)  # what tma estimate prints: position, ellipse
    err = np.array(answer.enu[:2], dtype=float) - truth_en
    return float(np.hypot(*err)), float(err @ np.linalg.solve(answer.covariance[:2, :2], err)), \
        answer


def shipped() -> None:
    folder = resources.files("tmakit") / "examples"
    truth = json.loads((folder / "truth.json").read_text())["drone.csv"]
    with resources.as_file(folder / "drone.csv") as log, \
            resources.as_file(folder / "drone.toml") as mapping:
        meas, chosen, truth_en = fits(Path(log), Path(mapping), truth)
    for what, result in (("defaults", chosen.result), ("--dim 2", chosen.flat)):
        d, m2, a = error(meas, result, truth_en)
        e = a.ellipse
        print(f"shipped drone log, {what} ({result.motion.name}): horizontal error {d:.1f} m, "
              f"95 % ellipse {e.semi_major:.1f} x {e.semi_minor:.1f} m, truth at Mahalanobis^2 "
              f"{m2:.1f} ({'inside' if m2 <= INSIDE_95 else 'OUTSIDE'} the 95 % ellipse)")
    print(f"  {chosen.note}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    args = parser.parse_args()
    shipped()
    chosen_m2, flat_m2, errors, dims = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seed, args.seed + args.runs):
            text, mapping, truth = drone_sample(seed)
            (Path(tmp) / "drone.csv").write_text(text)
            (Path(tmp) / "drone.toml").write_text(mapping)
            meas, chosen, truth_en = fits(Path(tmp) / "drone.csv", Path(tmp) / "drone.toml",
                                          truth)
            d, m2, _ = error(meas, chosen.result, truth_en)
            chosen_m2.append(m2)
            errors.append(d)
            flat_m2.append(error(meas, chosen.flat, truth_en)[1])
            dims.append(chosen.dim)
    c, f, d = np.array(chosen_m2), np.array(flat_m2), np.array(errors)
    print(f"{args.runs} seeded drone logs (seeds {args.seed}..{args.seed + args.runs - 1}): "
          f"3-D chosen in {np.mean(np.array(dims) == 3):.0%}; truth inside the 95 % ellipse: "
          f"defaults {np.mean(c <= INSIDE_95):.0%}, 2-D alone {np.mean(f <= INSIDE_95):.0%}; "
          f"horizontal error of the defaults: median {np.median(d):.1f} m, max {d.max():.1f} m")


if __name__ == "__main__":
    main()
