"""Automatic global initialisation: a grid of trajectories scored by the reduced likelihood.

The grid (:func:`grid_candidates`) is scored in two stages (:class:`GridScorer`, or
:class:`ChordScorer` for bearings under affine motion); the best distinct points
(:class:`Starts`) start the batched Levenberg–Marquardt solve.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..core.blas import matmul
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..observation.planar import PlanarUnits, planar_units
from .solver import VarProProblem

__all__ = ["SHORTLIST", "ChordScorer", "GridScorer", "GridSettings", "Starts", "best_starts",
           "best_starts_many", "chord_units", "first_of_many", "grid_candidates",
           "grid_candidates_for", "grid_start", "orthonormal_columns", "starts_of", "subsample"]


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
    coarse_rows: int = 8
    refine: int = 256


def _reference_point(meas: MeasurementSet, t_mid: float) -> NDArray[np.float64]:
    near = [np.argmin(np.abs(meas.time - t_mid) + 1e9 * ~meas.sensor_mask(s))
            for s in meas.sensors]
    return meas.sensor_state[near, :3].mean(axis=0)


def _positions(meas: MeasurementSet, rows: NDArray[np.intp] | None,
               values: NDArray[np.float64] | None, t_mid: float, dim: int, g: GridSettings
               ) -> NDArray[np.float64]:
    """Return candidate positions ``(m, 3)``: rays x elevations x ranges, in that order."""
    ranges = _ranges(g.min_range, g.max_range, g.n_ranges)
    kind = meas.kind_mask("bearing")
    at = np.flatnonzero(kind if rows is None else kind[rows])  # bearings among the rows
    if at.size:
        own = at if rows is None else rows[at]  # (their rows in the set)
        codes, time = meas.sensor_code[own], meas.time[own]
        if codes.min() == codes.max():  # one sensor
            ends = [at[np.argmin(np.abs(time - t_mid))]]
        else:  # the sensors in the order of their ids
            ends = []
            for c in sorted(np.unique(codes).tolist(), key=meas.sensor_names.__getitem__):
                mine = codes == c
                ends.append(at[mine][np.argmin(np.abs(time[mine] - t_mid))])
        ends_set = ends if rows is None else rows[ends]
        origins = meas.sensor_state[ends_set, :3]
        bearings = meas.value_si[ends_set] if values is None else values[ends]
        dirs = _directions(bearings, _elevations(dim, tuple(g.elevations_deg)))
    else:
        dirs = _fan(g.n_bearings, dim, tuple(g.elevations_deg))
        origins = np.broadcast_to(
            _reference_point(meas if rows is None else meas.take(rows), t_mid),
            (dirs.shape[0], 3))
    pts = (origins[:, None, None, :]
           + ranges[None, None, :, None] * dirs[:, :, None, :]).reshape(-1, 3)
    if dim == 2:
        pts[:, 2] = 0.0
    return pts


def _median(x: NDArray[np.float64]) -> float:
    """Return ``np.median(x)`` of a 1-D array, the same bits, without its overhead for few rows."""
    n = x.shape[0]
    if not 0 < n <= 256:
        return float(np.median(x))
    s = np.sort(x)
    if s[-1] != s[-1]:  # NaN (sorted last): median's NaN
        return float(np.median(x))
    return float(s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2.0)


def _elevations(dim: int, elevations_deg: tuple[float, ...]) -> NDArray[np.float64]:
    """Return candidate elevation angles (rad): the given ones in 3-D, 0 in 2-D."""
    return np.radians(elevations_deg) if dim == 3 else np.zeros(1)


def _directions(bearings: NDArray[np.float64], elev: NDArray[np.float64]
                ) -> NDArray[np.float64]:
    """Return unit vectors ``(rays, elevations, 3)`` at each bearing and elevation (rad)."""
    b, e = bearings[:, None], elev[None, :]
    out = np.empty((bearings.shape[0], elev.shape[0], 3))
    cos_e = np.cos(e)
    np.multiply(cos_e, np.sin(b), out=out[..., 0])
    np.multiply(cos_e, np.cos(b), out=out[..., 1])
    out[..., 2] = np.sin(e)
    return out


@lru_cache(maxsize=16)
def _fan(n_bearings: int, dim: int, elevations_deg: tuple[float, ...]) -> NDArray[np.float64]:
    """Return :func:`_directions` of ``n_bearings`` even bearings (read-only, cached)."""
    dirs = _directions(np.linspace(0.0, 2 * np.pi, n_bearings, endpoint=False),
                       _elevations(dim, elevations_deg))
    dirs.flags.writeable = False
    return dirs


@lru_cache(maxsize=16)
def _ranges(min_range: float, max_range: float, n_ranges: int) -> NDArray[np.float64]:
    """Return candidate ranges (m), geometrically spaced; read-only, made once per settings."""
    ranges = np.geomspace(min_range, max_range, n_ranges)
    ranges.flags.writeable = False
    return ranges


@lru_cache(maxsize=16)
def _velocities(speeds: tuple[float, ...], n_courses: int) -> NDArray[np.float64]:
    """Return candidate velocities ``(m, 3)`` (m/s): at rest, then each speed and course."""
    moves = np.array([v for v in speeds if v > 0], dtype=np.float64)
    courses = np.linspace(0.0, 2 * np.pi, n_courses, endpoint=False)
    moving = np.stack(np.broadcast_arrays(moves[:, None] * np.sin(courses),
                                          moves[:, None] * np.cos(courses), 0.0), axis=-1)
    vel = np.concatenate([np.zeros((1, 3)), moving.reshape(-1, 3)])
    vel.flags.writeable = False
    return vel


def grid_candidates(problem: VarProProblem, settings: GridSettings | None = None
                    ) -> NDArray[np.float64]:
    """Return the candidate parameter vectors ``(m, p)``, SI, at the median measurement time."""
    return grid_candidates_for(problem.obs.meas, problem.obs.motion, settings)


def grid_candidates_for(meas: MeasurementSet, motion: MotionModel,
                        settings: GridSettings | None = None,
                        rows: NDArray[np.intp] | None = None,
                        values: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Return :func:`grid_candidates` from the measurements and motion model themselves."""
    g = settings or GridSettings()
    t_mid = _median(meas.time if rows is None else meas.time[rows])
    pos = _positions(meas, rows, values, t_mid, motion.dim, g)
    moving = "vx" in motion.param_names or "speed" in motion.param_names
    vel = _velocities(tuple(g.speeds), g.n_courses) if moving else np.zeros((1, 3))
    # Component-major (each component of every state contiguous): the conversion then runs
    # along long rows instead of across rows of 6.
    states = np.empty((6, pos.shape[0], vel.shape[0]))
    states[:3] = pos.T[:, :, None]
    states[3:] = vel.T[:, None, :]
    return motion.from_state(states.reshape(6, -1).T, t_mid)


