"""Piecewise curvilinear trajectories for many parameter vectors at once, with derivatives.

The work-horse of the manoeuvre estimator (:mod:`tmakit.batch.manoeuvre`).

The motion is that of :class:`tmakit.motion.PiecewiseCurvilinear`
(Hörst & Oispuu (2010), eqs. 1-4), in the same parameters ``x, y, speed, course, at_0, an_0,
..., at_M, an_M, t_1, ..., t_M`` (m, m, m/s, rad clockwise from North, m/s², s), restricted to
a reference time **before every change-over time** (``ref_time < t_1 < ... < t_M``; other
parameter vectors give NaN states, which a least-squares solver treats as an infinite cost, a
barrier).  The estimator references its internal fits at the first measurement time, so the
restriction costs nothing; results are reported in the user's own parameterisation.

Everything is vectorised over a leading batch axis (grid points of a profile likelihood, or
starting points), which the general model's per-vector evaluation is not.

The one-segment closed form and its derivatives are those of
:mod:`tmakit.motion.curvilinear_closed` (the one copy in tmakit); this module
chains segments forwards from the reference state through the change-over states (Hörst &
Oispuu (2010), eq. 4) by the chain rule, for a batch of parameter vectors at once.  One pass
per parameter batch gives the states and, kept for :meth:`ForwardPiecewise.chain`, the
derivatives (an observation model asks for both at the same point); at the samples only the
position and velocity derivatives are formed, and the chain rule runs segment by segment.

References
----------
Hörst & Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arrays import Array, IntArray
from ..blas import matmul
from . import curvilinear_compiled as compiled
from .base import MotionModel
from .curvilinear_closed import (
    propagate_position_velocity,
    propagate_state_partials,
    propagate_with_partials,
)

NormalMaker = Callable[[NDArray[np.int64] | None], tuple[Array, Array]]
"""``make(runs)``: ``J'J`` and ``J'r`` of some runs of a batch (None: all)."""


class ForwardPiecewise(MotionModel):
    """Piecewise curvilinear motion, change-over times after the reference time, in batches.

    :class:`~tmakit.motion.PiecewiseCurvilinear`, evaluated in batches with analytic
    derivatives.

    Same parameter names and meaning.  Segment ``m`` covers ``(t_m, t_{m+1}]`` (a sample at a
    change-over time belongs to the earlier segment), segment 0 also everything before the
    reference time.  Parameter vectors with ``t_1 <= ref_time`` or change-over times out of
    order give NaN states, and so do change-over times at or after ``end_time`` if given (the
    estimator keeps them inside the data span this way).

    The derivatives of the last parameters and times asked for are cached (an observation
    model asks for states, then derivatives, at the same point): one instance should not be
    shared between threads.  Within :meth:`derivatives_for`, :meth:`chain` gives the
    derivatives with respect to some parameters only (a fit holding the others).

    Parameters
    ----------
    manoeuvres : int
        The number of manoeuvres ``M`` (>= 0).
    ref_time : float
        Reference time of the state parameters (s), before every change-over time.
    end_time : float
        Change-over times at or after it give NaN states (s; default: none).

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
        """Make :meth:`chain` give, within the block, the derivatives for ``free`` only.

        Its columns are then those of the parameters ``free`` (the same values as in the
        whole Jacobian), the others not formed: for a fit that holds them (a solver given the
        same ``free`` reads such a Jacobian as its fitted columns).

        Parameters
        ----------
        free : ndarray of bool, optional
            ``(p,)`` the parameters whose derivatives are wanted (None: all).

        Yields
        ------
        None
            Inside the block, :meth:`chain` gives ``(..., n, q)``, ``q`` the number free.
        """
        before = self._columns
        self._columns = (None if free is None or np.all(free)
                         else np.flatnonzero(np.asarray(free, dtype=bool)))
        try:
            yield
        finally:
            self._columns = before

    # -- the chain of change-over states -----------------------------------------------------
    def _anchors(self, theta: Array, partials: bool
                 ) -> tuple[Array, Array | None, Array, Array]:
        """Chain the states ``(x, y, speed, course)`` at the start of every segment.

        Give them ``(B, M+1, 4)``, their derivatives ``(B, M+1, 4, p)`` (or None), the
        segments' start times ``(B, M+1)`` and a validity mask ``(B,)``.
        """
        M, p = self.manoeuvres, self.n_params
        b = theta.shape[0]
        acc = theta[:, 4:6 + 2 * M].reshape(b, M + 1, 2)
        cot = theta[:, 6 + 2 * M:]
        starts = np.concatenate([np.full((b, 1), self.ref_time), cot], axis=1)
        valid = np.all(np.diff(starts, axis=1) > 0, axis=1) & (starts[:, -1] < self.end_time
                                                              if M else True)
        anchors = np.empty((b, M + 1, 4))
        anchors[:, 0] = theta[:, :4]
        d_anchor = None
        if partials:
            d_anchor = np.zeros((b, M + 1, 4, p))
            d_anchor[:, 0, :, :4] = np.eye(4)
        for m in range(1, M + 1):
            x0, y0, v0, c0 = anchors[:, m - 1].T
            args = (x0, y0, v0, c0, acc[:, m - 1, 0], acc[:, m - 1, 1],
                    starts[:, m] - starts[:, m - 1])
            if partials:
                val, par = propagate_state_partials(*args)
            else:
                val, _ = propagate_with_partials(*args, partials=False)
            anchors[:, m] = val[:, :4]
            if partials:
                assert d_anchor is not None
                d = np.einsum("bij,bjp->bip", par[:, :, :4], d_anchor[:, m - 1])
                d[:, :, 4 + 2 * (m - 1)] += par[:, :, 4]
                d[:, :, 5 + 2 * (m - 1)] += par[:, :, 5]
                d[:, :, 6 + 2 * M + m - 1] += par[:, :, 6]
                if m >= 2:
                    d[:, :, 6 + 2 * M + m - 2] -= par[:, :, 6]
                d_anchor[:, m] = d
        anchors[~valid] = np.nan
        return anchors, d_anchor, starts, valid

    def _segments(self, theta: Array, t: Array, partials: bool
                  ) -> tuple[IntArray, Array, Array | None, Array | None]:
        """Propagate every sample from the start of its segment.

        Give per sample its segment ``(B, n)``, propagated values ``(B, n, 6)`` and the
        partials of ``(x, y, vx, vy)`` ``(B, n, 4, 7)`` with respect to the segment's start
        state, accelerations and the time since its start; plus the anchors' derivatives.
        """
        M = self.manoeuvres
        if compiled.available():
            return compiled.piecewise(theta, t, M, self.ref_time, self.end_time, partials)
        b = theta.shape[0]
        anchors, d_anchor, starts, _ = self._anchors(theta, partials)
        acc = theta[:, 4:6 + 2 * M].reshape(b, M + 1, 2)
        if M == 0:
            seg = np.zeros((b, t.size), dtype=np.int64)
            a0 = np.broadcast_to(anchors[:, :1], (b, t.size, 4))
            ac = np.broadcast_to(acc[:, :1], (b, t.size, 2))
            dt = np.broadcast_to(t[None, :] - starts[:, :1], (b, t.size))
        else:
            cot = theta[:, 6 + 2 * M:]
            seg = np.sum(t[None, :, None] > cot[:, None, :], axis=-1)  # (B, n)
            rows = np.arange(b)[:, None]
            a0 = anchors[rows, seg]                          # (B, n, 4)
            ac = acc[rows, seg]                              # (B, n, 2)
            dt = t[None, :] - starts[rows, seg]
        args = (a0[..., 0], a0[..., 1], a0[..., 2], a0[..., 3], ac[..., 0], ac[..., 1], dt)
        par: Array | None
        if partials:
            val, par = propagate_position_velocity(*args)
        else:
            val, par = propagate_with_partials(*args, partials=False)
        return seg, val, par, d_anchor

    def _flat(self, theta: ArrayLike) -> tuple[Array, tuple[int, ...]]:
        theta = self.check_theta(theta)
        return theta.reshape(-1, self.n_params), theta.shape[:-1]

    # -- the MotionModel interface -----------------------------------------------------------
    def states(self, theta: ArrayLike, t: ArrayLike) -> Array:
        """Give ENU states ``(..., n, 6)`` (m, m/s) at times ``t`` (s).

        Parameters and returns as :meth:`MotionModel.states`; NaN for parameters outside the
        model's domain (see the class docstring).  The derivatives at the same parameters and
        times are computed in the same pass and kept for :meth:`chain` (an observation model
        asks for them next).
        """
        return self._rows_states(theta, t, None)

    def states_minus(self, theta: ArrayLike, t: ArrayLike, sensor: Array) -> Array:
        """Give :meth:`states` minus the sensor's states ``(n, 6)``, in one pass if compiled.

        Parameters and returns as :meth:`MotionModel.states_minus` (the same bits).
        """
        sensor = np.asarray(sensor, dtype=float)
        t = np.asarray(t, dtype=float)
        if sensor.shape != (t.shape[0], 6) or not compiled.available():
            return self.states(theta, t) - sensor
        return self._rows_states(theta, t, sensor)

    def _rows_states(self, theta: ArrayLike, t: ArrayLike, sensor: Array | None) -> Array:
        """Give the states at every time of ``t`` (minus ``sensor``'s if given, compiled)."""
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
        if compiled.available():
            return compiled.scatter_states(val, inv, sensor).reshape(*lead, t.shape[0], 6)
        out = np.zeros((flat.shape[0], tu.size, 6))
        out[..., 0], out[..., 1] = val[..., 0], val[..., 1]
        out[..., 3], out[..., 4] = val[..., 4], val[..., 5]
        out[..., 2] = out[..., 5] = np.where(np.isnan(val[..., 0]), np.nan, 0.0)
        return out[:, inv].reshape(*lead, t.shape[0], 6)

    def _theta_partials(self, flat: Array, t: Array
                        ) -> tuple[IntArray, Array, Array, NDArray[np.int64] | None]:
        """Give the per-segment partials at the unique times ``tu`` of ``t``, cached.

        The segment of every sample ``(B, nu)``, ``d (x, y, vx, vy) / d inputs``
        ``(B, nu, 4, 7)`` — the inputs being a segment's start state, its accelerations and the
        time since its start — and the segment start states' derivatives ``(B, M+1, 4, p)``;
        plus the index of every ``t`` into ``tu`` (None when ``t`` is ``tu``).

        The last result is kept (:meth:`states` makes it): an observation model asks for the
        states at all its rows and then for the derivatives at the same parameters and times.
        """
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
        """Give the analytic ``d state / d theta`` ``(..., n, 6, p)`` at times ``t`` (s).

        Parameters and returns as :meth:`MotionModel.jacobian`.
        """
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
        """Give ``d value / d theta`` ``(B, n, p)`` from ``d value / d state`` ``(B, n, 6)``.

        Per sample, ``ds`` times ``d state / d (segment inputs)`` gives ``w`` ``(B, n, 7)``;
        then, segment by segment, ``w`` times the derivatives of that segment's inputs (its
        start state's, unit rows for its accelerations, minus one for its change-over time),
        kept on the rows in that segment.  With ``cols``, only those columns ``(B, n, q)``.
        """
        M, p = self.manoeuvres, self.n_params
        b = flat.shape[0]
        seg_u, par_u, d_anchor, idx = self._theta_partials(flat, t)
        if compiled.available():
            return compiled.chain(ds, par_u, seg_u, idx, d_anchor, M, cols)
        w, seg = _weights(ds, par_u, seg_u, idx)
        if M == 0:
            return np.ascontiguousarray(w[..., :6] if cols is None else w[..., cols])
        # d (segment inputs) / d theta per segment: the start state's derivatives, then unit
        # rows for the accelerations and minus one for the change-over time starting it
        d_inputs = np.zeros((b, M + 1, 7, p))
        d_inputs[:, :, :4] = d_anchor
        for m in range(M + 1):
            d_inputs[:, m, 4, 4 + 2 * m] = d_inputs[:, m, 5, 5 + 2 * m] = 1.0
            if m >= 1:
                d_inputs[:, m, 6, 5 + 2 * M + m] = -1.0
        out = matmul(w, d_inputs[:, 0])
        for m in range(1, M + 1):
            np.copyto(out, matmul(w, d_inputs[:, m]), where=(seg == m)[..., None])
        return out if cols is None else np.ascontiguousarray(out[..., cols])

    def chain(self, d_state: Array, theta: ArrayLike, t: ArrayLike) -> Array:
        """Apply the chain rule, contracting the state axis before the parameter axis.

        No ``(B, n, 6, p)`` array is formed.  Parameters and returns as
        :meth:`MotionModel.chain`.
        """
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        cols = self._columns
        if d_state.ndim != len(lead) + 2:
            out = super().chain(d_state, theta, t)
            return out if cols is None else out[..., cols]
        out = self._chain_flat(d_state.reshape(flat.shape[0], t.shape[0], 6), flat, t, cols)
        return out.reshape(*lead, t.shape[0], out.shape[-1])

    def normal_equations(self, d_state: Array, residual: Array, weights: Array,
                         theta: ArrayLike, t: ArrayLike) -> tuple[Array, Array] | None:
        """Give ``J'J`` and ``J'r`` of the whitened Jacobian without forming it, or None.

        ``J`` is :meth:`chain` of ``d_state`` with every parameter (``derivatives_for`` not
        applied: a solver selects its free rows and columns), its rows whitened by
        ``weights``; summed by segments (:mod:`tmakit.motion.curvilinear_normal_numba`).
        None without the compiled kernels.

        Parameters
        ----------
        d_state : ndarray
            ``(B, n, 6)`` derivatives of the predictions by the ENU state.
        residual : ndarray
            ``(B, n)`` whitened residuals.
        weights : ndarray
            ``(n,)`` inverse standard deviations of the rows.
        theta : array_like
            ``(B, p)`` parameters (SI units).
        t : array_like
            ``(n,)`` the rows' times (s).

        Returns
        -------
        (ndarray, ndarray) or None
            ``(B, p, p)`` and ``(B, p)``.
        """
        later = self.normal_equations_later(d_state, residual, weights, theta, t)
        return None if later is None else later(None)

    def normal_equations_later(self, d_state: Array, residual: Array, weights: Array,
                               theta: ArrayLike, t: ArrayLike) -> NormalMaker | None:
        """Hold what :meth:`normal_equations` needs; sum it later, for the runs asked.

        A solver rejects about a third of its trial points; their ``J'J`` is never summed.
        The arrays are held as they are (none is written again: the sample partials are
        those of this ``theta``, made by :meth:`states`).

        Parameters
        ----------
        d_state, residual, weights, theta, t
            As for :meth:`normal_equations`.

        Returns
        -------
        callable or None
            ``make(runs)``: ``J'J`` ``(R, p, p)`` and ``J'r`` ``(R, p)`` of the rows ``runs``
            of the batch (None: all), each the same bits as in the whole; None without the
            compiled kernels.
        """
        if not compiled.available():
            return None
        flat, _ = self._flat(theta)
        t = np.asarray(t, dtype=float)
        seg_u, par_u, d_anchor, idx = self._theta_partials(flat, t)
        m = self.manoeuvres

        def make(runs: NDArray[np.int64] | None) -> tuple[Array, Array]:
            return compiled.segment_normal(d_state, residual, weights, par_u, seg_u, idx,
                                           d_anchor, m, runs)
        return make

    def segment_states(self, theta: ArrayLike, t: ArrayLike) -> Array:
        """Give ``(x, y, speed, course)`` at times ``t``, the course unwrapped.

        These are the parameters of the same trajectory referenced at another time.

        Parameters
        ----------
        theta : array_like
            ``(..., p)`` parameters (SI units).
        t : array_like
            ``(n,)`` times (s).

        Returns
        -------
        ndarray
            ``(..., n, 4)`` (m, m, m/s, rad clockwise from North, continuous from the
            reference course).
        """
        flat, lead = self._flat(theta)
        t = np.asarray(t, dtype=float)
        _, val, _, _ = self._segments(flat, t, partials=False)
        return val[..., :4].reshape(*lead, t.shape[0], 4)

    def __repr__(self) -> str:
        """Name the class, the number of manoeuvres and the reference time."""
        return f"ForwardPiecewise(manoeuvres={self.manoeuvres}, ref_time={self.ref_time})"


