"""Two bearing sensors on one own ship fitted together: honest, and no worse than either alone.

A hull array (2 deg, every 4 s) and a towed array (1 deg, every 4 s, 2 s after the hull's) on
one own ship zig-zagging at 8 m/s (four legs, 90-degree turns), a cv2d target about 10 km away
(the scenario of ``docs/your-own-data.md``, "Several sensors on one own ship"). Each seeded run
is fitted three ways, ``tk.estimate(meas, "cv2d")`` on both sensors' bearings and on each
sensor's alone. Printed: how often the truth at T = 480 s lies in the printed 95 % region
(``EstimateResult.region_contains``; target about 95 %), the RMS of the position error at T
against the CRLB's position std at T (``tk.crlb`` of the same scenario), for each of the three.

    python benchmarks/two_sensors.py --runs 200 --seed 20261207
"""

from __future__ import annotations

import argparse

import numpy as np

import tmakit as tk
from tmakit.scenario.files import scenario_from_dict

LEGS = [{"duration": 110.0}, {"duration": 10.0, "turn_rate_deg_s": -9.0},
        {"duration": 110.0}, {"duration": 10.0, "turn_rate_deg_s": 9.0},
        {"duration": 110.0}, {"duration": 10.0, "turn_rate_deg_s": -9.0},
        {"duration": float("inf")}]
#: The hull array: 2 deg every 4 s; the towed array: 1 deg every 4 s, 2 s after the hull's.
HULL_SIGMA_DEG, TOWED_SIGMA_DEG = 2.0, 1.0
TRUTH = {"x": 4000.0, "y": 9000.0, "vx": -6.0, "vy": -3.0}
T_END = 480.0
FITS = ("both", "hull", "towed")


def scenario(sensors: tuple[str, ...] = ("hull", "towed")) -> tk.Scenario:
    """Return the own ship with the sensors named (both by default)."""
    own = {"type": "legs", "start": [0.0, 0.0], "heading_deg": 45.0, "speed": 8.0,
           "legs": LEGS}
    plans = {"hull": {"kind": "bearing", "sensor": "hull", "sigma": HULL_SIGMA_DEG,
                      "times": {"start": 4.0, "stop": T_END, "step": 4.0}},
             "towed": {"kind": "bearing", "sensor": "towed", "sigma": TOWED_SIGMA_DEG,
                       "times": {"start": 2.0, "stop": T_END - 2.0, "step": 4.0}}}
    data = {"name": "two-arrays", "target": {"motion": "cv2d", "truth": TRUTH},
            "sensors": [{**own, "id": s} for s in sensors],
            "measurements": [plans[s] for s in sensors]}
    return scenario_from_dict(data, "two-arrays.toml")


def final_position(theta: np.ndarray) -> np.ndarray:
    """Return the cv2d position (East, North, m) at T_END."""
    return np.array([theta[0] + theta[2] * T_END, theta[1] + theta[3] * T_END])


def study(runs: int, seed: int) -> dict[str, dict[str, float]]:
    """Return, per fit, the runs converged, the truth inside, the RMS and the bound (m)."""
    truth_end = final_position(np.array([TRUTH[k] for k in ("x", "y", "vx", "vy")]))
    errors: dict[str, list[np.ndarray]] = {k: [] for k in FITS}
    inside = dict.fromkeys(FITS, 0)
    converged = dict.fromkeys(FITS, 0)
    both = scenario()
    rng = np.random.default_rng(seed)
    for _ in range(runs):
        meas = both.simulate(rng=rng)
        for name in FITS:
            part = meas if name == "both" else meas.take(meas.sensor_mask(name))
            result = tk.estimate(part, "cv2d")
            converged[name] += result.converged
            inside[name] += result.region_contains(truth_end, part, time=T_END)
            errors[name].append(final_position(result.estimate) - truth_end)
    jac = np.array([[1.0, 0.0, T_END, 0.0], [0.0, 1.0, 0.0, T_END]])
    out = {}
    for name in FITS:
        cov = tk.crlb(scenario(FITS[1:] if name == "both" else (name,))).covariance[:4, :4]
        out[name] = {"runs": runs, "converged": converged[name], "inside": inside[name],
                     "rms_m": float(np.sqrt(np.mean(np.sum(np.square(errors[name]), axis=1)))),
                     "bound_m": float(np.sqrt(np.trace(jac @ cov @ jac.T)))}
    return out


def main() -> None:
    """Print the study's table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=20261207)
    args = parser.parse_args()
    print(f"{'fit':6} {'inside 95 %':>14} {'RMS (m)':>9} {'CRLB (m)':>9} {'RMS/CRLB':>9}")
    for name, r in study(args.runs, args.seed).items():
        print(f"{name:6} {r['inside']:>5} of {r['runs']:<5} {r['rms_m']:9.1f} "
              f"{r['bound_m']:9.1f} {r['rms_m'] / r['bound_m']:9.3f}"
              + ("" if r["converged"] == r["runs"] else f"  ({r['converged']} converged)"))


if __name__ == "__main__":
    main()
