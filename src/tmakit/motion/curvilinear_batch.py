"""Piecewise curvilinear trajectories for many parameter vectors at once, with derivatives.

The motion of :class:`tmakit.motion.PiecewiseCurvilinear` (Hörst & Oispuu (2010), eqs. 1-4)
vectorised over a leading batch axis for the manoeuvre estimator, with a reference time before
every change-over time (other vectors give NaN states).  The loops are compiled in
:mod:`tmakit.motion.curvilinear_compiled`.

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from .base import MotionModel

NormalMaker = Callable[[NDArray[np.int64] | None], tuple[Array, Array]]
"""``make(runs)``: ``J'J`` and ``J'r`` of some runs of a batch (None: all)."""


class ForwardPiecewise(MotionModel):
    """Piecewise curvilinear motion, change-over times after the reference time, in batches.

    Like :class:`~tmakit.motion.PiecewiseCurvilinear` with analytic derivatives; vectors with
    ``t_1 <= ref_time``, times out of order or at or after ``end_time`` give NaN states.  The last
    derivatives are cached: do not share an instance between threads.

    Parameters
    ----------
    manoeuvres : int
        ``M`` >= 0.
    ref_time : float
        s, before every change-over time.
    end_time : float
        s; default none.

    Raises
    ------
    ValueError
        For a negative number of manoeuvres.

    References
    ----------
    Hörst & Oispuu (2010), eqs. 1-4.
    """

    dim = 2

    def __init__(self, manoeuvres: int, ref_time: float, end_time: float = np.inf) -> None:
        if manoeuvres < 0:
            raise ValueError("the number of manoeuvres must be >= 0")
        self.manoeuvres = int(manoeuvres)
        self.ref_time = float(ref_time)
        self.end_time = float(end_time)
        accel: list[str] = []
        for m in range(self.manoeuvres + 1):
            accel += [f"at_{m}", f"an_{m}"]
        times = [f"t_{m}" for m in range(1, self.manoeuvres + 1)]
        self.param_names = ("x", "y", "speed", "course", *accel, *times)
        self.name = f"curvilinear:{self.manoeuvres}"
        self._times = np.zeros(0)  # the unique times of the last states() call
        self._cache: tuple | None = None
        self._rows: tuple[Array, NDArray[np.int64] | None] = (np.zeros(0), None)
        self._columns: NDArray[np.int64] | None = None  # chain()'s columns (None: all)

    @contextmanager
    def derivatives_for(self, free: NDArray[np.bool_] | None) -> Iterator[None]:
        """Make :meth:`chain` give, within the block, the derivatives for ``free`` only."""
        before = self._columns
        self._columns = (None if free is None or np.all(free)
                         else np.flatnonzero(np.asarray(free, dtype=bool)))
        try:
            yield
        finally:
            self._columns = before

    def _segments(self, theta: Array, t: Array, partials: bool
                  ) -> tuple[NDArray[np.int64], Array, Array | None, Array | None]:
        """Propagate every sample from the start of its segment (:func:`.piecewise`)."""
        return _compiled().piecewise(theta, t, self.manoeuvres, self.ref_time, self.end_time,
                                     partials)

    def _flat(self, theta: ArrayLike) -> tuple[Array, tuple[int, ...]]:
        theta = self.check_theta(theta)
        return theta.reshape(-1, self.n_params), theta.shape[:-1]

    # -- the MotionModel interface -----------------------------------------------------------
    def states(self, theta: ArrayLike, t: ArrayLike) -> Array:
        """Give ENU states ``(..., n, 6)`` (m, m/s) at times ``t`` (s)."""
        return self._rows_states(theta, t, None)

    def states_minus(self, theta: ArrayLike, t: ArrayLike, sensor: Array) -> Array:
        """Give :meth:`states` minus the sensor's states ``(n, 6)``, in one pass."""
        sensor = np.asarray(sensor, dtype=float)
        t = np.asarray(t, dtype=float)
        if sensor.shape != (t.shape[0], 6):
            return self.states(theta, t) - sensor
        return self._rows_states(theta, t, sensor)

    def _rows_states(self, theta: ArrayLike, t: ArrayLike, sensor: Array | None) -> Array:
        """Give the states at every time of ``t`` (minus ``sensor``'s if given)."""
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        last_t, last_inv = self._rows
        if last_inv is not None and t.shape == last_t.shape and np.array_equal(t, last_t):
            tu, inv = self._times, last_inv  # the rows of the last call (the usual case)
        else:
            tu, inv = np.unique(t, return_inverse=True)  # kinds measured at the same times
            inv = inv.reshape(-1)
            self._rows = (t.copy(), inv)
        self._times = tu
        seg_u, val, par_u, d_anchor = self._segments(flat, tu, partials=True)
        self._cache = ((flat.tobytes(), flat.shape), tu, seg_u, par_u, d_anchor)
        out = _compiled().scatter_states(val, inv, sensor)
        return out.reshape(*lead, t.shape[0], 6)

    def _theta_partials(self, flat: Array, t: Array
                        ) -> tuple[Array, Array, Array, NDArray[np.int64] | None]:
        """Give the per-segment partials at the unique times ``tu`` of ``t``, cached."""
        key = (flat.tobytes(), flat.shape)
        cache = self._cache
        last_t, last_idx = self._rows
        same_rows = t.shape == last_t.shape and np.array_equal(t, last_t)
        if cache is not None and cache[0] == key and same_rows:
            return cache[2], cache[3], cache[4], last_idx
        if cache is None or cache[0] != key or not np.all(np.isin(t, cache[1])):
            tu = np.unique(t)
            if self._times.size and np.all(np.isin(t, self._times)):
                tu = self._times
            seg_u, _, par_u, d_anchor = self._segments(flat, tu, partials=True)
            assert par_u is not None and d_anchor is not None
            self._cache = cache = (key, tu, seg_u, par_u, d_anchor)
        tu, seg_u, par_u, d_anchor = cache[1:]
        idx = None
        if t.shape != tu.shape or not np.array_equal(t, tu):
            idx = np.searchsorted(tu, t)
        return seg_u, par_u, d_anchor, idx

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> Array:
        """Give the analytic ``d state / d theta`` ``(..., n, 6, p)`` at times ``t`` (s)."""
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        jac = np.zeros((flat.shape[0], t.shape[0], 6, self.n_params))
        for c in (0, 1, 3, 4):
            d = np.zeros((flat.shape[0], t.shape[0], 6))
            d[..., c] = 1.0
            jac[:, :, c] = self._chain_flat(d, flat, t)
        return jac.reshape(*lead, t.shape[0], 6, self.n_params)

    def _chain_flat(self, ds: Array, flat: Array, t: Array,
                    cols: NDArray[np.int64] | None = None) -> Array:
        """Give ``d value / d theta`` ``(B, n, p)`` from ``d value / d state`` ``(B, n, 6)``."""
        seg_u, par_u, d_anchor, idx = self._theta_partials(flat, t)
        return _compiled().chain(ds, par_u, seg_u, idx, d_anchor, self.manoeuvres, cols)

    def chain(self, d_state: Array, theta: ArrayLike, t: ArrayLike) -> Array:
        """Apply the chain rule, contracting the state axis before the parameter axis."""
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        cols = self._columns
        if d_state.ndim != len(lead) + 2:
            out = super().chain(d_state, theta, t)
            return out if cols is None else out[..., cols]
        out = self._chain_flat(d_state.reshape(flat.shape[0], t.shape[0], 6), flat, t, cols)
        return out.reshape(*lead, t.shape[0], out.shape[-1])

    def normal_equations(self, d_state: Array, residual: Array, weights: Array,
                         theta: ArrayLike, t: ArrayLike) -> tuple[Array, Array]:
        """Give ``J'J`` and ``J'r`` of the whitened Jacobian without forming it."""
        return self.normal_equations_later(d_state, residual, weights, theta, t)(None)

    def normal_equations_later(self, d_state: Array, residual: Array, weights: Array,
                               theta: ArrayLike, t: ArrayLike) -> NormalMaker:
        """Hold what :meth:`normal_equations` needs; sum it later, for the runs asked."""
        flat, _ = self._flat(theta)
        t = np.asarray(t, dtype=float)
        seg_u, par_u, d_anchor, idx = self._theta_partials(flat, t)
        m = self.manoeuvres

        def make(runs: NDArray[np.int64] | None) -> tuple[Array, Array]:
            return _compiled().segment_normal(d_state, residual, weights, par_u, seg_u, idx,
                                              d_anchor, m, runs)
        return make

    def segment_states(self, theta: ArrayLike, t: ArrayLike) -> Array:
        """Give ``(x, y, speed, course)`` at times ``t``, the course unwrapped."""
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        _, val, _, _ = self._segments(flat, t, partials=False)
        return val[..., :4].reshape(*lead, t.shape[0], 4)

    def __repr__(self) -> str:
        """Name the class, the number of manoeuvres and the reference time."""
        return f"ForwardPiecewise(manoeuvres={self.manoeuvres}, ref_time={self.ref_time})"



def _compiled() -> ModuleType:
    """Give the compiled kernels (``numba`` is imported at the first call: 0.1 s a process)."""
    from . import curvilinear_compiled
    return curvilinear_compiled
