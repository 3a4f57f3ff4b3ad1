"""Observability: the rank of the normalised Fisher information and what the data cannot see.

Unobservable directions are named by testing candidate motions that leave the measurements
unchanged (rotations about sensors, translations, scalings about a sensor).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.linalg import eigh, normalise
from ..data import MeasurementSet
from ..measurements import KINDS
from ..motion import MotionModel
from .own_legs import one_leg, range_words

RANK_TOL = 1e-10
"""Eigenvalues of the normalised information below this fraction of the largest are zero."""

_TINY = float(np.finfo(float).tiny)

#: The eigen-decomposition of a normalised information: eigenvalues ascending, their unit
#: eigenvectors, and the normalisation ``D`` (the information is ``D^-1 V diag(w) V' D^-1``).
Decomposition = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


def full_rank(info: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Tell whether each of a batch of information matrices has full rank (as :func:`analyse`)."""
    d = np.diagonal(info, axis1=-2, axis2=-1)
    scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    evals = np.linalg.eigh(info * scale[:, :, None] * scale[:, None, :])[0]
    top = np.maximum(evals[:, -1], np.finfo(float).tiny)
    return cast(NDArray[np.bool_], ~(evals <= RANK_TOL * top[:, None]).any(axis=1))


_AXES = {"East": np.array([1.0, 0, 0]), "North": np.array([0, 1.0, 0]),
         "Up": np.array([0, 0, 1.0])}


@dataclass
class Direction:
    """One unobservable direction: a sentence and a parameter change the data cannot see.

    Parameters
    ----------
    sentence : str
    weights : dict of str to float
        The change in each parameter's unit, largest magnitude 1.
    """

    sentence: str
    weights: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """Return ``{"sentence": ..., "weights": ...}``.

        Returns
        -------
        dict of str to object
        """
        return {"sentence": self.sentence, "weights": self.weights}


@dataclass
class Observability:
    """What an information matrix can see.

    Parameters
    ----------
    rank, size : int
        Rank and number of unknowns.
    condition : float
        Of the normalised information.
    null_basis : ndarray, shape (size, size - rank)
        Unit basis of the null space, physical units.
    observable : ndarray of bool, shape (size,)
    decomposition : tuple of ndarray, optional
        Eigenvalues (ascending), eigenvectors and normalisation ``D`` the rank came from.
    describe : callable, optional
        Gives :attr:`directions` (called on first use; None: no unobservable direction).
    """

    rank: int
    size: int
    condition: float
    null_basis: NDArray[np.float64]
    observable: NDArray[np.bool_]
    decomposition: Decomposition | None = field(default=None, repr=False, compare=False)
    describe: Callable[[], list[Direction]] | None = field(default=None, repr=False,
                                                           compare=False)

    @cached_property
    def directions(self) -> list[Direction]:
        """The unobservable directions, named (made on first use: many fits need the rank only)."""
        return [] if self.describe is None else self.describe()

    @property
    def full_rank(self) -> bool:
        """Whether every unknown is observable (rank equals size)."""
        return self.rank == self.size


def _fixed_sensors(meas: MeasurementSet) -> dict[str, NDArray[np.float64]]:
    out = {}
    for s in meas.sensors:
        st = meas.sensor_state[meas.sensor_mask(s)]
        if np.allclose(st, st[0], rtol=0, atol=1e-9) and np.allclose(st[0, 3:], 0.0):
            out[s] = st[0, :3]
    return out


