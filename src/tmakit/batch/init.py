"""Automatic global initialisation: no initial guess needed.

A coarse grid of trajectories is scored by the reduced (nuisance-eliminated) likelihood in two
vectorised stages (every point on a few rows, the best of them on more), and the best few,
mutually distinct, become the starting points of the batched Levenberg–Marquardt solve.
Positions are placed at the median measurement time: along the measured bearings when there
are bearings (rays from each bearing sensor), otherwise on a polar grid around the sensors, at
geometrically spaced ranges; velocities on a grid of speeds and courses.  3-D models add a few
elevation angles above the sensors' plane (emitters below the sensors are not searched: with
no elevation data, z and its mirror fit equally).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._blas import matmul
from .solver import VarProProblem


@dataclass(frozen=True)
class GridSettings:
    """Extent and density of the initial search (SI units).

    Every grid point is scored on ``coarse_rows`` evenly spread rows, the ``refine`` best on
    ``max_rows``; ``starts`` distinct points start the solve."""

    min_range: float = 100.0
    max_range: float = 50_000.0
    n_ranges: int = 10
    n_bearings: int = 12
    speeds: tuple[float, ...] = (0.0, 10.0, 40.0, 150.0, 450.0)
    n_courses: int = 8
    elevations_deg: tuple[float, ...] = (0.0, 3.0, 10.0, 25.0, 50.0)
    max_rows: int = 30
    starts: int = 6
    coarse_rows: int = 8
    refine: int = 256


def _reference_point(problem: VarProProblem, t_mid: float) -> NDArray[np.float64]:
    meas = problem.obs.meas
    near = [np.argmin(np.abs(meas.time - t_mid) + 1e9 * (meas.sensor != s))
            for s in meas.sensors]
    return meas.sensor_state[near, :3].mean(axis=0)


def _positions(problem: VarProProblem, t_mid: float, dim: int, g: GridSettings
               ) -> NDArray[np.float64]:
    """Candidate positions ``(m, 3)``: rays (from each bearing sensor along its bearing
    nearest ``t_mid``, or a fan around the sensors) x elevations x ranges, in that order."""
    meas = problem.obs.meas
    ranges = np.geomspace(g.min_range, g.max_range, g.n_ranges)
    bearing_rows = np.flatnonzero(meas.kind == "bearing")
    if bearing_rows.size:
        ends = []
        for s in np.unique(meas.sensor[bearing_rows]):
            rows = bearing_rows[meas.sensor[bearing_rows] == s]
            ends.append(rows[np.argmin(np.abs(meas.time[rows] - t_mid))])
        origins = meas.sensor_state[ends, :3]
        bearings = meas.value_si[ends]
    else:
        bearings = np.linspace(0.0, 2 * np.pi, g.n_bearings, endpoint=False)
        origins = np.broadcast_to(_reference_point(problem, t_mid), (bearings.size, 3))
    elev = np.radians(g.elevations_deg) if dim == 3 else np.zeros(1)
    b, e = bearings[:, None], elev[None, :]
    dirs = np.stack(np.broadcast_arrays(np.cos(e) * np.sin(b), np.cos(e) * np.cos(b),
                                        np.sin(e)), axis=-1)  # (rays, elevations, 3)
    pts = (origins[:, None, None, :]
           + ranges[None, None, :, None] * dirs[:, :, None, :]).reshape(-1, 3)
    if dim == 2:
        pts[:, 2] = 0.0
    return pts


def _velocities(dim: int, g: GridSettings) -> NDArray[np.float64]:
    """Candidate velocities ``(m, 3)``: at rest, then each positive speed in every course."""
    speeds = np.array([v for v in g.speeds if v > 0], dtype=float)
    courses = np.linspace(0.0, 2 * np.pi, g.n_courses, endpoint=False)
    moving = np.stack(np.broadcast_arrays(speeds[:, None] * np.sin(courses),
                                          speeds[:, None] * np.cos(courses), 0.0), axis=-1)
    return np.concatenate([np.zeros((1, 3)), moving.reshape(-1, 3)])


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
    for rows in problem.obs.rows.values():
        take = max(2, round(max_rows * rows.size / len(meas)))
        keep.append(rows[np.unique(np.linspace(0, rows.size - 1, take).round().astype(int))])
    idx = np.sort(np.concatenate(keep))
    sub = meas.take(idx)
    obs = ObservationModel(sub, problem.obs.motion, problem.obs.options)
    return VarProProblem(obs, None, problem.fixed), idx


GEOMETRY_FREE = 1e-4
"""A nuisance column whose geometry-dependent part varies over the candidates by less than this
fraction of its size is taken as the same for every candidate (the carrier's, whose Doppler
factor ``1 - rdot/c`` differs from 1 by about 1e-6): the projection is then shared."""


class GridScorer:
    """Reduced cost of a fixed set of candidate trajectories for many data sets at once.

    The predictions of the candidates do not depend on the data, so they are computed once;
    each data set then costs a few matrix products.  With ``u`` the whitened data and ``g``
    the whitened predictions about a reference nuisance ``nu*`` and ``Q`` an orthonormal basis
    of the whitened nuisance design of a candidate, the projected cost is
    ``(|u|^2 - 2 u.g + |g|^2 - |Q'u - Q'g|^2) / 2``; when the design is the same for every
    candidate (see :data:`GEOMETRY_FREE`) ``u`` and ``g`` are projected once and the last term
    drops.  Angle rows (which carry no nuisance) use the chord form
    ``w^2 (1 - cos(y - h))``: equal to the squared residual for small residuals, free of
    wrapping, and bilinear in (cos y, sin y).
    """

    def __init__(self, problem: VarProProblem, candidates: NDArray[np.float64]) -> None:
        self.problem = problem
        self.candidates = candidates
        obs = problem.obs
        h0, a_var = _predictions(obs, candidates)
        self.bad = ~(np.isfinite(h0).all(axis=1) & np.isfinite(a_var).all(axis=(1, 2)))
        if self.bad.any():  # no prediction: infinite cost; any finite values do meanwhile
            h0[self.bad] = 0.0
            a_var[self.bad] = a_var[np.argmin(self.bad)] if not self.bad.all() else 0.0
        self.angle = problem.angle
        self.a_const = problem.const_design  # geometry-free: one copy
        self.h0, self.a_var = h0, a_var
        self.weight2 = problem.noise.inv_sigma[self.angle] ** 2
        self.shared = None  # (n, k) basis shared by every candidate
        self.basis = None   # (C, n, k) basis per candidate
        if problem.eliminates:
            ref = a_var[0]
            aw = problem.const_design_w + problem.noise.whiten(
                ref if _same_design(a_var, ref, self.a_const) else a_var, axis=-2)
            aw[..., self.angle, :] = 0.0
            if aw.ndim == 2:
                self.shared = orthonormal_columns(aw[None])[0]
            else:
                self.basis = orthonormal_columns(aw)

    def _reference(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """A nuisance value near the data's (least squares on the geometry-free design of the
        median data set), about which residuals are formed without cancellation."""
        return self.problem.reference_nuisance(np.median(y, axis=0))[0]

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Costs ``(B, C)`` for grouped data ``y`` ``(B, n)``."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        noise, angle = self.problem.noise, self.angle
        star = self._reference(y)
        u = noise.whiten(y - self.a_const @ star)
        g = self.h0.copy(order="K")
        for j in np.flatnonzero(star):  # the design one column at a time (k is small)
            g += self.a_var[..., j] * star[j]
        g = noise.whiten(g)
        u[:, angle] = 0.0
        g[:, angle] = 0.0
        if self.shared is not None:
            u -= (u @ self.shared) @ self.shared.T
            g -= matmul(matmul(g, self.shared), self.shared.T)
        cost = matmul(g, -u.T).T
        cost += 0.5 * np.einsum("cn,cn->c", g, g)[None, :]
        cost += 0.5 * np.einsum("bn,bn->b", u, u)[:, None]
        if self.basis is not None:
            c, n, k = self.basis.shape
            qu = matmul(self.basis.transpose(0, 2, 1).reshape(c * k, n),
                        u.T).reshape(c, k, -1).transpose(2, 0, 1)
            qg = (g[:, None, :] @ self.basis)[:, 0, :]
            sv = qu - qg
            cost -= 0.5 * np.einsum("bck,bck->bc", sv, sv)
        if np.any(angle):
            ya, ha = y[:, angle], self.h0[:, angle]
            w2 = self.weight2
            cost += (w2.sum() - matmul(np.cos(ha), (np.cos(ya) * w2).T).T
                     - matmul(np.sin(ha), (np.sin(ya) * w2).T).T)
        cost[:, self.bad] = np.inf
        return np.where(np.isfinite(cost), cost, np.inf)


CANDIDATE_BLOCK = 1024
"""Candidates predicted at a time.  Small blocks keep every temporary array small: memory the
allocator reuses instead of fresh pages from the system, whose first touch (a page fault
each) cost more than the arithmetic on some machines."""


def _predictions(obs, candidates: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``h0`` ``(C, n)`` and ``A_var`` ``(C, n, k)`` of every candidate, block by block."""
    c, n, k = candidates.shape[0], len(obs.meas), obs.n_nuisance
    h0 = np.empty((n, c)).T  # batch axis innermost, as the linearisation makes them
    a_var = np.empty((k, n, c)).transpose(2, 1, 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for lo in range(0, c, CANDIDATE_BLOCK):
            block = slice(lo, lo + CANDIDATE_BLOCK)
            lin = obs.linearisation(candidates[block], derivatives=False)
            h0[block], a_var[block] = lin.h0, lin.a_var
    return h0, a_var


def _same_design(a_var: NDArray[np.float64], ref: NDArray[np.float64],
                 a_const: NDArray[np.float64]) -> bool:
    """Whether every candidate's design ``a_const + a_var`` ``(C, n, k)`` is ``a_const + ref``
    to :data:`GEOMETRY_FREE` of each column's size."""
    size = np.max(np.abs(a_const + ref), axis=0)
    # reductions over the leading axis first: elementwise and fast
    spread = np.maximum(a_var.max(axis=0) - ref, ref - a_var.min(axis=0)).max(axis=0)
    return bool(np.all(spread <= GEOMETRY_FREE * size))


def orthonormal_columns(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """An orthonormal basis ``(C, n, k)`` of the columns of each ``a`` ``(C, n, k)`` (modified
    Gram-Schmidt; a column that depends on the previous ones, or is zero, adds nothing)."""
    q = np.zeros(a.shape)
    for j in range(a.shape[-1]):
        v = a[..., j].copy()
        for i in range(j):
            v -= np.einsum("cn,cn->c", q[..., i], v)[:, None] * q[..., i]
        norm = np.sqrt(np.einsum("cn,cn->c", v, v))
        ref = np.sqrt(np.einsum("cn,cn->c", a[..., j], a[..., j]))
        keep = norm > 1e-10 * ref
        q[..., j] = np.where(keep[:, None], v / np.where(keep, norm, 1.0)[:, None], 0.0)
    return q


class Starts:
    """The mutually distinct candidates of one data set, best first, chosen as they are asked
    for: greedily in order of cost, each candidate not within 5 % of each parameter's spread
    of one already chosen.  ``scaled`` (the candidates divided by that spread, transposed) may
    be shared by data sets with the same candidates."""

    def __init__(self, candidates: NDArray[np.float64], cost: NDArray[np.float64],
                 scaled: NDArray[np.float64] | None = None) -> None:
        self.candidates = candidates
        self.scaled = _scaled(candidates) if scaled is None else scaled
        self.left = np.where(np.isfinite(cost), cost, np.inf)
        self.chosen: list[int] = []

    def first(self, m: int) -> NDArray[np.float64]:
        """The ``m`` best distinct candidates ``(<= m, p)`` (fewer when no more are finite)."""
        while len(self.chosen) < m:
            i = int(np.argmin(self.left))
            if not np.isfinite(self.left[i]):
                break
            self.chosen.append(i)
            near = np.max(np.abs(self.scaled - self.scaled[:, i:i + 1]), axis=0) <= 0.05
            self.left[near] = np.inf
        return self.candidates[self.chosen[:m]]


def _scaled(candidates: NDArray[np.float64]) -> NDArray[np.float64]:
    """Candidates over each parameter's spread, transposed ``(p, C)`` for fast distances."""
    scale = np.maximum(np.abs(candidates).max(axis=0), 1.0)
    return np.ascontiguousarray((candidates / scale).T)


def best_starts(problem: VarProProblem, y: NDArray[np.float64],
                settings: GridSettings | None = None) -> NDArray[np.float64]:
    """The best few distinct grid candidates for data ``y`` (n,), best first: ``(s, p)``."""
    g = settings or GridSettings()
    return best_starts_many(problem, np.asarray(y, dtype=float)[None, :], g)[0].first(g.starts)


def _data_dependent(problem: VarProProblem) -> bool:
    """Whether the candidate set depends on the data (rays along measured bearings)."""
    return bool(np.any(problem.obs.meas.kind == "bearing"))


def best_starts_many(problem: VarProProblem, ys: NDArray[np.float64],
                     settings: GridSettings | None = None) -> list[Starts]:
    """The grid's distinct candidates, best first, for several data sets ``(B, n)`` that share
    times, sensors and noise (Monte Carlo runs): ``starts[b].first(m)``.  When the candidates
    do not depend on the data they are predicted once for all."""
    g = settings or GridSettings()
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    small, rows = _subsample(problem, g.max_rows)
    coarse, coarse_rows = _subsample(problem, min(g.coarse_rows, g.max_rows))
    stages = ((coarse, coarse.group(ys[:, coarse_rows])), (small, small.group(ys[:, rows])))
    if _data_dependent(problem):
        out = []
        for b in range(ys.shape[0]):
            cand = grid_candidates(_with_values(small, stages[1][1][b]), g)
            cand, cost = _scores(stages, cand, g.refine, b)
            out.append(Starts(cand, cost[0]))
        return out
    cand, cost = _scores(stages, grid_candidates(small, g), g.refine)
    scaled = _scaled(cand)
    return [Starts(cand, cost[b], scaled) for b in range(ys.shape[0])]


def _scores(stages, cand: NDArray[np.float64], refine: int, run: int | None = None
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Grid costs ``(B, C')`` of candidates ``(C, p)`` in two stages: every candidate on a few
    rows (``stages[0]``: problem and grouped data), then the ``refine`` best of each data set
    (their union) on more rows (``stages[1]``).  ``run`` scores that data set only."""
    (coarse, y_coarse), (small, y_small) = stages
    if run is not None:
        y_coarse, y_small = y_coarse[run:run + 1], y_small[run:run + 1]
    if coarse is not small and cand.shape[0] > refine:
        first = GridScorer(coarse, cand).score(y_coarse)
        best = np.argpartition(first, refine - 1, axis=1)[:, :refine]
        keep = np.unique(best[np.isfinite(np.take_along_axis(first, best, axis=1))])
        cand = cand[keep]
    return cand, GridScorer(small, cand).score(y_small)


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
