"""Bearings of a constant-velocity or stationary emitter from a weaving observer, for tests.

The observer weaves east (3 km sine, 300 s period) while moving north at 400 m/min, so that
every motion model tested is observable from bearings alone.
"""

from __future__ import annotations

import numpy as np

import tmakit as tk


def bearings(motion: tk.MotionModel, theta: np.ndarray, n: int, seed: int, dim: int = 2,
             unequal_sigma: bool = False) -> tk.MeasurementSet:
    """Give ``n`` noisy bearings (1 deg, or 0.5-2 deg each) over 1800 s, seeded."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 1800.0, n))
    state = np.zeros((n, 6))
    state[:, 0] = 3000.0 * np.sin(t / 300.0)
    state[:, 1] = 400.0 * t / 60.0
    state[:, 3] = 10.0 * np.cos(t / 300.0)
    state[:, 4] = 400.0 / 60.0
    if dim == 3:
        state[:, 2] = -50.0
    truth = motion.states(theta, t)
    bearing = np.arctan2(truth[:, 0] - state[:, 0], truth[:, 1] - state[:, 1])
    sigma = (np.radians(rng.uniform(0.5, 2.0, n)) if unequal_sigma
             else np.full(n, np.radians(1.0)))
    return tk.MeasurementSet.from_si(t, np.zeros(n, dtype=int), np.full(n, "bearing"),
                                     bearing + sigma * rng.normal(size=n), sigma, state)


def scenario_rows(n: int, seed: int, name: str = "bearings-only-2d"
                  ) -> tuple[tk.Scenario, tk.MeasurementSet]:
    """Give the scenario ``name`` with ``n`` evenly spaced rows per plan and one seeded set."""
    import dataclasses

    scn = tk.load_scenario(name)
    lo, hi = scn.time_span()
    plans = [dataclasses.replace(p, times=np.linspace(lo, hi, n)) for p in scn.plans]
    scn = dataclasses.replace(scn, plans=plans)
    return scn, scn.simulate(np.random.default_rng(seed))
