"""Automatic global initialisation: no initial guess needed.

A coarse grid of trajectories is scored by the reduced (nuisance-eliminated) likelihood in one
vectorised evaluation, and the best few, mutually distinct, become the starting points of the
batched Levenberg–Marquardt solve.  Positions are placed at the median measurement time: along
the measured bearings when there are bearings (rays from each bearing sensor), otherwise on a
polar grid around the sensors, at geometrically spaced ranges; velocities on a grid of speeds
and courses.  3-D models add a few elevation angles above the sensors' plane (emitters below
the sensors are not searched: with no elevation data, z and its mirror fit equally).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .solver import VarProProblem


@dataclass(frozen=True)
class GridSettings:
    """Extent and density of the initial search (SI units)."""

    min_range: float = 100.0
    max_range: float = 50_000.0
    n_ranges: int = 10
    n_bearings: int = 12
    speeds: tuple[float, ...] = (0.0, 10.0, 40.0, 150.0, 450.0)
    n_courses: int = 8
    elevations_deg: tuple[float, ...] = (0.0, 3.0, 10.0, 25.0, 50.0)
    max_rows: int = 30
    starts: int = 6


def _reference_point(problem: VarProProblem, t_mid: float) -> NDArray[np.float64]:
    meas = problem.obs.meas
    near = [np.argmin(np.abs(meas.time - t_mid) + 1e9 * (meas.sensor != s))
            for s in meas.sensors]
    return meas.sensor_state[near, :3].mean(axis=0)


def _positions(problem: VarProProblem, t_mid: float, dim: int, g: GridSettings
               ) -> NDArray[np.float64]:
    meas = problem.obs.meas
    ranges = np.geomspace(g.min_range, g.max_range, g.n_ranges)
    rays = []  # (origin, bearing)
    bearing_rows = np.flatnonzero(meas.kind == "bearing")
    if bearing_rows.size:
        for s in np.unique(meas.sensor[bearing_rows]):
            rows = bearing_rows[meas.sensor[bearing_rows] == s]
            i = rows[np.argmin(np.abs(meas.time[rows] - t_mid))]
            rays.append((meas.sensor_state[i, :3], float(meas.value_si[i]), meas.time[i]))
    else:
        centre = _reference_point(problem, t_mid)
        for b in np.linspace(0.0, 2 * np.pi, g.n_bearings, endpoint=False):
            rays.append((centre, b, t_mid))
    elev = np.radians(g.elevations_deg) if dim == 3 else np.zeros(1)
    pts = []
    for origin, b, _ in rays:
        for e in elev:
            for r in ranges:
                pts.append(origin + r * np.array([np.cos(e) * np.sin(b),
                                                  np.cos(e) * np.cos(b), np.sin(e)]))
    pts = np.array(pts)
    if dim == 2:
        pts[:, 2] = 0.0
    return pts


def _velocities(dim: int, g: GridSettings) -> NDArray[np.float64]:
    vel = [np.zeros(3)]
    for speed in g.speeds:
        if speed <= 0:
            continue
        for c in np.linspace(0.0, 2 * np.pi, g.n_courses, endpoint=False):
            vel.append(speed * np.array([np.sin(c), np.cos(c), 0.0]))
    return np.array(vel)


def grid_candidates(problem: VarProProblem, settings: GridSettings | None = None
                    ) -> NDArray[np.float64]:
    """Candidate parameter vectors ``(m, p)`` for the problem's motion model."""
    g = settings or GridSettings()
    motion = problem.obs.motion
    meas = problem.obs.meas
    t_mid = float(np.median(meas.time))
    pos = _positions(problem, t_mid, motion.dim, g)
    moving = "vx" in motion.param_names or "speed" in motion.param_names
    vel = _velocities(motion.dim, g) if moving else np.zeros((1, 3))
    states = np.zeros((pos.shape[0], vel.shape[0], 6))
    states[..., :3] = pos[:, None, :]
    states[..., 3:] = vel[None, :, :]
    return motion.from_state(states.reshape(-1, 6), t_mid)


def _subsample(problem: VarProProblem, max_rows: int
               ) -> tuple[VarProProblem, NDArray[np.int64]]:
    """A problem on an evenly spread subset of rows per kind (the grid needs no more) and
    the indices of the rows kept."""
    from ..observation import ObservationModel

    meas = problem.obs.meas
    every = np.arange(len(meas))
    if len(meas) <= max_rows or problem.noise.correlated:
        return problem, every
    keep = []
    for k in meas.kinds:
        rows = np.flatnonzero(meas.kind == k)
        take = max(2, round(max_rows * rows.size / len(meas)))
        keep.append(rows[np.unique(np.linspace(0, rows.size - 1, take).round().astype(int))])
    idx = np.sort(np.concatenate(keep))
    sub = meas.take(idx)
    opts = {k: _options_of(m) for k, m in problem.obs.models.items()}
    obs = ObservationModel(sub, problem.obs.motion, opts)
    return VarProProblem(obs, None, problem.fixed), idx


def _options_of(model) -> dict[str, object]:
    opts: dict[str, object] = {}
    if hasattr(model, "drift"):
        opts["drift"] = model.drift
    if hasattr(model, "exponent"):
        opts["exponent"] = model.exponent
    return opts


def best_starts(problem: VarProProblem, y: NDArray[np.float64],
                settings: GridSettings | None = None) -> NDArray[np.float64]:
    """The best few distinct grid candidates for data ``y`` (n,), best first: ``(s, p)``."""
    g = settings or GridSettings()
    cand = grid_candidates(problem, g)
    small, rows = _subsample(problem, g.max_rows)
    y_small = small.group(np.asarray(y, dtype=float)[..., rows])
    nu0 = np.zeros((cand.shape[0], small.k))
    cost = small.evaluate(cand, np.broadcast_to(y_small, (cand.shape[0], rows.size)), nu0,
                          with_jacobian=False).cost
    order = np.argsort(cost)
    chosen: list[int] = []
    scale = np.maximum(np.abs(cand).max(axis=0), 1.0)
    for i in order:
        if not np.isfinite(cost[i]):
            break
        if all(np.max(np.abs(cand[i] - cand[j]) / scale) > 0.05 for j in chosen):
            chosen.append(int(i))
        if len(chosen) == g.starts:
            break
    return cand[chosen]
