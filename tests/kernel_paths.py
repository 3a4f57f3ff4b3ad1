"""What the motion and kernel tests share: :func:`hoerst_thetas`, :func:`numerical_jacobian`."""

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


def numerical_jacobian(model, theta: np.ndarray, t: np.ndarray,
                       rel_step: float = 1e-6) -> np.ndarray:
    """``d state / d theta`` ``(..., n, 6, p)`` of a motion model by central differences."""
    theta = model.check_theta(theta)
    t = np.asarray(t, dtype=float)
    cols = []
    for j in range(model.n_params):
        h = rel_step * np.maximum(1.0, np.abs(theta[..., j]))
        step = np.zeros(theta.shape)
        step[..., j] = h
        up = model.states(theta + step, t)
        down = model.states(theta - step, t)
        cols.append((up - down) / (2.0 * h[..., None, None]))
    return np.stack(cols, axis=-1)
