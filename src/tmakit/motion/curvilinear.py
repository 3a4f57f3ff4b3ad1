"""Exact curvilinear motion (Hörst & Oispuu (2010), §2.1, eq. 1) and its pieces (eqs. 2-4).

State ``(x, y, v, phi)``: ENU position (m), speed (m/s), course (rad, clockwise from North);
``a_t`` changes the speed, ``a_n`` turns the course at ``a_n / v`` (positive: starboard).  The
closed form and its analytic derivatives are compiled
(:func:`tmakit.motion.curvilinear_compiled.propagate_with_partials`);
:class:`PiecewiseCurvilinear` chains them through the change-over times.  Reference: Hörst &
Oispuu (2010), §2, eqs. 1-4.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from .base import MotionModel


def _propagate(x: ArrayLike, y: ArrayLike, speed: ArrayLike, course: ArrayLike,
               a_t: ArrayLike, a_n: ArrayLike, dt: ArrayLike, derivatives: bool = False
               ) -> tuple[tuple[Array, ...], Array | None]:
    """Propagate (compiled, ``numba`` imported at the first call); give ``(values, D)``."""
    from .curvilinear_compiled import propagate_with_partials
    values, par = propagate_with_partials(x, y, speed, course, a_t, a_n, dt, derivatives)
    return tuple(np.moveaxis(values, -1, 0)), None if par is None else par[..., :4, :]


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
    return _propagate(x, y, speed, course, a_t, a_n, dt)[0]


def propagate_curvilinear_derivatives(x: ArrayLike, y: ArrayLike, speed: ArrayLike,
                                      course: ArrayLike, a_t: ArrayLike, a_n: ArrayLike,
                                      dt: ArrayLike
                                      ) -> tuple[tuple[NDArray[np.float64], ...],
                                                 NDArray[np.float64]]:
    """Propagate as :func:`propagate_curvilinear`, with analytic derivatives."""
    values, D = _propagate(x, y, speed, course, a_t, a_n, dt, derivatives=True)
    assert D is not None
    return values, D


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
        accel = []
        for m in range(self.manoeuvres + 1):
            accel += [f"at_{m}", f"an_{m}"]
        times = [f"t_{m}" for m in range(1, self.manoeuvres + 1)]
        self.param_names = ("x", "y", "speed", "course", *accel, *times)
        self.name = f"curvilinear:{self.manoeuvres}"

    # -- parameter layout ----------------------------------------------------------------
    def accel_index(self, segment: int) -> tuple[int, int]:
        """Give the indices of ``at_segment`` and ``an_segment`` in ``theta``.

        Parameters
        ----------
        segment : int
            0..M.

        Returns
        -------
        tuple of int
        """
        return 4 + 2 * segment, 5 + 2 * segment

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

    # -- evaluation ------------------------------------------------------------------------
    def _evaluate(self, theta: Array, t: Array, derivatives: bool
                  ) -> tuple[Array, Array, Array | None]:
        """Evaluate ``theta`` ``(B, p)`` at times ``t``, with derivatives if asked."""
        M, p = self.manoeuvres, self.n_params
        B, n = theta.shape[0], t.shape[0]
        acc = theta[:, 4:6 + 2 * M].reshape(B, M + 1, 2)
        cot = theta[:, 6 + 2 * M:]
        rows = np.arange(B)
        eye = np.eye(p)
        with np.errstate(invalid="ignore"):
            ordered = (np.all(np.diff(cot, axis=1) > 0, axis=1) if M > 1
                       else np.all(np.isfinite(cot), axis=1))
            seg_ref = np.sum(cot < self.ref_time, axis=1)               # (B,)
            seg_of = np.sum(t[None, :, None] > cot[:, None, :], axis=-1)  # (B, n)
        # Anchor of each segment: a time inside or at the edge of it and the state there.
        anc_t = np.full((B, M + 1), np.nan)
        anc_s = np.full((B, M + 1, 4), np.nan)
        anc_t[rows, seg_ref] = self.ref_time
        anc_s[rows, seg_ref] = theta[:, :4]
        if derivatives:
            anc_J = np.zeros((B, M + 1, 4, p))      # d anchor state / d theta
            anc_dT = np.zeros((B, M + 1, p))        # d anchor time / d theta
            anc_J[rows, seg_ref, :, :4] = np.eye(4)

        def link(frm: int, to: int, seg_acc: int, m: int, mask: Array) -> None:
            """Set anchor ``to``: anchor ``frm`` moved to ``t_m`` by segment ``seg_acc``."""
            if not np.any(mask):
                return
            a = acc[:, seg_acc]
            dt = cot[:, m - 1] - anc_t[:, frm]
            s = anc_s[:, frm]
            vals, D = _propagate(s[:, 0], s[:, 1], s[:, 2], s[:, 3], a[:, 0], a[:, 1], dt,
                                 derivatives)
            anc_t[mask, to] = cot[mask, m - 1]
            anc_s[mask, to] = np.stack(vals[:4], axis=-1)[mask]
            if derivatives:
                assert D is not None
                i_at, i_an = self.accel_index(seg_acc)
                d_dt = eye[self.time_index(m)] - anc_dT[:, frm]             # (B, p)
                J = (D[:, :, :4] @ anc_J[:, frm] + D[:, :, 4:5] * eye[i_at]
                     + D[:, :, 5:6] * eye[i_an] + D[:, :, 6:7] * d_dt[:, None, :])
                anc_J[mask, to] = J[mask]
                anc_dT[mask, to] = eye[self.time_index(m)]

        with np.errstate(invalid="ignore"):
            for j in range(1, M + 1):        # forwards: t_j starts segment j
                link(j - 1, j, j - 1, j, j > seg_ref)
            for j in range(M - 1, -1, -1):   # backwards: t_{j+1} ends segment j
                link(j + 1, j, j + 1, j + 1, j < seg_ref)

            r2 = rows[:, None]
            a = acc[r2, seg_of]                                             # (B, n, 2)
            s = anc_s[r2, seg_of]
            vals, D = _propagate(s[..., 0], s[..., 1], s[..., 2], s[..., 3], a[..., 0],
                                 a[..., 1], t[None, :] - anc_t[r2, seg_of], derivatives)
        x, y, speed, course, vx, vy = vals
        bad = np.where(ordered, 0.0, np.nan)[:, None]
        zeros = np.zeros_like(x)
        cart = np.stack([x, y, zeros, vx, vy, zeros], axis=-1) + bad[..., None]
        intrinsic = np.stack([x, y, speed, course], axis=-1) + bad[..., None]
        if not derivatives:
            return cart, intrinsic, None
        assert D is not None
        i_at = 4 + 2 * seg_of
        J = (D[..., :4] @ anc_J[r2, seg_of] + D[..., 4:5] * eye[i_at][..., None, :]
             + D[..., 5:6] * eye[i_at + 1][..., None, :]
             - D[..., 6:7] * anc_dT[r2, seg_of][..., None, :])
        jac = np.zeros((B, n, 6, p))
        jac[:, :, 0] = J[:, :, 0]
        jac[:, :, 1] = J[:, :, 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            sin_c, cos_c = (vx / speed)[..., None], (vy / speed)[..., None]
        jac[:, :, 3] = sin_c * J[:, :, 2] + vy[..., None] * J[:, :, 3]
        jac[:, :, 4] = cos_c * J[:, :, 2] - vx[..., None] * J[:, :, 3]
        jac = jac + bad[..., None, None]
        return cart, intrinsic, jac

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
