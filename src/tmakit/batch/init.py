"""Automatic global initialisation: no initial guess needed.

A coarse grid of trajectories is scored by the reduced (nuisance-eliminated) likelihood in two
vectorised stages (every point on a few rows, the best of them on more), and the best few,
mutually distinct, become the starting points of the batched Levenberg–Marquardt solve.
Bearings alone under an affine motion model are scored by
:class:`~tmakit.batch.chord.ChordScorer` on the rows of the problem itself (sines and cosines
from the relative positions, no subset problem); the others by :class:`GridScorer` on the
problem restricted to the rows.
The grid itself is :mod:`tmakit.batch.grid`: positions along the measured bearings or on a
polar grid around the sensors, velocities on a grid of speeds and courses; 3-D models add a few
elevation angles above the sensors' plane (emitters below the sensors are not searched: with
no elevation data, z and its mirror fit equally).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..core.blas import matmul
from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from .chord import ChordScorer, chord_units
from .grid import GridSettings, grid_candidates, grid_candidates_for
from .solver import VarProProblem
from .starts import Starts, starts_of

__all__ = ["ChordScorer", "GridScorer", "GridSettings", "Starts", "best_starts",
           "best_starts_many", "chord_units", "grid_candidates", "grid_start",
           "orthonormal_columns", "subsample"]


def _subsample(problem: VarProProblem, max_rows: int
               ) -> tuple[VarProProblem, NDArray[np.int64]]:
    """Return the problem on an evenly spread subset of rows per kind, and the rows kept.

    The grid needs no more rows.
    """
    idx = _spread_rows(problem, max_rows)
    if idx is None:  # correlated rows: the subset's noise is its own block
        return problem, np.arange(len(problem.obs.meas))
    return problem.take(idx), idx


def _spread_rows(problem: VarProProblem, max_rows: int) -> NDArray[np.int64] | None:
    """Return the rows (set order) of :func:`_subsample`, or None when it keeps them all."""
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


def subsample(problem: VarProProblem, max_rows: int
              ) -> tuple[VarProProblem, NDArray[np.int64]]:
    """Return the problem on about ``max_rows`` evenly spread rows per kind, and the rows kept.

    The whole problem (and every row) when it has no more rows.  With correlated noise
    (range differences whose spans overlap) the subset's noise model is made for its own rows:
    their covariance is the whole one's block on them.

    Parameters
    ----------
    problem : VarProProblem
        The problem.
    max_rows : int
        Rows wanted in all (shared among the kinds by their counts).

    Returns
    -------
    (VarProProblem, ndarray of int)
        The smaller problem and its rows in the measurement set's order.
    """
    return _subsample(problem, max_rows)


@lru_cache(maxsize=64)
def _evenly_spread(size: int, take: int) -> NDArray[np.int64]:
    """Return about ``take`` evenly spread indices into ``size`` rows, first and last included.

    Read-only, made once per pair.
    """
    idx = np.unique(np.linspace(0, size - 1, take).round().astype(int))
    idx.flags.writeable = False
    return idx


GEOMETRY_FREE = 1e-4
"""A nuisance column whose geometry-dependent part varies over the candidates (of a block of
:class:`GridScorer`) by less than this fraction of its size is taken as the same for every
candidate (the carrier's, whose Doppler factor ``1 - rdot/c`` differs from 1 by about 1e-6):
the projection is then shared."""


class GridScorer:
    """Reduced cost of a fixed set of candidate trajectories for many data sets at once.

    Parameters
    ----------
    problem : VarProProblem
        The observation and noise model (nuisance eliminated or fixed).
    candidates : ndarray, shape (C, p)
        Motion parameters of the candidates (SI).

    Notes
    -----
    With ``u`` the whitened data and ``g`` the whitened predictions about a reference nuisance
    ``nu*`` and ``Q`` an orthonormal basis of the whitened nuisance design of a candidate, the
    projected cost is ``(|u|^2 - 2 u.g + |g|^2 - |Q'u - Q'g|^2) / 2``; where the design is the
    same for every candidate of a block (see :data:`GEOMETRY_FREE`) ``u`` and ``g`` are
    projected on one shared basis (:attr:`shared`) and the last term drops.  Angle rows (which
    carry no nuisance) use the chord form ``w^2 (1 - cos(y - h))``: equal to the squared
    residual for small residuals, free of wrapping, and bilinear in (cos y, sin y).

    The candidates are predicted and scored block by block (:data:`CANDIDATE_ROWS`), every
    data set at once: no array ever holds the predictions of every candidate.
    """

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
        """Return ``h0`` ``(c, n)`` and ``A_var`` ``(c, n, k)`` of the candidates of block ``i``.

        Those made by :meth:`_reference_design` are handed over once.
        """
        if i in self._made:
            return self._made.pop(i)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            lin = self.problem.obs.linearisation(self.candidates[self.blocks[i]],
                                                 derivatives=False)
        return lin.h0, lin.a_var

    def _reference_design(self) -> NDArray[np.float64]:
        """Return ``A_var`` ``(n, k)`` of the first candidate with finite predictions.

        It is the design the shared basis is made from (zero if none).
        """
        for i in range(len(self.blocks)):
            h0, a_var = self._made[i] = self._predict(i)
            good = np.flatnonzero(~_bad(h0, a_var))
            if good.size:
                return a_var[good[0]].copy()
        return np.zeros((len(self.problem.obs.meas), self.problem.k))

    def _reference(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return a nuisance value near the data's, about which residuals do not cancel.

        Least squares on the geometry-free design of the median data set.
        """
        # (the median of one data set is that data set)
        return self.problem.reference_nuisance(y[0] if y.shape[0] == 1
                                               else np.median(y, axis=0))[0]

    def score(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the reduced costs of every candidate for each data set.

        Parameters
        ----------
        y : ndarray, shape (B, n) or (n,)
            Data sets in grouped row order (SI).

        Returns
        -------
        ndarray, shape (B, C)
            Half the weighted sum of squares (dimensionless); inf without predictions.
        """
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
        """Return costs ``(B, c)`` of the candidates of block ``i``.

        ``data`` holds the whitened data (and half its squared norm), unprojected (False) and
        projected on :attr:`shared` (True).
        """
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
"""Candidates times rows predicted and scored at a time.  Small blocks keep every temporary
array small (below ~0.5 MB): memory the allocator reuses instead of fresh pages from the
system, whose first touch (a page fault each) cost more than the arithmetic: with twice this
the allocator returned ~1.5 MB to the system after every gu2007 solve and faulted it back in
the next (~300 page faults, ~1 ms)."""


def _block_size(n_rows: int) -> int:
    """Return candidates per block for ``n_rows`` rows.

    About :data:`CANDIDATE_ROWS` / ``n_rows`` but at least 128 (each block costs some fixed
    work), kept off multiples of 512.  The candidates are the innermost axis, so the rows of
    a block's arrays would otherwise be a multiple of 4 KiB apart and share cache sets: a
    (48 x 4) @ (4 x 1024) product took three times as long as a (48 x 4) @ (4 x 1016) one.
    """
    step = max(128, CANDIDATE_ROWS // max(1, n_rows))
    if step >= 512 and abs(step - 512 * round(step / 512)) <= 8:
        step -= 16
    return step


def _bad(h0: NDArray[np.float64], a_var: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Flag the candidates ``(c,)`` without finite predictions or design."""
    return np.asarray(~(np.isfinite(h0).all(axis=1) & np.isfinite(a_var).all(axis=(1, 2))))


def _same_design(a_var: NDArray[np.float64], ref: NDArray[np.float64],
                 tolerance: NDArray[np.float64]) -> bool:
    """Tell whether every candidate's design ``A_const + a_var`` is ``A_const + ref``.

    To ``tolerance`` per column (:data:`GEOMETRY_FREE` of the column's size).
    """
    # reductions over the leading axis first: elementwise and fast
    spread = np.maximum(a_var.max(axis=0) - ref, ref - a_var.min(axis=0)).max(axis=0)
    return bool(np.all(spread <= tolerance))


def orthonormal_columns(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return an orthonormal basis of the columns of each matrix (modified Gram-Schmidt).

    Parameters
    ----------
    a : ndarray, shape (C, n, k)
        The matrices (any unit).

    Returns
    -------
    ndarray, shape (C, n, k)
        Orthonormal columns (dimensionless); a column that depends on the previous ones, or
        is zero, is zero.
    """
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
    """Return the best few distinct grid candidates for one data set, best first.

    Parameters
    ----------
    problem : VarProProblem
        The observation and noise model.
    y : ndarray, shape (n,)
        The data in grouped row order (SI).
    settings : GridSettings, optional
        The grid (default :class:`GridSettings()`).

    Returns
    -------
    ndarray, shape (s, p)
        Up to ``settings.starts`` motion parameter vectors (SI).
    """
    g = settings or GridSettings()
    return best_starts_many(problem, np.asarray(y, dtype=float)[None, :], g)[0].first(g.starts)


def _data_dependent(problem: VarProProblem) -> bool:
    """Tell whether the candidate set depends on the data (rays along measured bearings)."""
    return "bearing" in problem.obs.models  # (the kinds present)


def best_starts_many(problem: VarProProblem, ys: NDArray[np.float64],
                     settings: GridSettings | None = None) -> list[Starts]:
    """Rank the grid's candidates for several data sets sharing times, sensors and noise.

    When the candidates do not depend on the data they are predicted once for all.

    Parameters
    ----------
    problem : VarProProblem
        The observation and noise model.
    ys : ndarray, shape (B, n)
        The data sets in grouped row order (SI), e.g. Monte Carlo runs.
    settings : GridSettings, optional
        The grid (default :class:`GridSettings()`).

    Returns
    -------
    list of Starts
        One per data set: ``starts[b].first(m)``.
    """
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


class _Stage:
    """The rows one stage of the grid scores on, and the data sets on them.

    All-angle problems of one planar kind under an affine motion model (bearings, constant
    velocity or at rest) are scored by :class:`~tmakit.batch.chord.ChordScorer` on the rows
    of the problem itself; the others by :class:`GridScorer` on the problem restricted to the rows
    (:func:`_subsample`).

    Parameters
    ----------
    problem : VarProProblem
        The whole problem.
    rows : ndarray of int or None
        The stage's rows (set order), None for all.
    ys : ndarray, shape (B, n)
        The data sets (SI, set order).
    """

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
    """Return grid costs ``(B, C')`` of candidates ``(C, p)`` in two stages.

    Every candidate on a few rows (``coarse``), then the ``refine`` best of each data set
    (their union) on more rows (``small``).  ``run`` scores that data set only.
    """
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
    """Return the no-guess starting point of tmakit: the best point of the likelihood grid.

    The starting point the papers' local methods get when none is given (the same grid the
    maximum likelihood starts from).

    Parameters
    ----------
    meas : MeasurementSet
        The rows to score the grid on.
    motion : MotionModel
        The motion model of the point.
    options : Mapping, optional
        The nuisance model per kind (default: each kind's default model).

    Returns
    -------
    ndarray, shape (p,)
        The motion parameters of the best grid point (SI).

    Raises
    ------
    ValueError
        When no grid point gives finite predictions.
    """
    obs = ObservationModel(meas, motion, options)
    problem = VarProProblem(obs, NoiseModel(obs.grouped, obs.models))
    starts = best_starts(problem, obs.values)
    if starts.shape[0] == 0:
        raise ValueError("no starting point gives finite predictions; check the data")
    return starts[0]