def _candidates(meas: MeasurementSet, motion: MotionModel, theta: NDArray[np.float64]
                ) -> list[tuple[str, NDArray[np.float64] | None]]:
    """(sentence, parameter change or None) for each candidate motion of the track."""
    t = np.unique(np.concatenate([meas.time, meas.time_ref[np.isfinite(meas.time_ref)]]))
    states = motion.states(theta, t)
    p, v = states[:, :3], states[:, 3:]
    cands: list[tuple[str, NDArray[np.float64], NDArray[np.float64]]] = []
    fixed = _fixed_sensors(meas)

    def rotation(axis: NDArray[np.float64], centre: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
        return np.column_stack([np.cross(axis, p - centre), np.cross(axis, v)])

    for name, c in fixed.items():
        for axis_name, axis in _AXES.items():
            cands.append((f"rotation of the whole track about the {axis_name} axis through "
                          f"sensor {name}", rotation(axis, c), t))
    names = list(fixed)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            base = fixed[b] - fixed[a]
            if np.linalg.norm(base) > 0:
                cands.append((f"rotation of the whole track about the line through sensors "
                              f"{a} and {b}", rotation(base / np.linalg.norm(base), fixed[a]),
                              t))
    for axis_name, axis in _AXES.items():
        cands.append((f"translation of the whole track along {axis_name}",
                       np.column_stack([np.broadcast_to(axis, p.shape), np.zeros(p.shape)]),
                       t))
    angles = _angles_only(meas)
    for name in meas.sensors:
        path = fixed.get(name)
        own = (np.column_stack([np.broadcast_to(path, p.shape), np.zeros(p.shape)])
               if path is not None else _straight_path(meas, name, t))
        if own is not None:
            cands.append((range_words(meas, name) if angles else
                          f"scaling of the track about sensor {name} (range is not observable)",
                          states - own, t))
            if not angles:  # Doppler on one leg: the relative track's shape, not its heading
                up = _AXES["Up"]
                cands.append((f"rotation of the track seen from sensor {name} about it: on its "
                              "one straight leg the frequencies give the contact's speed "
                              "relative to it and its closest approach, not the direction; an "
                              "own-ship turn, or bearings, would pin it down",
                              np.column_stack([np.cross(up, p - own[:, :3]),
                                               np.cross(up, v - own[:, 3:])]), t))
    return [(s, _to_theta(motion, theta, tt, d)) for s, d, tt in cands]


def _angles_only(meas: MeasurementSet) -> bool:
    return all(KINDS[k].scale_free for k in meas.kinds)


def _straight_path(meas: MeasurementSet, sensor: str, t: NDArray[np.float64]
                   ) -> NDArray[np.float64] | None:
    """Give the sensor's states at ``t`` when its rows lie on one straight leg, else None."""
    rows = meas.sensor_mask(sensor)
    st = meas.sensor_state[rows]
    if not one_leg(st):
        return None
    tr = meas.time[rows]
    design = np.column_stack([np.ones_like(tr), tr - tr[0]])
    coef = np.linalg.lstsq(design, st[:, :3], rcond=None)[0]  # position = a + b (t - t0)
    pos = np.column_stack([np.ones_like(t), t - tr[0]]) @ coef
    return np.column_stack([pos, np.broadcast_to(coef[1], pos.shape)])


def _velocity_fixed(motion: MotionModel, theta: NDArray[np.float64],
                    t: NDArray[np.float64]) -> bool:
    """Tell whether the velocity's derivatives by ``theta`` are the same at every time ``t``."""
    first = motion.jacobian(theta, t[:1])[0, 3:6]
    for lo in range(0, len(t), _TIME_BLOCK):
        velocity = motion.jacobian(theta, t[lo:lo + _TIME_BLOCK])[:, 3:6]
        if not np.allclose(velocity, first, rtol=1e-9, atol=1e-12):
            return False
    return True


_TIME_BLOCK = 65_536


def _to_theta(motion: MotionModel, theta: NDArray[np.float64], t: NDArray[np.float64],
              dstate: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Return the parameter change that moves the states by ``dstate``, or None."""
    jac = motion.jacobian(theta, t).reshape(-1, motion.n_params)
    target = dstate.reshape(-1)
    if not np.any(target):
        return None
    sol, *_ = np.linalg.lstsq(jac, target, rcond=None)
    if np.linalg.norm(jac @ sol - target) > 1e-6 * np.linalg.norm(target):
        return None
    return cast(NDArray[np.float64], sol)


def _weights(names: tuple[str, ...], vec: NDArray[np.float64]) -> dict[str, float]:
    big = np.max(np.abs(vec))
    w = vec / big if big > 0 else vec
    return {n: round(float(x), 6) for n, x in zip(names, w, strict=True) if abs(x) > 1e-9}


def analyse(info: NDArray[np.float64], names: tuple[str, ...], meas: MeasurementSet,
            motion: MotionModel, theta: NDArray[np.float64],
            decomposition: Decomposition | None = None) -> Observability:
    """Find the rank, conditioning and named unobservable directions of an information (SI)."""
    size = info.shape[0]
    unseen = _range_by_shape(meas, motion, theta, info, size)
    if decomposition is not None and unseen is None:
        evals, evecs, scale = decomposition
        norm = None  # made if needed (a rank deficiency to describe)
    else:
        norm, scale = normalise(info)
        if unseen is not None:
            norm = norm - np.outer(norm @ unseen, unseen) - np.outer(unseen, unseen @ norm) + (
                float(unseen @ norm @ unseen) * np.outer(unseen, unseen))
        evals, evecs = eigh(norm)
    low, high = float(evals[0]), float(evals[-1])
    top = max(high, _TINY)
    if low > RANK_TOL * top:  # full rank (eigenvalues ascending), said in floats
        return Observability(size, size, top / low, np.zeros((size, 0)),
                             np.array([True] * size), (evals, evecs, scale))
    null = evals <= RANK_TOL * top
    rank = int(size - null.sum())
    positive = evals[~null]
    condition = float(top / positive.min()) if positive.size else np.inf
    null_norm = evecs[:, null]  # normalised coordinates
    null_phys = null_norm * scale[:, None]
    if null_phys.size:
        null_phys = null_phys / np.linalg.norm(null_phys, axis=0, keepdims=True)
    observable = np.ones(size, dtype=bool)
    if null_norm.size:
        observable = np.linalg.norm(null_norm, axis=1) < 1e-6
    describe = None
    if rank < size:
        norm = normalise(info)[0] if norm is None else norm
        describe = partial(_describe, null_norm, scale, names, norm, top, meas, motion,
                           np.array(theta, dtype=float), unseen)
    return Observability(rank, size, condition, null_phys, observable,
                         (evals, evecs, scale), describe)


def _range_by_shape(meas: MeasurementSet, motion: MotionModel, theta: NDArray[np.float64],
                    info: NDArray[np.float64], size: int) -> NDArray[np.float64] | None:
    """Give the range direction (normalised unit vector) only a manoeuvre model's shape sees."""
    # a stationary emitter (a moving sensor's bearings do give its range) or constant
    # velocity (the rank says whether range is seen): no manoeuvre to take it from
    if motion.velocity_fixed or len(meas.sensors) != 1 or not _angles_only(meas):
        return None
    theta = np.asarray(theta, float)
    if not np.all(np.isfinite(theta)):
        return None
    sensor = meas.sensors[0]
    if not one_leg(meas.sensor_state[meas.sensor_mask(sensor)]):
        return None
    t = np.unique(meas.time)
    own = _straight_path(meas, sensor, t)
    if own is None or _velocity_fixed(motion, theta, t):
        return None
    jac = motion.jacobian(theta, t)
    d = motion.states(theta, t) - own
    dtheta = np.linalg.lstsq(jac.reshape(-1, motion.n_params), d.reshape(-1), rcond=None)[0]
    full = np.zeros(size)
    full[:motion.n_params] = dtheta
    norm, scale = normalise(info)
    u = full / scale
    if not np.all(np.isfinite(u)) or not np.any(u):
        return None
    u /= np.linalg.norm(u)
    top = float(np.linalg.eigvalsh(norm)[-1])
    return u if float(u @ norm @ u) > 1e3 * RANK_TOL * top else None  # (else already unseen)


def _describe(null_norm: NDArray[np.float64], scale: NDArray[np.float64],
              names: tuple[str, ...], norm: NDArray[np.float64], top: float,
              meas: MeasurementSet, motion: MotionModel, theta: ArrayLike,
              unseen: NDArray[np.float64] | None = None) -> list[Direction]:
    nullity = null_norm.shape[1]
    p = motion.n_params
    chosen: list[NDArray[np.float64]] = []  # normalised coordinates, unit vectors
    directions: list[Direction] = []
    if unseen is not None:
        chosen.append(unseen)
        directions.append(Direction(range_words(meas, meas.sensors[0], manoeuvring_model=True),
                                    _weights(names, unseen * scale)))
    for sentence, dtheta in _candidates(meas, motion, np.asarray(theta, float)):
        if dtheta is None:
            continue
        full = np.zeros(len(names))
        full[:p] = dtheta
        u = full / scale
        u /= np.linalg.norm(u)
        if float(u @ norm @ u) > 1e3 * RANK_TOL * top:
            continue  # the data see this motion
        if chosen:
            basis = np.column_stack(chosen)
            resid = u - basis @ np.linalg.lstsq(basis, u, rcond=None)[0]
            if np.linalg.norm(resid) < 1e-6:
                continue  # already explained by the directions found so far
        chosen.append(u)
        directions.append(Direction(sentence, _weights(names, full)))
        if len(chosen) == nullity:
            return directions
    # Whatever the candidates do not explain is reported as a plain combination.
    rest = null_norm
    if chosen:
        basis = np.column_stack(chosen)
        rest = rest - basis @ np.linalg.lstsq(basis, rest, rcond=None)[0]
    u_ = np.linalg.svd(rest, full_matrices=False)[0]
    for k in range(nullity - len(chosen)):
        vec = u_[:, k] * scale
        w = _weights(names, vec)
        terms = " ".join(f"{'+' if x >= 0 else '-'} {abs(x):.3g}·{n}" for n, x in w.items())
        directions.append(Direction(
            f"the combination {terms.lstrip('+ ')} cannot be determined from the data", w))
    return directions
