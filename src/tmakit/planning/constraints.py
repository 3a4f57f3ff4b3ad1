"""Tactical constraints on a planned sensor path, checked per candidate at the times of a step.

A constraint is **hard** (a violating candidate is infeasible; if every candidate violates, the
planner takes the one that violates least and says so) or a **penalty** (Hurtado & Nehorai
(2008), section 5, example 2).  Range constraints are held to the *estimated* target.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array

#: Default penalty weight (dimensionless).
DEFAULT_PENALTY = 10.0


@dataclass(frozen=True)
class Violation:
    """How far each candidate goes past one constraint.

    Attributes
    ----------
    name : str
        The constraint's label.
    amount : ndarray, shape (C,)
        Largest violation over the checked times (m; 0 where the constraint holds).
    hard : bool
        Whether a violation makes the candidate infeasible.
    scale : float
        The constraint's length (m) used by the penalty.
    weight : float
        Penalty weight (dimensionless; unused when hard).
    """

    name: str
    amount: Array
    hard: bool
    scale: float
    weight: float

    @property
    def violated(self) -> NDArray[np.bool_]:
        """Boolean (C,): where the constraint is broken (by more than 1 mm)."""
        return self.amount > 1e-3

    def penalty_factor(self) -> Array:
        """Return the cost factor ``1 + weight * amount / scale`` (1 for hard).

        Returns
        -------
        ndarray, shape (C,)
            Dimensionless, >= 1.
        """
        if self.hard:
            return np.ones_like(self.amount)
        return 1.0 + self.weight * self.amount / self.scale


def _positions(sensor_positions: ArrayLike) -> Array:
    pos = np.asarray(sensor_positions, dtype=float)
    if pos.ndim == 2:
        pos = pos[:, None, :]
    if pos.ndim != 3 or pos.shape[-1] not in (2, 3):
        raise ValueError(f"sensor positions must be (C, k, 3) ENU metres; got {pos.shape}")
    return pos


def _horizontal_range(sensor_positions: ArrayLike, target_positions: ArrayLike) -> Array:
    pos = _positions(sensor_positions)
    tgt = np.asarray(target_positions, dtype=float)
    tgt = np.broadcast_to(tgt[..., :2], (pos.shape[1], 2)) if tgt.ndim > 1 else tgt[:2]
    d = pos[..., :2] - tgt
    return np.hypot(d[..., 0], d[..., 1])


def _check_limit(name: str, value: float, weight: float) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive distance in metres; got {value}")
    if not (np.isfinite(weight) and weight >= 0):
        raise ValueError(f"the penalty weight of {name} must be >= 0; got {weight}")


@dataclass(frozen=True)
class _RangeLimit:
    """A limit on the horizontal range (m) to the estimated target."""

    distance: float
    hard: bool = True
    weight: float = DEFAULT_PENALTY
    name: str = field(default="range limit", init=False)
    #: +1 for a minimum range (broken below it), -1 for a maximum range.
    _sign: ClassVar[float] = 1.0

    def __post_init__(self) -> None:
        """Check the distance and weight."""
        _check_limit(f"the {self.name}", self.distance, self.weight)

    def check(self, sensor_positions: ArrayLike, target_positions: ArrayLike) -> Violation:
        """Return how far (m) each candidate's range goes past the limit.

        Parameters
        ----------
        sensor_positions : array_like, shape (C, k, 3) or (C, 3)
            Candidate sensor positions at the checked times, ENU m.
        target_positions : array_like, shape (k, 3) or (3,)
            The estimated target position at those times, ENU m.
        """
        r = _horizontal_range(sensor_positions, target_positions)
        amount = np.clip(self._sign * (self.distance - r), 0.0, None).max(axis=-1)
        return Violation(self.name, amount, self.hard, self.distance, self.weight)


@dataclass(frozen=True)
class MinimumRange(_RangeLimit):
    """Stay at least ``distance`` (m, horizontal) from the estimated target.

    Parameters
    ----------
    distance : float
        Minimum range, m (> 0).
    hard : bool, optional
        Infeasible when broken (default) or penalised.
    weight : float, optional
        Penalty weight (dimensionless), when not hard.

    References
    ----------
    Hurtado & Nehorai (2008), section 5, example 2 (5 km, as a penalty).
    """

    name: str = field(default="minimum range", init=False)


@dataclass(frozen=True)
class MaximumRange(_RangeLimit):
    """Stay within ``distance`` (m, horizontal) of the estimated target (detection range).

    Parameters as for :class:`MinimumRange`.
    """

    name: str = field(default="maximum range", init=False)
    _sign: ClassVar[float] = -1.0


def _polygon(shape: object, what: str) -> object:
    import shapely

    if isinstance(shape, shapely.Geometry):
        geom = shape
    else:
        pts = np.asarray(shape, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise ValueError(f"{what} must be a shapely polygon or at least three (east, "
                             f"north) vertices in metres; got shape {pts.shape}")
        geom = shapely.Polygon(pts)
    if geom.geom_type not in ("Polygon", "MultiPolygon") or geom.is_empty:
        raise ValueError(f"{what} must be a non-empty polygon; got {geom.geom_type}")
    if not geom.is_valid:
        raise ValueError(f"{what} is not a valid polygon ({shapely.is_valid_reason(geom)})")
    return geom


def _scale(geom: object) -> float:
    import shapely

    return float(max(np.sqrt(shapely.area(geom)), 1.0))


class _Region:
    """A fixed region of the plane: kept out of (``_keep_out``) or kept in."""

    name: str
    hard: bool
    weight: float
    _keep_out: ClassVar[bool] = True

    def check(self, sensor_positions: ArrayLike, target_positions: ArrayLike | None = None
              ) -> Violation:
        """Return how far (m) each candidate goes to the wrong side of the boundary.

        ``sensor_positions`` as for :meth:`MinimumRange.check`; ``target_positions`` unused.
        """
        import shapely

        pos = _positions(sensor_positions)
        geom = self._geometry  # type: ignore[attr-defined]
        inside = shapely.contains_xy(geom, pos[..., 0], pos[..., 1])
        wrong = inside if self._keep_out else ~inside  # on the boundary: inside
        dist = np.zeros(pos.shape[:-1])
        if wrong.any():
            pts = shapely.points(pos[wrong][:, 0], pos[wrong][:, 1])
            dist[wrong] = shapely.distance(geom.boundary if self._keep_out else geom, pts)
        return Violation(self.name, dist.max(axis=-1), self.hard, _scale(geom), self.weight)


@dataclass(frozen=True)
class KeepOutZones(_Region):
    """Never enter any of the given polygons (e.g. a no-fly zone, shallow water, a coast).

    Parameters
    ----------
    zones : sequence of polygons
        shapely polygons or (k, 2) vertex arrays, local (east, north) m.
    hard, weight
        As for :class:`MinimumRange`; the penalty scale is the square root of the zones' area.

    Notes
    -----
    The violation is the depth inside a zone (the distance to its boundary, m).
    """

    zones: Sequence[object]
    hard: bool = True
    weight: float = DEFAULT_PENALTY
    name: str = field(default="keep-out zone", init=False)

    def __post_init__(self) -> None:
        """Turn the zones into one shapely geometry."""
        import shapely

        if len(self.zones) == 0:
            raise ValueError("keep-out zones: give at least one polygon")
        polys = [_polygon(z, f"keep-out zone {i}") for i, z in enumerate(self.zones)]
        object.__setattr__(self, "_geometry", shapely.union_all(polys))


@dataclass(frozen=True)
class OperatingArea(_Region):
    """Stay inside one polygon (the area the platform may use).

    Parameters
    ----------
    area : polygon
        A shapely polygon or (k, 2) vertex array, local (east, north) m.
    hard, weight
        As for :class:`MinimumRange`; the penalty scale is the square root of the area.

    Notes
    -----
    The violation is the distance outside the area (m).
    """

    area: object
    hard: bool = True
    weight: float = DEFAULT_PENALTY
    name: str = field(default="operating area", init=False)
    _keep_out: ClassVar[bool] = False

    def __post_init__(self) -> None:
        """Turn the area into a shapely geometry."""
        object.__setattr__(self, "_geometry", _polygon(self.area, "the operating area"))


Constraint = MinimumRange | MaximumRange | KeepOutZones | OperatingArea
