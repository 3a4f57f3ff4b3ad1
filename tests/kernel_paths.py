"""The manoeuvre parameter vectors the kernel tests share (:func:`hoerst_thetas`)."""

from __future__ import annotations

import numpy as np


def hoerst_thetas(m: int, rng: np.random.Generator, rows: int) -> np.ndarray:
    """``rows`` parameter vectors of ``m`` manoeuvres on hoerst2010, accelerations jittered.

    The scenario's start, accelerations ``(0.01, 0.02)`` per segment plus ``0.01``-sized
    seeded noise, and change-over times evenly spread over 200-700 s; callers set their
    corner cases in the rows.
    """
    import tmakit as tk

    scn = tk.load_scenario("hoerst2010")
    base = np.concatenate([scn.theta[:4], np.tile([0.01, 0.02], m + 1),
                           np.linspace(200.0, 700.0, m)])
    theta = np.tile(base, (rows, 1))
    theta[:, 4:6 + 2 * m] += 0.01 * rng.normal(size=(rows, 2 + 2 * m))
    return theta
