"""Exact curvilinear motion (Hörst & Oispuu (2010), §2.1, eq. 1) and its pieces (eqs. 2-4).

State ``(x, y, v, phi)``: ENU position (m), speed (m/s), course (rad, clockwise from North);
``a_t`` changes the speed, ``a_n`` turns the course at ``a_n / v`` (positive: starboard).  The
closed form, its analytic derivatives and the chaining through the change-over times are
compiled (:mod:`tmakit.motion.curvilinear_compiled`, ``numba`` imported at the first call):
:class:`PiecewiseCurvilinear` for any reference time, :class:`ForwardPiecewise` for the
manoeuvre estimator's batches (reference time before every change-over time), with its chain
rule and normal equations.  Reference: Hörst & Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array, IntArray
from .base import MotionModel


def _param_names(manoeuvres: int) -> tuple[str, ...]:
    """Name ``x, y, speed, course, at_0, an_0, ..., at_M, an_M, t_1, ..., t_M``."""
    accel = [f"{a}_{m}" for m in range(manoeuvres + 1) for a in ("at", "an")]
    times = [f"t_{m}" for m in range(1, manoeuvres + 1)]
    return ("x", "y", "speed", "course", *accel, *times)


def propagate_curvilinear(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
                          a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike
                          ) -> tuple[NDArray[np.float64], ...]:
    """Propagate curvilinear states by ``dt`` seconds (any sign); all inputs broadcast.

    Parameters
    ----------
    x, y, speed, course, a_t, a_n, dt : array_like
        m, m, m/s, rad, m/s^2, m/s^2, s.

    Returns
    -------
    tuple of ndarray
        ``(x, y, speed, course, vx, vy)``; NaN where the speed would reach zero.

    References
    ----------
    Hörst & Oispuu (2010), eq. 1.
    """
    from .curvilinear_compiled import propagate_with_partials
    values, _ = propagate_with_partials(x, y, speed, course, a_t, a_n, dt, partials=False)
    return tuple(np.moveaxis(values, -1, 0))


def propagate_curvilinear_derivatives(x: ArrayLike, y: ArrayLike, speed: ArrayLike,
                                      course: ArrayLike, a_t: ArrayLike, a_n: ArrayLike,
                                      dt: ArrayLike
                                      ) -> tuple[tuple[NDArray[np.float64], ...],
                                                 NDArray[np.float64]]:
    """Propagate as :func:`propagate_curvilinear`, with analytic derivatives."""
    from .curvilinear_compiled import propagate_with_partials
    values, par = propagate_with_partials(x, y, speed, course, a_t, a_n, dt)
    assert par is not None
    return tuple(np.moveaxis(values, -1, 0)), par[..., :4, :]


class PiecewiseCurvilinear(MotionModel):
    """Piecewise curvilinear motion with ``M`` manoeuvres (Hörst & Oispuu (2010), eqs. 1-4).

    Parameters ``x, y, speed, course`` (m, m, m/s, rad) at ``ref_time``, the accelerations
    ``at_0, an_0, ..., at_M, an_M`` (m/s^2; ``at_m, an_m`` act from ``t_m`` on, §4) and the
    change-over times ``t_1 < ... < t_M`` (s).  A sample at a change-over time belongs to the
    earlier segment; times out of order or a speed reaching zero give NaN states.  Planar (z = 0);
    the Jacobian is analytic.

    Parameters
    ----------
    manoeuvres : int
        ``M`` >= 0.
    ref_time : float
        s.

    Raises
    ------
    ValueError
        For a negative number of manoeuvres.

    References
    ----------
    Hörst & Oispuu (2010), §2, eqs. 1-4; §4 for the indexing.
    """

    dim = 2

    def __init__(self, manoeuvres: int = 0, ref_time: float = 0.0) -> None:
        if manoeuvres < 0:
            raise ValueError("the number of manoeuvres must be >= 0")
        self.manoeuvres = int(manoeuvres)
        self.ref_time = float(ref_time)
        self.param_names = _param_names(self.manoeuvres)
        self.name = f"curvilinear:{self.manoeuvres}"

    def time_index(self, m: int) -> int:
        """Give the index of the change-over time ``t_m`` in ``theta``.

        Parameters
        ----------
        m : int
            1..M.

        Returns
        -------
        int
        """
        return 5 + 2 * self.manoeuvres + m

    def _evaluate(self, theta: Array, t: Array, derivatives: bool
                  ) -> tuple[Array, Array, Array | None]:
        """Evaluate ``theta`` ``(B, p)`` at times ``t`` (compiled), with derivatives if asked."""
        M, p = self.manoeuvres, self.n_params
        B, k0 = theta.shape[0], 6 + 2 * M
        cot = theta[:, k0:]
        with np.errstate(invalid="ignore"):
            ordered = (np.all(np.diff(cot, axis=1) > 0, axis=1) if M > 1
                       else np.all(np.isfinite(cot), axis=1))
            seg_ref = np.sum(cot < self.ref_time, axis=1)
        from .curvilinear_compiled import piecewise
        seg, vals, par, d_anchor = piecewise(theta, t, M, self.ref_time, np.inf, derivatives,
                                             anywhere=True)
        bad = np.where(ordered, 0.0, np.nan)[:, None, None]
        x, y, vx, vy = vals[..., 0], vals[..., 1], vals[..., 4], vals[..., 5]
        zeros = np.zeros_like(x)
        cart = np.stack([x, y, zeros, vx, vy, zeros], axis=-1) + bad
        intrinsic = vals[..., :4] + bad
        if not derivatives:
            return cart, intrinsic, None
        assert par is not None and d_anchor is not None
        # d anchor time / d theta: t_m for a later segment's start, t_{m+1} for an earlier
        # segment's end, nothing for the segment of the reference time
        d_time = np.zeros((B, M + 1, p))
        for m in range(M + 1):
            if m:
                d_time[m > seg_ref, m, k0 + m - 1] = 1.0
            if m < M:
                d_time[m < seg_ref, m, k0 + m] = 1.0
        r2 = np.arange(B)[:, None]
        eye = np.eye(p)
        i_at = 4 + 2 * seg
        J = (par[..., :4] @ d_anchor[r2, seg] + par[..., 4:5] * eye[i_at][..., None, :]
             + par[..., 5:6] * eye[i_at + 1][..., None, :]
             - par[..., 6:7] * d_time[r2, seg][..., None, :])
        jac = np.zeros((B, t.shape[0], 6, p))
        jac[:, :, [0, 1, 3, 4]] = J
        return cart, intrinsic, jac + bad[..., None]

    def _flat(self, theta: ArrayLike, t: ArrayLike) -> tuple[Array, Array, tuple[int, ...]]:
        theta = self.check_theta(theta)
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"sample times must be one-dimensional; got shape {t.shape}")
        return theta.reshape(-1, self.n_params), t, theta.shape[:-1]

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ENU states ``(..., n, 6)`` (m, m/s) at times ``t`` (s)."""
        flat, t, lead = self._flat(theta, t)
        cart = self._evaluate(flat, t, derivatives=False)[0]
        return cart.reshape(*lead, t.shape[0], 6)

    def intrinsic_states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give the intrinsic states ``(x, y, speed, course)`` ``(..., n, 4)`` at times ``t``.

        Parameters
        ----------
        theta, t : array_like
            As for :meth:`states`.

        Returns
        -------
        ndarray
            m, m, m/s, rad (the course unwrapped).
        """
        flat, t, lead = self._flat(theta, t)
        intrinsic = self._evaluate(flat, t, derivatives=False)[1]
        return intrinsic.reshape(*lead, t.shape[0], 4)

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give the analytic ``d state / d theta`` as :meth:`MotionModel.jacobian` does."""
        flat, t, lead = self._flat(theta, t)
        jac = self._evaluate(flat, t, derivatives=True)[2]
        assert jac is not None
        return jac.reshape(*lead, t.shape[0], 6, self.n_params)

    def rereferenced(self, theta: ArrayLike, ref_time: float, manoeuvres: int | None = None
                     ) -> tuple[PiecewiseCurvilinear, NDArray[np.float64]]:
        """Give the same trajectory as a model referenced at another time.

        Parameters
        ----------
        theta : array_like
            ``(p,)``, SI.
        ref_time : float
            s.
        manoeuvres : int, optional
            The first change-over times kept (default all).

        Returns
        -------
        model : PiecewiseCurvilinear
        theta : ndarray
            SI.

        Raises
        ------
        ValueError
            For a ``theta`` of the wrong shape or ``manoeuvres`` out of range.
        """
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (self.n_params,):
            raise ValueError(f"expected {self.n_params} parameters "
                             f"({', '.join(self.param_names)}), got shape {theta.shape}")
        keep = self.manoeuvres if manoeuvres is None else int(manoeuvres)
        if not 0 <= keep <= self.manoeuvres:
            raise ValueError(f"manoeuvres must be between 0 and {self.manoeuvres}; got {keep}")
        state = self.intrinsic_states(theta, [ref_time])[0]
        acc = theta[4:6 + 2 * keep]
        cot = theta[6 + 2 * self.manoeuvres:6 + 2 * self.manoeuvres + keep]
        return PiecewiseCurvilinear(keep, ref_time), np.concatenate([state, acc, cot])

    def __repr__(self) -> str:
        """Name the class, the number of manoeuvres and the reference time."""
        return f"PiecewiseCurvilinear(manoeuvres={self.manoeuvres}, ref_time={self.ref_time})"