def subsample(problem: VarProProblem, max_rows: int
              ) -> tuple[VarProProblem, NDArray[np.int64]]:
    """Return the problem on about ``max_rows`` evenly spread rows per kind, and the rows kept."""
    idx = _spread_rows(problem, max_rows)
    if idx is None:  # correlated rows: the subset's noise is its own block
        return problem, np.arange(len(problem.obs.meas))
    return problem.take(idx), idx


def _spread_rows(problem: VarProProblem, max_rows: int) -> NDArray[np.int64] | None:
    """Return the rows (set order) of :func:`subsample`, or None when it keeps them all."""
    n = len(problem.obs.meas)
    if n <= max_rows:
        return None
    obs = problem.obs
    keep = []
    for sl in obs.slices.values():
        size = sl.stop - sl.start
        pick = _evenly_spread(size, max(2, round(max_rows * size / n)))
        # rows already grouped: a kind's rows are its slice (no index array of every row)
        keep.append(pick + sl.start if obs.in_set_order else obs.order[sl][pick])
    return keep[0] if len(keep) == 1 else np.sort(np.concatenate(keep))


@lru_cache(maxsize=64)
def _evenly_spread(size: int, take: int) -> NDArray[np.int64]:
    """Return about ``take`` evenly spread indices into ``size`` rows, first and last included."""
    idx = np.unique(np.linspace(0, size - 1, take).round().astype(int))
    idx.flags.writeable = False
    return idx


