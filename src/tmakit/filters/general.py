"""The general filter path, compiled once per file: any kinds, any sensors, 2-D and 3-D.

A filter step on the general path used to build a :class:`~tmakit.observation.MeasurementGroup`
(its row model, noise covariance and layout), move the state to the rows, call each kind's
``predict`` and ``jacobian``, chain the Jacobian, and solve twice on a Cholesky factor: about
290 Python calls.  Here everything that does not depend on the state is made once per file
(:class:`~.plan.StepPlan`): the rows of each update sorted by kind (every kind's rows a slice, a
view), the linear map from the filter state to the target states at the rows (one per pattern
of row-time offsets), the noise covariance of each update, the angle rows.  A step is then one
product for the relative states, one fused ``predict_gradient`` per kind, one product for the
chained Jacobian, and :func:`kalman_gain` — closed form for one and two rows, one Cholesky
factorisation otherwise.  The dynamics' ``Phi`` and ``Q`` are cached per step size
(:class:`DynamicsCache`); the EKF's posterior covariance is ``P - K H P``, the Joseph form only
when that fails its Cholesky check (:func:`updated_covariance`), repaired only when that fails
too (:func:`checked_psd`).  Small products use ``ndarray.dot``: on arrays of a few entries
NumPy 2's ``@`` (a ufunc) costs about twice as much per call, for the same BLAS result.

Kinds with an earlier reference sample (range differences) keep the group path.  The results
equal the group path's (:meth:`TrackingFilter.run_groups`) to rounding;
``tests/test_filters.py::test_general_plan_equals_the_group_path`` pins them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dposv, dpotrf

from ..arrays import Array
from ..frames import wrap_angle
from ..linalg import repair_psd, solve_spd
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import TIME_TOLERANCE
from .kernels import TWO_PI, KernelRun

#: One update of a plan: update time (s), values (m,), sensor states flattened (m * 6,),
#: the kinds' parts, the state-to-target map ``T`` (m * 6, n), its rows as (m, 6, n) or None
#: when every row is at the update time (then ``E`` (6, n) chains), noise ``R`` (m, m), the
#: angle rows (index or None), the row times (m,), and the rows as plain-float records
#: for the kinds' ``row_gradient`` (or None: the kinds' ``predict_gradient`` on arrays).
Step = tuple


def sym(p: Array) -> Array:
    """Give ``(P + P^T) / 2`` of one square matrix (the value of :func:`~tmakit.linalg.symmetrise`).

    Parameters
    ----------
    p : numpy.ndarray
        ``(n, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        A new symmetric matrix (units of ``p``).
    """
    out = p + p.T
    out *= 0.5
    return out


def checked_psd(p: Array) -> Array:
    """Give ``p`` symmetrised, repaired (:func:`~tmakit.linalg.repair_psd`) only if not PD.

    Parameters
    ----------
    p : numpy.ndarray
        Covariance ``(n, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        Symmetric, numerically positive-definite ``(n, n)`` matrix: ``p`` symmetrised when its
        Cholesky factorisation succeeds (the check), else :func:`~tmakit.linalg.repair_psd`.
    """
    p = sym(p)
    if dpotrf(p, lower=1, clean=0)[1] == 0:
        return p
    return repair_psd(p)


def innovation_solve(s: Array, hp: Array, residual: Array) -> tuple[Array, float, float]:
    """Give ``(S^-1 HP)^T``, the NIS ``residual^T S^-1 residual`` and ``log det S``.

    One and two rows in closed form, more by one Cholesky factorisation and solve (LAPACK
    ``posv``); an ``S`` that is not numerically positive definite goes to
    :func:`~tmakit.linalg.solve_spd`, which repairs it.

    Parameters
    ----------
    s : numpy.ndarray
        Innovation covariance ``(m, m)`` (measurement units squared), symmetric to rounding:
        two rows average ``s[0, 1]`` and ``s[1, 0]``, more rows read the lower triangle.
    hp : numpy.ndarray
        ``H P`` ``(m, n)`` (the cross covariance of measurement and state, transposed).
    residual : numpy.ndarray
        Innovation ``(m,)`` (SI).

    Returns
    -------
    gain : numpy.ndarray
        ``P H^T S^-1`` ``(n, m)``.
    nis : float
        Normalised innovation squared.
    log_det : float
        ``log det S`` (natural logarithm).
    """
    m = s.shape[0]
    if m == 1:
        s00 = float(s[0, 0])
        if s00 > 0.0:
            y0 = float(residual[0])
            return hp.T / s00, y0 * y0 / s00, math.log(s00)
    elif m == 2:
        a, c = float(s[0, 0]), float(s[1, 1])
        b = 0.5 * (float(s[0, 1]) + float(s[1, 0]))
        det = a * c - b * b
        if a > 0.0 and det > 0.0:
            inv = np.array([[c, -b], [-b, a]]) / det
            return inv.dot(hp).T, float(residual.dot(inv).dot(residual)), math.log(det)
    else:
        chol, sol, info = dposv(s, np.concatenate((hp, residual[:, None]), axis=1), lower=1)
        if info == 0:
            return (sol[:, :-1].T, float(residual.dot(sol[:, -1])),
                    2.0 * math.fsum(map(math.log, chol.diagonal().tolist())))
    sol, log_det = solve_spd(s, np.concatenate([hp, residual[:, None]], axis=1))
    return sol[:, :-1].T, float(residual @ sol[:, -1]), log_det


def kalman_gain(cov: Array, h: Array, r: Array, residual: Array
                ) -> tuple[Array, float, float]:
    """Give the Kalman gain ``P H^T S^-1``, the NIS and ``log det S``, ``S = H P H^T + R``.

    Parameters
    ----------
    cov : numpy.ndarray
        Prior covariance ``(n, n)``.
    h : numpy.ndarray
        Measurement matrix ``(m, n)``.
    r : numpy.ndarray
        Measurement noise covariance ``(m, m)``.
    residual : numpy.ndarray
        Innovation ``(m,)`` (SI).

    Returns
    -------
    gain, nis, log_det
        As for :func:`innovation_solve`.
    """
    hp = h.dot(cov)
    s = hp.dot(h.T)
    s += r
    return innovation_solve(s, hp, residual)


def updated_covariance(cov: Array, gain: Array, hp: Array, h: Array, r: Array) -> Array:
    """Give the updated covariance ``P - K H P``, in Joseph form only when that is not PD.

    ``P - K (H P)`` symmetrised is taken when its Cholesky check succeeds; otherwise the Joseph
    form ``(I - K H) P (I - K H)^T + K R K^T`` (equal for the optimal gain, and safer in
    rounding), symmetrised and repaired when its own check fails (:func:`checked_psd`).

    Parameters
    ----------
    cov : numpy.ndarray
        Prior covariance ``P`` ``(n, n)`` (SI).
    gain : numpy.ndarray
        Kalman gain ``K`` ``(n, m)``.
    hp : numpy.ndarray
        ``H P`` ``(m, n)``.
    h : numpy.ndarray
        Measurement matrix ``H`` ``(m, n)``.
    r : numpy.ndarray
        Measurement noise covariance ``(m, m)`` (SI).

    Returns
    -------
    numpy.ndarray
        The updated covariance ``(n, n)``, symmetric and numerically positive definite.
    """
    p = cov - gain.dot(hp)
    p = p + p.T
    p *= 0.5
    if dpotrf(p, lower=1, clean=0)[1] == 0:
        return p
    i_kh = np.eye(cov.shape[0]) - gain.dot(h)
    p = i_kh.dot(cov).dot(i_kh.T)
    p += gain.dot(r).dot(gain.T)
    return checked_psd(p)


class DynamicsCache:
    """``Phi(dt)`` and ``Q(dt)`` of nearly-constant-velocity dynamics, made once per step size.

    Parameters
    ----------
    dynamics : NearlyConstantVelocity
        The dynamics.

    References
    ----------
    Chen & Sun, §2.1 (``Phi(T)`` and ``Q_k``).
    """

    def __init__(self, dynamics: NearlyConstantVelocity) -> None:
        self.dynamics = dynamics
        self._cache: dict[float, tuple[Array, Array, Array]] = {}

    def get(self, dt: float) -> tuple[Array, Array, Array]:
        """Give the transition and process noise of one step (cached by step size).

        Parameters
        ----------
        dt : float
            The step, s (> 0).

        Returns
        -------
        phi, phi_t, q : ndarray
            ``Phi(dt)``, its transpose (contiguous) and ``Q(dt)``, each ``(n, n)``, SI.
        """
        out = self._cache.get(dt)
        if out is None:
            if len(self._cache) > 256:  # irregular times: keep the cache small
                self._cache.clear()
            phi = self.dynamics.transition(dt)
            out = (phi, np.ascontiguousarray(phi.T), self.dynamics.noise(dt))
            self._cache[dt] = out
        return out


def predict_rows(step: Step, x: Array, dim: int) -> tuple[Array, Array]:
    """Give the predictions ``(..., m)`` and relative states ``(..., m, 6)`` at states ``x``.

    Parameters
    ----------
    step : Step
        One update of a :class:`~.plan.StepPlan`.
    x : numpy.ndarray
        Filter states ``(..., 2 dim)`` (m, m/s).
    dim : int
        2 or 3.

    Returns
    -------
    values, rel : numpy.ndarray
        Predicted values (SI) and the relative states they came from (m, m/s).
    """
    _, _, sens, parts, tmap, _, _, _, times, _ = step
    xt = x.dot(tmap.T) if x.ndim <= 2 else x @ tmap.T
    rel = (xt - sens).reshape(*x.shape[:-1], -1, 6)
    if len(parts) == 1:
        model, _, nu = parts[0]
        return model.predict(rel, times, nu, None), rel
    out = np.empty(rel.shape[:-1])
    for model, sl, nu in parts:
        out[..., sl] = model.predict(rel[..., sl, :], times[sl], nu, None)
    return out, rel


def wrap_small(a: Array) -> Array:
    """Wrap angle differences to (-pi, pi], leaving those already inside untouched.

    The values of :func:`~tmakit.frames.wrap_angle` (which also keeps values inside as they
    are), without its copy: the few entries of a filter's update are tested as floats, and
    only an array with a value outside goes to ``wrap_angle``.

    Parameters
    ----------
    a : numpy.ndarray
        Angle differences (rad), any shape.

    Returns
    -------
    numpy.ndarray
        ``a`` itself when every entry is in (-pi, pi], else ``wrap_angle(a)`` (rad).
    """
    flat = a.ravel().tolist()
    if flat and -math.pi < min(flat) and max(flat) <= math.pi:
        return a
    return wrap_angle(a)


def linearise(step: Step, x: Array, eye_map: Array) -> tuple[Array, Array, bool]:
    """Give the wrapped residual ``z - h(x)`` (m,) and the Jacobian ``H`` (m, n) at ``x``.

    Parameters
    ----------
    step : Step
        One update of a :class:`~.plan.StepPlan`.
    x : numpy.ndarray
        Filter state ``(n,)`` (m, m/s).
    eye_map : numpy.ndarray
        The map ``(6, n)`` of a row at the update time.

    Returns
    -------
    residual, h : numpy.ndarray
        Innovation (SI, angles wrapped to (-pi, pi]) and ``d h / d x``.
    ok : bool
        Whether both are finite.
    """
    _, z, sens, parts, tmap, t3, _, angle, times, rows = step
    if rows is not None:
        return _linearise_rows(rows, x, eye_map.shape[1] // 2)
    rel = (tmap.dot(x) - sens).reshape(-1, 6)
    if len(parts) == 1:
        model, _, nu = parts[0]
        pred, d = model.predict_gradient(rel, times, nu)
    else:
        pred = np.empty(rel.shape[0])
        d = np.empty(rel.shape)
        for model, sl, nu in parts:
            pred[sl], d[sl] = model.predict_gradient(rel[sl], times[sl], nu)
    h = d.dot(eye_map) if t3 is None else np.einsum("mi,min->mn", d, t3)
    y = z - pred
    if angle is not None:
        y[angle] = wrap_angle(y[angle])
    return y, h, finite(y, h)


def _linearise_rows(rows: list[tuple], x: Array, dim: int) -> tuple[Array, Array, bool]:
    """:func:`linearise` in plain floats, row by row (``row_gradient`` of each kind).

    A row whose arithmetic divides by zero (the state on a sensor) gives NaN, as NumPy's
    inf/NaN would, so that the update is skipped.
    """
    xs = x.tolist()
    if dim == 2:
        px, py, vx, vy = xs
        pz = vz = 0.0
    else:
        px, py, pz, vx, vy, vz = xs
    ys: list[float] = []
    hs: list[float] = []
    nan = float("nan")
    for fn, nu, t, dt, z, ang, s in rows:
        try:
            if dt:
                v, g0, g1, g2, g3, g4, g5 = fn(
                    (px + dt * vx - s[0], py + dt * vy - s[1], pz + dt * vz - s[2],
                     vx - s[3], vy - s[4], vz - s[5]), t, nu)
            else:
                v, g0, g1, g2, g3, g4, g5 = fn(
                    (px - s[0], py - s[1], pz - s[2], vx - s[3], vy - s[4], vz - s[5]), t, nu)
        except (ZeroDivisionError, OverflowError, ValueError):
            v = g0 = g1 = g2 = g3 = g4 = g5 = nan
        if ang:
            y = math.remainder(z - v, TWO_PI)
            ys.append(math.pi if y == -math.pi else y)
        else:
            ys.append(z - v)
        if dim == 2:
            hs += (g0, g1, g0 * dt + g3, g1 * dt + g4) if dt else (g0, g1, g3, g4)
        else:
            hs += (g0, g1, g2, g0 * dt + g3, g1 * dt + g4, g2 * dt + g5) if dt else \
                (g0, g1, g2, g3, g4, g5)
    m = len(ys)
    ys += hs
    both = np.array(ys)
    y_arr, h_arr = both[:m], both[m:].reshape(m, 2 * dim)
    # NaN or infinity anywhere makes the sum NaN or infinite; an overflow of a finite sum
    # is told apart by the arrays themselves.
    total = sum(ys)
    ok = total - total == 0.0 or bool(np.isfinite(both).all())
    return y_arr, h_arr, ok


def finite(y: Array, h: Array) -> bool:
    """Tell whether a residual and a Jacobian are finite.

    Two dot products decide when their sum is finite; otherwise (a NaN, an infinity, or an
    overflow of the squares) ``numpy.isfinite`` does.

    Parameters
    ----------
    y, h : ndarray
        A residual ``(m,)`` and a Jacobian ``(m, n)``.

    Returns
    -------
    bool
        True when every entry of both is finite.
    """
    flat = h.reshape(-1)
    total = float(y.dot(y)) + float(flat.dot(flat))
    if total - total == 0.0:
        return True
    return bool(np.isfinite(y).all() and np.isfinite(h).all())


class PlanOutputs:
    """Per-update outputs of a run on a plan, gathered as rows, stacked at the end.

    The states and covariances are kept by reference: every step makes new arrays.

    Parameters
    ----------
    k : int
        Number of updates.
    n : int
        State size.

    Attributes
    ----------
    rows : list of tuple
        One ``(time s, state (n,), covariance (n, n), NIS, rows, cumulative log-likelihood
        nats)`` per update, appended by the run (``rows.append``: one call a step).
    """

    def __init__(self, k: int, n: int) -> None:
        self.n = n
        self.rows: list[tuple[float, Array, Array, float, int, float]] = []

    def put(self, t: float, mean: Array, cov: Array, nis: float, dof: int, ll: float) -> None:
        """Record the next update.

        Parameters
        ----------
        t : float
            Its time, s.
        mean, cov : ndarray
            The updated state ``(n,)`` and covariance ``(n, n)``, SI (kept by reference).
        nis : float
            Normalised innovation squared.
        dof : int
            Measurement rows of the update.
        ll : float
            Cumulative log-likelihood, nats.
        """
        self.rows.append((t, mean, cov, nis, dof, ll))

    def run(self, mean: Array, cov: Array, t: float, ll: float) -> KernelRun:
        """Give the outputs as a :class:`~.kernels.KernelRun` ending at the last update.

        Parameters
        ----------
        mean, cov : ndarray
            The final state ``(n,)`` and covariance ``(n, n)``, SI.
        t : float
            Their time, s.
        ll : float
            The final cumulative log-likelihood, nats.

        Returns
        -------
        KernelRun
            The run, with every recorded update stacked.
        """
        n, k = self.n, len(self.rows)
        if not k:
            return KernelRun(0, False, mean, cov, t, ll, np.zeros(0), np.zeros((0, n)),
                             np.zeros((0, n, n)), np.zeros(0), np.zeros(0),
                             np.zeros(0, dtype=np.int64), True)
        times, states, covs, nis, dof, lls = zip(*self.rows, strict=True)
        return KernelRun(k, False, mean, cov, t, ll, np.array(times),
                         np.concatenate(states).reshape(-1, n),
                         np.concatenate(covs).reshape(-1, n, n), np.array(nis),
                         np.array(lls), np.array(dof, dtype=np.int64), True)


def predict_gaussian(dyn: DynamicsCache, mean: Array, cov: Array, t: float, tk: float
                     ) -> tuple[Array, Array, float]:
    """Move a Gaussian from ``t`` to ``tk`` (s) as :meth:`TrackingFilter.predict` does.

    The predicted covariance is not symmetrised: it only enters the update, whose result is.

    Parameters
    ----------
    dyn : DynamicsCache
        The dynamics' ``Phi`` and ``Q`` per step size.
    mean, cov : numpy.ndarray
        State ``(n,)`` and covariance ``(n, n)`` at ``t``.
    t, tk : float
        Times (s).

    Returns
    -------
    mean, cov, time
        At ``max(t, tk)``.

    Raises
    ------
    ValueError
        If ``tk`` is earlier than ``t`` (beyond :data:`TIME_TOLERANCE`).
    """
    dt = tk - t
    if dt > TIME_TOLERANCE:
        phi, phit, q = dyn.get(dt)
        p = phi.dot(cov).dot(phit)
        p += q
        return phi.dot(mean), p, tk
    if dt < -TIME_TOLERANCE:
        raise ValueError(f"filters run forward: cannot predict from t={t} s back to t={tk} s")
    return mean, cov, max(t, tk)