NormalMaker = Callable[[NDArray[np.int64] | None], tuple[Array, Array]]
"""``make(runs)``: ``J'J`` and ``J'r`` of some runs of a batch (None: all)."""


class ForwardPiecewise(MotionModel):
    """Piecewise curvilinear motion (eqs. 1-4), ``M >= 0`` manoeuvres after ``ref_time``, batched.

    :class:`~tmakit.motion.PiecewiseCurvilinear`'s states with the search's chain rule and
    normal equations; ``t_1 <= ref_time``, times out of order or at or after ``end_time`` (s)
    give NaN states.  The last derivatives are cached: one instance per thread.
    """

    dim = 2

    def __init__(self, manoeuvres: int, ref_time: float, end_time: float = np.inf) -> None:
        if manoeuvres < 0:
            raise ValueError("the number of manoeuvres must be >= 0")
        self.manoeuvres = int(manoeuvres)
        self.ref_time = float(ref_time)
        self.end_time = float(end_time)
        self.param_names = _param_names(self.manoeuvres)
        self.name = f"curvilinear:{self.manoeuvres}"
        self._times = np.zeros(0)  # the unique times of the last states() call
        self._cache: tuple[Any, ...] | None = None
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
                  ) -> tuple[IntArray, Array, Array | None, Array | None]:
        """Propagate every sample from the start of its segment (:func:`.piecewise`)."""
        from .curvilinear_compiled import piecewise
        return piecewise(theta, t, self.manoeuvres, self.ref_time, self.end_time, partials)

    def _flat(self, theta: ArrayLike) -> tuple[Array, tuple[int, ...]]:
        theta = self.check_theta(theta)
        return theta.reshape(-1, self.n_params), theta.shape[:-1]

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
        from .curvilinear_compiled import scatter_states
        out = scatter_states(val, inv, sensor)
        return out.reshape(*lead, t.shape[0], 6)

    def _theta_partials(self, flat: Array, t: Array
                        ) -> tuple[IntArray, Array, Array, NDArray[np.int64] | None]:
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
        from .curvilinear_compiled import chain
        return chain(ds, par_u, seg_u, idx, d_anchor, self.manoeuvres, cols)

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
            from .curvilinear_compiled import segment_normal
            return segment_normal(d_state, residual, weights, par_u, seg_u, idx, d_anchor, m,
                                  runs)
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