def _weights(ds: Array, par_u: Array, seg_u: IntArray, idx: NDArray[np.int64] | None
             ) -> tuple[Array, IntArray]:
    """Contract ``ds`` ``(B, n, 6)`` with the sample partials ``par_u`` ``(B, nu, 4, 7)``.

    Give ``w`` ``(B, n, 7)`` and every row's segment ``(B, n)``.  Rows that follow the unique
    times in order (one block per kind, usually) are contracted on views; anything else is
    gathered.
    """
    b, n = ds.shape[:2]
    if idx is None:
        blocks = [(0, n, 0)]
    else:
        cuts = np.flatnonzero(np.diff(idx) != 1) + 1
        starts = np.concatenate([[0], cuts])
        ends = np.concatenate([cuts, [n]])
        blocks = ([(int(a), int(e), int(idx[a])) for a, e in zip(starts, ends, strict=True)]
                  if starts.size <= 16 else [])
    if not blocks:
        assert idx is not None
        par_u, seg_u, blocks = par_u[:, idx], seg_u[:, idx], [(0, n, 0)]
    w = np.empty((b, n, 7))
    seg = np.empty((b, n), dtype=seg_u.dtype)
    w[..., 0], w[..., 1] = ds[..., 0], ds[..., 1]  # the position rows: (1, 0) and (0, 1)
    for a, e, u in blocks:
        par = par_u[:, u:u + e - a, :, 2:]
        d = ds[:, a:e]
        w[:, a:e, 2:] = (d[..., 0, None] * par[:, :, 0] + d[..., 1, None] * par[:, :, 1]
                         + d[..., 3, None] * par[:, :, 2] + d[..., 4, None] * par[:, :, 3])
        seg[:, a:e] = seg_u[:, u:u + e - a]
    return w, seg
