"""The grid of candidate trajectories that the automatic initialisation scores.

Positions are placed at the median measurement time: along the measured bearings when there
are bearings (rays from each bearing sensor), otherwise on a polar grid around the sensors, at
geometrically spaced ranges; velocities on a grid of speeds and courses.  3-D models add a few
elevation angles above the sensors' plane.  :mod:`tmakit.batch.init` scores them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from .solver import VarProProblem

__all__ = ["GridSettings", "grid_candidates", "grid_candidates_for"]

@dataclass(frozen=True)
class GridSettings:
    """Extent and density of the initial search (SI units).

    Every grid point is scored on ``coarse_rows`` evenly spread rows, the ``refine`` best on
    ``max_rows``; ``starts`` distinct points start the solve.

    Parameters
    ----------
    min_range, max_range : float
        Extent of the geometrically spaced ranges (m).
    n_ranges : int
        Ranges per ray.
    n_bearings : int
        Bearings of the fan around the sensors when no bearing is measured.
    speeds : tuple of float
        Speeds of the velocity grid (m/s); 0 is the target at rest.
    n_courses : int
        Courses per positive speed.
    elevations_deg : tuple of float
        Elevations above the sensors' plane for 3-D models (degrees).
    max_rows, coarse_rows : int
        Rows the ``refine`` best points and every point are scored on.
    starts : int
        Distinct points that start the solve.
    refine : int
        Points of the coarse stage scored again on ``max_rows``.
    """

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
    """Return candidate positions ``(m, 3)``: rays x elevations x ranges, in that order.

    The rays go from each bearing sensor along its bearing nearest ``t_mid``, or fan out
    around the sensors.  Of the rows ``rows`` of the set (None: all), whose values are
    ``values`` (None: the set's).
    """
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
    """Return ``np.median(x)`` of a 1-D array, the same bits, without its overhead for few rows.

    The middle element of the sorted rows, or the mean ``(a + b) / 2`` of the middle two (as
    :func:`numpy.median` forms it).
    """
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
    """Return candidate velocities ``(m, 3)`` (m/s): at rest, then each speed and course.

    Read-only, made once per settings.
    """
    moves = np.array([v for v in speeds if v > 0], dtype=np.float64)
    courses = np.linspace(0.0, 2 * np.pi, n_courses, endpoint=False)
    moving = np.stack(np.broadcast_arrays(moves[:, None] * np.sin(courses),
                                          moves[:, None] * np.cos(courses), 0.0), axis=-1)
    vel = np.concatenate([np.zeros((1, 3)), moving.reshape(-1, 3)])
    vel.flags.writeable = False
    return vel


def grid_candidates(problem: VarProProblem, settings: GridSettings | None = None
                    ) -> NDArray[np.float64]:
    """Return the candidate parameter vectors for the problem's motion model.

    Parameters
    ----------
    problem : VarProProblem
        The problem (its measurements place the grid; its motion model converts it).
    settings : GridSettings, optional
        Extent and density (default :class:`GridSettings()`).

    Returns
    -------
    ndarray, shape (m, p)
        Motion parameters (SI) of the grid's states at the median measurement time.
    """
    return grid_candidates_for(problem.obs.meas, problem.obs.motion, settings)


def grid_candidates_for(meas: MeasurementSet, motion: MotionModel,
                        settings: GridSettings | None = None,
                        rows: NDArray[np.intp] | None = None,
                        values: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Return :func:`grid_candidates` from the measurements and motion model themselves.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements that place the grid (times, sensors, measured bearings).
    motion : MotionModel
        The motion model that converts it.
    settings : GridSettings, optional
        Extent and density (default :class:`GridSettings()`).
    rows : ndarray of int, optional
        The rows of ``meas`` that place it (its row order; default all): the grid of
        ``meas.take(rows)``.
    values : ndarray, optional
        The values of those rows (SI; default the set's), e.g. another data set's bearings.

    Returns
    -------
    ndarray, shape (m, p)
        Motion parameters (SI) of the grid's states at the median measurement time.
    """
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
