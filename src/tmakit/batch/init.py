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
    obs = ObservationModel(sub, problem.obs.motion, problem.obs.options)
    return VarProProblem(obs, None, problem.fixed), idx


class GridScorer:
    """Reduced cost of a fixed set of candidate trajectories for many data sets at once.

    The predictions of the candidates do not depend on the data, so they are computed once;
    each data set then costs a few matrix products.  With ``e = u - g`` the whitened residual
    about a reference nuisance ``nu*`` and ``q`` the scaled whitened design, the projected cost
    is ``(|u|^2 - 2 u.g + |g|^2 - s' G^-1 s) / 2`` with ``s = q'u - q'g``.  Angle rows (which
    carry no nuisance) use the chord form ``w^2 (1 - cos(y - h))``: equal to the squared
    residual for small residuals, free of wrapping, and bilinear in (cos y, sin y).
    """

    def __init__(self, problem: VarProProblem, candidates: NDArray[np.float64]) -> None:
        self.problem = problem
        self.candidates = candidates
        obs = problem.obs
        with np.errstate(invalid="ignore", divide="ignore"):
            h0, a_const, a_var, _, _ = obs.linearise_grouped(candidates, derivatives=False)
        self.bad = ~np.all(np.isfinite(h0), axis=1) | ~np.all(np.isfinite(a_var), axis=(1, 2))
        h0 = np.where(np.isfinite(h0), h0, 0.0)
        a_var = np.where(np.isfinite(a_var), a_var, 0.0)
        self.angle = problem.angle
        self.a_const = a_const[0] if a_const.shape[0] else a_const  # geometry-free: one copy
        self.h0, self.a_var = h0, a_var
        self.k = problem.k
        self.weight2 = problem.noise.inv_sigma[self.angle] ** 2
        if self.k and problem.fixed is None:
            aw = problem.noise.whiten(a_const + a_var, axis=-2)
            aw[:, self.angle, :] = 0.0
            scale = np.sqrt(np.einsum("cnk,cnk->ck", aw, aw))
            self.q = aw / np.where(scale > 0, scale, 1.0)[:, None, :]
            self.ginv = np.linalg.pinv(np.einsum("cnk,cnl->ckl", self.q, self.q))

    def _reference(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """A nuisance value near the data's (least squares on the geometry-free design of the
        median data set), about which residuals are formed without cancellation."""
        if self.problem.fixed is not None:
            return self.problem.fixed
        if self.k == 0 or not np.any(self.a_const):
            return np.zeros(self.k)
        med = np.median(y, axis=0)
        rows = ~self.angle & np.any(self.a_const != 0, axis=1)
        sol, *_ = np.linalg.lstsq(self.a_const[rows], med[rows], rcond=None)
        return sol

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Costs ``(B, C)`` for grouped data ``y`` ``(B, n)``."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        noise, angle = self.problem.noise, self.angle
        star = self._reference(y)
        u = noise.whiten(y - self.a_const @ star)
        g = noise.whiten(self.h0 + self.a_var @ star)
        u[:, angle] = 0.0
        g[:, angle] = 0.0
        cost = 0.5 * (np.einsum("bn,bn->b", u, u)[:, None] - 2.0 * u @ g.T
                      + np.einsum("cn,cn->c", g, g)[None, :])
        if self.k and self.problem.fixed is None:
            qu = np.einsum("cnk,bn->bck", self.q, u)
            qg = np.einsum("cnk,cn->ck", self.q, g)
            sv = qu - qg[None]
            cost -= 0.5 * np.einsum("bck,ckl,bcl->bc", sv, self.ginv, sv)
        if np.any(angle):
            ya, ha = y[:, angle], self.h0[:, angle]
            w2 = self.weight2
            cost += (w2.sum() - (np.cos(ya) * w2) @ np.cos(ha).T
                     - (np.sin(ya) * w2) @ np.sin(ha).T)
        cost[:, self.bad] = np.inf
        return np.where(np.isfinite(cost), cost, np.inf)


def _select(candidates: NDArray[np.float64], cost: NDArray[np.float64], starts: int
            ) -> NDArray[np.float64]:
    """The best ``starts`` mutually distinct candidates (5 % of each parameter's spread)."""
    order = np.argsort(cost, kind="stable")
    chosen: list[int] = []
    scale = np.maximum(np.abs(candidates).max(axis=0), 1.0)
    for i in order:
        if not np.isfinite(cost[i]):
            break
        if all(np.max(np.abs(candidates[i] - candidates[j]) / scale) > 0.05 for j in chosen):
            chosen.append(int(i))
        if len(chosen) == starts:
            break
    return candidates[chosen]


def best_starts(problem: VarProProblem, y: NDArray[np.float64],
                settings: GridSettings | None = None) -> NDArray[np.float64]:
    """The best few distinct grid candidates for data ``y`` (n,), best first: ``(s, p)``."""
    return best_starts_many(problem, np.asarray(y, dtype=float)[None, :], settings)[0]


def _data_dependent(problem: VarProProblem) -> bool:
    """Whether the candidate set depends on the data (rays along measured bearings)."""
    return bool(np.any(problem.obs.meas.kind == "bearing"))


def best_starts_many(problem: VarProProblem, ys: NDArray[np.float64],
                     settings: GridSettings | None = None) -> list[NDArray[np.float64]]:
    """:func:`best_starts` for several data sets ``(B, n)`` that share times, sensors and
    noise (Monte Carlo runs).  When the candidates do not depend on the data they are
    predicted once for all."""
    g = settings or GridSettings()
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    small, rows = _subsample(problem, g.max_rows)
    y_small = small.group(ys[:, rows])
    if _data_dependent(problem):
        out = []
        for b in range(ys.shape[0]):
            cand = grid_candidates(_with_values(small, y_small[b]), g)
            out.append(_select(cand, GridScorer(small, cand).score(y_small[b])[0], g.starts))
        return out
    cand = grid_candidates(small, g)
    cost = GridScorer(small, cand).score(y_small)
    return [_select(cand, cost[b], g.starts) for b in range(ys.shape[0])]


def _with_values(problem: VarProProblem, y_grouped: NDArray[np.float64]) -> VarProProblem:
    """The same problem whose measurement set carries the values ``y`` (grouped order), so that
    the grid can follow this data set's measured bearings."""
    from ..observation import ObservationModel

    meas = problem.obs.meas
    values = np.array(meas.value, dtype=float)
    si = y_grouped[problem.obs.inverse]
    for kind, model in problem.obs.models.items():
        sel = meas.kind == kind
        values[sel] = model.value_from_si(si[sel])
    copy = meas.take(np.arange(len(meas)))
    copy.value = values
    obs = ObservationModel(copy, problem.obs.motion, problem.obs.options)
    return VarProProblem(obs, problem.noise, problem.fixed)