GEOMETRY_FREE = 1e-4
"""A nuisance column varying over a block by less than this fraction is the same for all."""


class GridScorer:
    """Reduced cost ``(|u|^2 - 2 u.g + |g|^2 - |Q'u - Q'g|^2) / 2`` of candidates, by blocks."""

    def __init__(self, problem: VarProProblem, candidates: NDArray[np.float64]) -> None:
        self.problem = problem
        self.candidates = candidates
        self.angle = problem.angle
        self.a_const = problem.const_design  # geometry-free: one copy
        self.weight2 = problem.noise.inv_sigma[self.angle] ** 2
        step = _block_size(len(problem.obs.meas))
        self.blocks = [slice(lo, lo + step) for lo in range(0, candidates.shape[0], step)]
        self._made: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
        self.ref = self._reference_design()
        # A block's design is the reference's when within this of it (see _same_design).
        self.tolerance = GEOMETRY_FREE * np.max(np.abs(self.a_const + self.ref), axis=0)
        self.shared = None  # (n, k) basis shared by the candidates of same-design blocks
        if problem.eliminates:
            aw = problem.const_design_w + problem.noise.whiten(self.ref, axis=-2)
            aw[self.angle, :] = 0.0
            self.shared = orthonormal_columns(aw[None])[0]

    def _predict(self, i: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Return ``h0`` ``(c, n)`` and ``A_var`` ``(c, n, k)`` of the candidates of block ``i``."""
        if i in self._made:
            return self._made.pop(i)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            lin = self.problem.obs.linearisation(self.candidates[self.blocks[i]],
                                                 derivatives=False)
        return lin.h0, lin.a_var

    def _reference_design(self) -> NDArray[np.float64]:
        """Return ``A_var`` ``(n, k)`` of the first candidate with finite predictions."""
        for i in range(len(self.blocks)):
            h0, a_var = self._made[i] = self._predict(i)
            good = np.flatnonzero(~_bad(h0, a_var))
            if good.size:
                return a_var[good[0]].copy()
        return np.zeros((len(self.problem.obs.meas), self.problem.k))

    def _reference(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return a nuisance value near the data's, about which residuals do not cancel."""
        return self.problem.reference_nuisance(y[0] if y.shape[0] == 1
                                               else np.median(y, axis=0))[0]

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the reduced costs of every candidate for each data set."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        star = self._reference(y)
        u = self.problem.noise.whiten(y - self.a_const @ star)
        u[:, self.angle] = 0.0
        data = {False: (u, 0.5 * np.einsum("bn,bn->b", u, u)[:, None])}
        if self.shared is not None:
            up = u - (u @ self.shared) @ self.shared.T
            data[True] = (up, 0.5 * np.einsum("bn,bn->b", up, up)[:, None])
        cost = np.empty((y.shape[0], self.candidates.shape[0]))
        for i, block in enumerate(self.blocks):
            cost[:, block] = self._score_block(i, y, star, data)
        return np.where(np.isfinite(cost), cost, np.inf)

    def _score_block(self, i: int, y: NDArray[np.float64], star: NDArray[np.float64],
                     data: dict[bool, tuple[NDArray[np.float64], NDArray[np.float64]]]
                     ) -> NDArray[np.float64]:
        """Return costs ``(B, c)`` of the candidates of block ``i``."""
        noise, angle = self.problem.noise, self.angle
        h0, a_var = self._predict(i)
        bad = _bad(h0, a_var)
        if bad.any():  # no prediction: infinite cost; any finite values do meanwhile
            h0[bad] = 0.0
            a_var[bad] = self.ref
        if self.problem.all_angle:  # angles alone (no nuisance): the chord form is the cost
            cost = self._chord(y, h0)
            cost[:, bad] = np.inf
            return cost
        g = h0.copy(order="K")
        for j in np.flatnonzero(star):  # the design one column at a time (k is small)
            g += a_var[..., j] * star[j]
        g = noise.whiten(g)
        g[:, angle] = 0.0
        basis = self.shared
        shared = basis is not None and _same_design(a_var, self.ref, self.tolerance)
        if basis is not None and shared:
            g -= matmul(matmul(g, basis), basis.T)
        u, half_uu = data[shared]
        cost = matmul(g, -u.T).T
        cost += 0.5 * np.einsum("cn,cn->c", g, g)[None, :]
        cost += half_uu
        if self.problem.eliminates and not shared:  # a basis per candidate
            aw = self.problem.const_design_w + noise.whiten(a_var, axis=-2)
            aw[..., angle, :] = 0.0
            basis = orthonormal_columns(aw)
            c, n, k = basis.shape
            qu = matmul(basis.transpose(0, 2, 1).reshape(c * k, n),
                        u.T).reshape(c, k, -1).transpose(2, 0, 1)
            qg = (g[:, None, :] @ basis)[:, 0, :]
            sv = qu - qg
            cost -= 0.5 * np.einsum("bck,bck->bc", sv, sv)
        if np.any(angle):
            cost += self._chord(y[:, angle], h0[:, angle])
        cost[:, bad] = np.inf
        return cost

    def _chord(self, ya: NDArray[np.float64], ha: NDArray[np.float64]) -> NDArray[np.float64]:
        """Give ``sum w^2 (1 - cos(y - h))`` ``(B, c)`` of the angle rows (data, candidates)."""
        w2 = self.weight2
        return (w2.sum() - matmul(np.cos(ha), (np.cos(ya) * w2).T).T
                - matmul(np.sin(ha), (np.sin(ya) * w2).T).T)


CANDIDATE_ROWS = 8000
"""Candidates times rows scored at a time (temporaries the allocator reuses)."""


def _block_size(n_rows: int) -> int:
    """Return candidates per block for ``n_rows`` rows."""
    step = max(128, CANDIDATE_ROWS // max(1, n_rows))
    if step >= 512 and abs(step - 512 * round(step / 512)) <= 8:
        step -= 16
    return step


def _bad(h0: NDArray[np.float64], a_var: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Flag the candidates ``(c,)`` without finite predictions or design."""
    return np.asarray(~(np.isfinite(h0).all(axis=1) & np.isfinite(a_var).all(axis=(1, 2))))


def _same_design(a_var: NDArray[np.float64], ref: NDArray[np.float64],
                 tolerance: NDArray[np.float64]) -> bool:
    """Tell whether every candidate's design ``A_const + a_var`` is ``A_const + ref``."""
    # reductions over the leading axis first: elementwise and fast
    spread = np.maximum(a_var.max(axis=0) - ref, ref - a_var.min(axis=0)).max(axis=0)
    return bool(np.all(spread <= tolerance))


def orthonormal_columns(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return an orthonormal basis of the columns of each matrix (modified Gram-Schmidt)."""
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


def best_starts(problem: VarProProblem, y: NDArray[np.float64],
                settings: GridSettings | None = None) -> NDArray[np.float64]:
    """Return the best few distinct grid candidates for one data set, best first."""
    g = settings or GridSettings()
    return best_starts_many(problem, np.asarray(y, dtype=float)[None, :], g)[0].first(g.starts)


def _data_dependent(problem: VarProProblem) -> bool:
    """Tell whether the candidate set depends on the data (rays along measured bearings)."""
    return "bearing" in problem.obs.models  # (the kinds present)


def best_starts_many(problem: VarProProblem, ys: NDArray[np.float64],
                     settings: GridSettings | None = None) -> list[Starts]:
    """Rank the grid's candidates for several data sets sharing times, sensors and noise."""
    g = settings or GridSettings()
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    small = _Stage(problem, _spread_rows(problem, g.max_rows), ys)
    coarse = _Stage(problem, _spread_rows(problem, min(g.coarse_rows, g.max_rows)), ys)
    meas, rows = small.source()
    if _data_dependent(problem):
        out = []
        for b in range(ys.shape[0]):  # the grid along this data set's bearings
            cand = grid_candidates_for(meas, problem.obs.motion, g, rows, small.values(b))
            cand, cost = _scores(coarse, small, cand, g.refine, b)
            out.append(Starts(cand, cost[0]))
        return out
    cand, cost = _scores(coarse, small, grid_candidates_for(meas, problem.obs.motion, g, rows),
                         g.refine)
    return starts_of(cand, cost)


def chord_units(problem: VarProProblem, rows: NDArray[np.int64] | None = None
                ) -> PlanarUnits | None:
    """Give the predicted angles' sines and cosines of a problem's rows, or None."""
    obs = problem.obs
    if not problem.all_angle or problem.noise.correlated or not obs.in_set_order:
        return None
    return planar_units(obs, rows)


class ChordScorer:
    """Chord cost ``sum w^2 (1 - cos(y - h))`` of candidates (``step`` a block) from ``units``."""

    def __init__(self, units: PlanarUnits, weight2: NDArray[np.float64],
                 candidates: NDArray[np.float64], step: int) -> None:
        self.units = units
        self.weight2 = weight2
        self.candidates = candidates
        self.blocks = [slice(lo, lo + step) for lo in range(0, candidates.shape[0], step)]

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the chord costs of every candidate for each data set."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        w2 = self.weight2
        sin_w, cos_w = (np.sin(y) * w2).T, (np.cos(y) * w2).T  # (m, B)
        total = w2.sum()
        cost = np.empty((y.shape[0], self.candidates.shape[0]))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            for block in self.blocks:
                sin_h, cos_h = self.units(self.candidates[block])
                dot = matmul(sin_h, sin_w)
                dot += matmul(cos_h, cos_w)
                cost[:, block] = (total - dot).T
        return np.where(np.isfinite(cost), cost, np.inf)


class _Stage:
    """The rows (set order, None: all) one stage of the grid scores on, and the data ``ys``."""

    def __init__(self, problem: VarProProblem, rows: NDArray[np.int64] | None,
                 ys: NDArray[np.float64]) -> None:
        self.rows = rows
        self.units = chord_units(problem, rows)
        self.whole = problem
        if self.units is None:
            self.problem: VarProProblem | None = problem if rows is None else problem.take(rows)
            self.y = self.problem.group(ys if rows is None else ys[:, rows])
            return
        self.problem = None
        self.y = ys if rows is None else ys[:, rows]  # one kind: grouped is set order
        # the weights of the noise model the subset would get (see VarProProblem.take)
        self.weight2 = (problem.noise.inv_sigma if rows is None
                        else 1.0 / problem.obs.sigmas_grouped[rows]) ** 2

    def scorer(self, candidates: NDArray[np.float64]) -> GridScorer | ChordScorer:
        """Return the scorer of ``candidates`` ``(C, p)`` on the stage's rows."""
        if self.units is None:
            assert self.problem is not None  # (made when there are no chord units)
            return GridScorer(self.problem, candidates)
        return ChordScorer(self.units, self.weight2, candidates, _block_size(self.units.m))

    def source(self) -> tuple[MeasurementSet, NDArray[np.int64] | None]:
        """Return a measurement set and its rows (None: all) that are the stage's rows."""
        if self.problem is not None:
            return self.problem.obs.meas, None
        return self.whole.obs.meas, self.rows

    def values(self, b: int) -> NDArray[np.float64]:
        """Return data set ``b`` on the stage's rows in the set's order (SI)."""
        if self.problem is None:
            return self.y[b]
        return self.y[b][self.problem.obs.inverse]


def _scores(coarse: _Stage, small: _Stage, cand: NDArray[np.float64], refine: int,
            run: int | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return grid costs ``(B, C')`` of candidates ``(C, p)`` in two stages."""
    y_coarse, y_small = coarse.y, small.y
    if run is not None:
        y_coarse, y_small = y_coarse[run:run + 1], y_small[run:run + 1]
    if coarse.rows is not None and cand.shape[0] > refine:  # (else both are every row)
        first = coarse.scorer(cand).score(y_coarse)
        if first.shape[0] == 1:  # one data set: its best are distinct, sorted by a sort
            best = np.argpartition(first[0], refine - 1)[:refine]
            keep = np.sort(best[np.isfinite(first[0, best])])
        else:
            best = np.argpartition(first, refine - 1, axis=1)[:, :refine]
            keep = np.unique(best[np.isfinite(np.take_along_axis(first, best, axis=1))])
        cand = cand[keep]
    return cand, small.scorer(cand).score(y_small)


def grid_start(meas: MeasurementSet, motion: MotionModel,
               options: Mapping[str, Mapping[str, object]] | None = None
               ) -> NDArray[np.float64]:
    """Return tmakit's no-guess starting point: the best point of the likelihood grid."""
    obs = ObservationModel(meas, motion, options)
    problem = VarProProblem(obs, NoiseModel(obs.grouped, obs.models))
    starts = best_starts(problem, obs.values)
    if starts.shape[0] == 0:
        raise ValueError("no starting point gives finite predictions; check the data")
    return starts[0]


Shortlist = tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]


class Starts:
    """The distinct candidates ``(C, p)`` of one data set, best first (5 % of each spread apart)."""

    def __init__(self, candidates: NDArray[np.float64], cost: NDArray[np.float64],
                 scaled: NDArray[np.float64] | None = None,
                 shortlist: NDArray[np.int64] | None = None) -> None:
        self.candidates = candidates
        self.scaled = _scaled(candidates) if scaled is None else scaled
        self.left = np.where(np.isfinite(cost), cost, np.inf)
        self.chosen: list[int] = []
        # The shortlist walked first: indices, their scaled candidates (p, K), whether each is
        # near one chosen; None until made, False once the full set has taken over.
        self._short: Shortlist | bool | None
        self._short = None if shortlist is None else self._shortlist(shortlist)
        self._at = 0  # the shortlist's next position

    def _shortlist(self, idx: NDArray[np.int64]
                   ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
        """Give the shortlist state of candidates ``idx`` (in order)."""
        return idx, self.scaled[:, idx], np.zeros(idx.shape[0], dtype=bool)

    def first(self, m: int) -> NDArray[np.float64]:
        """Return the ``m`` best distinct candidates."""
        if len(self.chosen) < m and self._short is not False:
            self._from_shortlist(m)
        while len(self.chosen) < m:
            i = int(np.argmin(self.left))
            if not np.isfinite(self.left[i]):
                break
            self._choose(i)
        return self.candidates[self.chosen[:m]]

    def _choose(self, i: int) -> None:
        """Choose candidate ``i``: no candidate near it is chosen later."""
        self.chosen.append(i)
        self._drop_near(i)

    def _drop_near(self, i: int) -> None:
        """Leave out every candidate near candidate ``i`` (within 5 % of each spread)."""
        near = np.max(np.abs(self.scaled - self.scaled[:, i:i + 1]), axis=0) <= 0.05
        self.left[near] = np.inf

    def _from_shortlist(self, m: int) -> None:
        """Choose as :meth:`first` does, among the cheapest candidates alone (while exact)."""
        if self._short is None:
            self._short = self._shortlist(_cheapest(self.left[None, :])[0])
        _walk_together([self], m)
        if len(self.chosen) < m:  # the full set takes over from here
            self._short = False
            for i in self.chosen:
                self._drop_near(i)


SHORTLIST = 64
"""Cheapest candidates among which :meth:`Starts.first` chooses before it scans them all."""


def _cheapest(left: NDArray[np.float64]) -> NDArray[np.int64]:
    """Give the :data:`SHORTLIST` cheapest columns of each row of ``left`` ``(B, C)``."""
    count = left.shape[1]
    if count > SHORTLIST:
        idx = np.argpartition(left, SHORTLIST - 1, axis=1)[:, :SHORTLIST]
    else:
        idx = np.broadcast_to(np.arange(count), left.shape)
    order = np.lexsort((idx, np.take_along_axis(left, idx, axis=1)), axis=-1)
    return np.take_along_axis(idx, order, axis=1)


def first_of_many(starts: list[Starts], m: int) -> list[NDArray[np.float64]]:
    """Give ``s.first(m)`` for every ``s`` of ``starts``, their shortlists walked together."""
    group = [s for s in starts if len(s.chosen) < m and isinstance(s._short, tuple)
             and s._short[0].shape[0] == SHORTLIST]
    if len(group) > 1:
        _walk_together(group, m)
    return [s.first(m) for s in starts]


def _walk_together(group: list[Starts], m: int) -> None:
    """Walk the shortlists of ``group`` (all of one length) to ``m`` choices each, in place."""
    shorts = [s._short for s in group]
    idx = np.stack([sh[0] for sh in shorts])  # type: ignore[index]
    scaled = np.stack([sh[1] for sh in shorts])  # type: ignore[index]  # (R, p, K)
    out = np.stack([sh[2] for sh in shorts])  # type: ignore[index]
    cost = np.stack([s.left[i] for s, i in zip(group, idx, strict=True)])
    at = np.array([s._at for s in group])
    need = np.array([m - len(s.chosen) for s in group])
    k = idx.shape[1]
    cut = cost[:, -1] if k == SHORTLIST else np.full(len(group), np.inf)
    pos, rows = np.arange(k), np.arange(len(group))
    live = need > 0
    while live.any():
        avail = ~out & (pos >= at[:, None])
        has = np.asarray(avail.any(axis=1))
        nxt = np.argmax(avail, axis=1)  # the first candidate not near one chosen
        c = cost[rows, nxt]
        ok = has & (c < cut) & np.isfinite(c)
        stop = live & ~ok  # a tie with the cut, or none left: the walk stops there
        at[stop] = np.where(has[stop], nxt[stop], k)
        live &= ok
        r = np.flatnonzero(live)
        if not r.size:
            break
        nr = nxt[r]
        out[r] |= np.max(np.abs(scaled[r] - scaled[r, :, nr][:, :, None]), axis=1) <= 0.05
        at[r] = nr + 1
        for i, j in zip(r.tolist(), idx[r, nr].tolist(), strict=True):
            group[i].chosen.append(j)
        need[r] -= 1
        live &= need > 0
    for i, s in enumerate(group):
        s._at = int(at[i])
        s._short[2][:] = out[i]  # type: ignore[index]


def _scaled(candidates: NDArray[np.float64]) -> NDArray[np.float64]:
    """Candidates over each parameter's spread, transposed ``(p, C)`` for fast distances."""
    scaled = np.array(candidates.T, order="C")  # a copy; reductions along rows: fast
    scaled /= np.maximum(np.abs(scaled).max(axis=1), 1.0)[:, None]
    return scaled


def starts_of(candidates: NDArray[np.float64], costs: NDArray[np.float64]) -> list[Starts]:
    """Return the :class:`Starts` of several data sets scored on the same candidates."""
    scaled = _scaled(candidates)
    left = np.where(np.isfinite(costs), costs, np.inf)
    short = _cheapest(left) if costs.shape[0] > 1 else [None] * costs.shape[0]
    return [Starts(candidates, cost, scaled, s) for cost, s in zip(costs, short, strict=True)]
