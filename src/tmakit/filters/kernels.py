"""Closed-form step kernels for the commonest tracking problem.

That problem is one bearing per update and a 2-D nearly-constant-velocity state ``[x, y, vx, vy]``
(predict of Chen & Sun, §2.1, written out entry by entry).  A step whose numbers are not clearly
valid (target at the sensor, a non-positive innovation variance, LDL^T pivots below
:data:`PIVOT_FLOOR`, ...) is not taken here: the kernel stops and the filter does that step on
the general path, whose covariance repair always returns a positive semi-definite matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.arrays import Array
from ..observation.groups import TIME_TOLERANCE

TWO_PI = 2.0 * math.pi
LOG_2PI = math.log(TWO_PI)
#: LDL^T pivots of an updated covariance must exceed this fraction of the matching diagonal
#: entry, else the step goes to the general path (with its covariance repair).
PIVOT_FLOOR = 1e-13
#: Iterated-EKF stopping rule (as :data:`tmakit.filters.ekf.IEKF_TOL`).
IEKF_TOL = 1e-10

# Upper-triangle order of the ten covariance entries of a 4-state filter.
_IU = np.triu_indices(4)


@dataclass
class KernelRun:
    """What a kernel did."""

    stop: int  # Index of the first update it did not do (the number of updates when it finished)
    #: True when it stopped after predicting to update ``stop`` (the caller then updates on the
    #: general path)
    predicted: bool
    mean: Array  # Final state ``(4,)`` (m, m/s)
    covariance: Array  # Final covariance ``(4, 4)``
    time: float  # Final time (s)
    log_likelihood: float  # Final cumulative log-likelihood (nats)
    #: times, states, covariances, nis, log_likelihoods: Per-update outputs of the updates it did:
    #: times ``(k,)`` (s), states ``(k, 4)``, covariances ``(k, 4, 4)``, NIS ``(k,)`` and cumulative
    #: log-likelihoods ``(k,)``
    times: Array
    states: Array
    covariances: Array
    nis: Array
    log_likelihoods: Array
    dof: Array | None = None  # Degrees of freedom of each update ``(k,)`` (None: one row each)
    #: True for a run of the general path (:mod:`.general`), not a closed-form kernel
    general: bool = False


def wrap(a: float) -> float:
    """Wrap an angle to (-pi, pi] (the convention of :func:`tmakit.core.frames.wrap_angle`)."""
    r = math.remainder(a, TWO_PI)
    return math.pi if r == -math.pi else r


def _pd4(m00: float, m01: float, m02: float, m03: float, m11: float, m12: float, m13: float,
         m22: float, m23: float, m33: float) -> bool:
    """Tell whether a symmetric 4x4 matrix is clearly positive definite."""
    f = PIVOT_FLOOR
    if not m00 > f * abs(m00) or not math.isfinite(m00):
        return False
    i0 = 1.0 / m00
    s11 = m11 - m01 * m01 * i0
    if not s11 > f * abs(m11):
        return False
    s12 = m12 - m01 * m02 * i0
    s13 = m13 - m01 * m03 * i0
    s22 = m22 - m02 * m02 * i0
    s23 = m23 - m02 * m03 * i0
    s33 = m33 - m03 * m03 * i0
    i1 = 1.0 / s11
    t22 = s22 - s12 * s12 * i1
    if not t22 > f * abs(m22):
        return False
    t23 = s23 - s12 * s13 * i1
    t33 = s33 - s13 * s13 * i1
    d3 = t33 - t23 * t23 / t22
    return bool(d3 > f * abs(m33)) and math.isfinite(d3)


def _unpack(mean: Array, cov: Array) -> tuple[list[float], list[float]]:
    return [float(v) for v in mean], [float(v) for v in cov[_IU]]


def _finish(stop: int, predicted: bool, x: list[float], p: list[float], t: float, ll: float,
            times: list, states: list, covs: list, nis: list, lls: list) -> KernelRun:
    cov = np.zeros((4, 4))
    cov[_IU] = p
    cov = cov + np.triu(cov, 1).T
    k = len(states)
    cov_rows = np.zeros((k, 4, 4))
    if k:
        up = np.array(covs, dtype=float)
        cov_rows[:, _IU[0], _IU[1]] = up
        cov_rows[:, _IU[1], _IU[0]] = up
    return KernelRun(stop, predicted, np.array(x, dtype=float), cov, t, ll,
                     np.array(times, dtype=float), np.array(states, dtype=float).reshape(k, 4),
                     cov_rows, np.array(nis, dtype=float), np.array(lls, dtype=float))


def ekf_bearing_2d(mean: Array, cov: Array, time: float, ll: float, start: int,
                   columns: tuple[list[float], ...], q2: tuple[float, ...],
                   iterations: int = 1) -> KernelRun:
    """Run EKF steps from update ``start`` on, one bearing per update, 2-D.

    References
    ----------
    Chen & Sun, §2.1 (the dynamics).
    """
    return _bearing_2d(mean, cov, time, ll, start, columns, q2, iterations, None)


def ukf_bearing_2d(mean: Array, cov: Array, time: float, ll: float, start: int,
                   columns: tuple[list[float], ...], q2: tuple[float, ...],
                   weights: tuple[float, float, float, float]) -> KernelRun:
    """Run UKF steps from update ``start`` on, one bearing per update, 2-D.

    References
    ----------
    Chen & Sun, §2.1 (the dynamics); Wan & van der Merwe (2000) (the weights).
    """
    return _bearing_2d(mean, cov, time, ll, start, columns, q2, 1, weights)


# Complexity 23 > 15 on purpose: one loop with branches, not per-step helper calls (see the
# docstring); listed in tests/test_architecture.py's LONG_FUNCTION_EXCEPTIONS.
def _bearing_2d(mean: Array, cov: Array, time: float, ll: float, start: int,  # noqa: C901
                columns: tuple[list[float], ...], q2: tuple[float, ...], iterations: int,
                weights: tuple[float, float, float, float] | None) -> KernelRun:
    """Run the loop of both kernels."""
    times, zs, vs, sxs, sys_ = columns
    qx2, qy2, qdx, qdy = q2
    ukf = weights is not None
    if weights is not None:
        gamma, wm0, wc0, wi = weights
        wmc = wm0 + 4.0 * wi  # the centre and the four velocity-only points
        wcc = wc0 + 4.0 * wi
    (x0, x1, x2, x3), (p00, p01, p02, p03, p11, p12, p13, p22, p23, p33) = _unpack(mean, cov)
    t = float(time)
    tout: list = []
    states: list = []
    covs: list = []
    nis_out: list = []
    ll_out: list = []
    remainder, atan2, log, sqrt = math.remainder, math.atan2, math.log, math.sqrt
    cos, sin = math.cos, math.sin
    k = start
    n = len(times)
    # Every ``break`` below is a step not taken here: the state stays predicted to it.
    predicted = True
    while k < n:
        tk = times[k]
        dt = tk - t
        if dt > TIME_TOLERANCE:
            x0 += dt * x2
            x1 += dt * x3
            dt2 = dt * dt
            g = 0.25 * dt2 * dt2
            c = 0.5 * dt2 * dt
            g3 = dt2 * dt / 3.0
            c3 = 0.5 * dt2
            p00 += 2.0 * dt * p02 + dt2 * p22 + g * qx2 + g3 * qdx
            p01 += dt * (p03 + p12) + dt2 * p23
            p11 += 2.0 * dt * p13 + dt2 * p33 + g * qy2 + g3 * qdy
            p02 += dt * p22 + c * qx2 + c3 * qdx
            p03 += dt * p23
            p12 += dt * p23
            p13 += dt * p33 + c * qy2 + c3 * qdy
            p22 += dt2 * qx2 + dt * qdx
            p33 += dt2 * qy2 + dt * qdy
        if tk > t:
            t = tk
        if ukf:
            # Cholesky factor of P (lower); the sigma points need its first two columns.
            if not (p00 > 0.0 and math.isfinite(p00)):
                break
            l00 = sqrt(p00)
            l10 = p01 / l00
            l20 = p02 / l00
            l30 = p03 / l00
            d = p11 - l10 * l10
            if not d > 0.0:
                break
            l11 = sqrt(d)
            l21 = (p12 - l20 * l10) / l11
            l31 = (p13 - l30 * l10) / l11
            d = p22 - l20 * l20 - l21 * l21
            if not d > 0.0:
                break
            l22 = sqrt(d)
            l32 = (p23 - l30 * l20 - l31 * l21) / l22
            if not p33 - l30 * l30 - l31 * l31 - l32 * l32 > 0.0:
                break
            dx = x0 - sxs[k]
            dy = x1 - sys_[k]
            u0 = gamma * l00
            u1 = gamma * l10
            v1 = gamma * l11
            zc = atan2(dx, dy)
            zap = atan2(dx + u0, dy + u1)
            zam = atan2(dx - u0, dy - u1)
            zbp = atan2(dx, dy + v1)
            zbm = atan2(dx, dy - v1)
            cs = wmc * cos(zc) + wi * (cos(zap) + cos(zam) + cos(zbp) + cos(zbm))
            sn = wmc * sin(zc) + wi * (sin(zap) + sin(zam) + sin(zbp) + sin(zbm))
            if not cs * cs + sn * sn > 1e-24:
                break
            zbar = atan2(sn, cs)
            ec = remainder(zc - zbar, TWO_PI)
            eap = remainder(zap - zbar, TWO_PI)
            eam = remainder(zam - zbar, TWO_PI)
            ebp = remainder(zbp - zbar, TWO_PI)
            ebm = remainder(zbm - zbar, TWO_PI)
            s = wcc * ec * ec + wi * (eap * eap + eam * eam + ebp * ebp + ebm * ebm) + vs[k]
            if not (s > 0.0 and math.isfinite(s)):
                break
            fa = wi * gamma * (eap - eam)
            fb = wi * gamma * (ebp - ebm)
            c0 = l00 * fa
            c1 = l10 * fa + l11 * fb
            c2 = l20 * fa + l21 * fb
            c3 = l30 * fa + l31 * fb
            inv = 1.0 / s
            nu = remainder(zs[k] - zbar, TWO_PI)
        else:
            dx = x0 - sxs[k]
            dy = x1 - sys_[k]
            r2 = dx * dx + dy * dy
            if not (r2 > 0.0 and math.isfinite(r2)):
                break
            h0 = dy / r2
            h1 = -dx / r2
            c0 = p00 * h0 + p01 * h1
            c1 = p01 * h0 + p11 * h1
            c2 = p02 * h0 + p12 * h1
            c3 = p03 * h0 + p13 * h1
            hph = h0 * c0 + h1 * c1
            s = hph + vs[k]
            if not (hph >= 0.0 and s > 0.0 and math.isfinite(s)):
                break
            inv = 1.0 / s
            nu = remainder(zs[k] - atan2(dx, dy), TWO_PI)
        if nu == -math.pi:
            nu = math.pi
        gain = nu * inv
        nis = nu * gain
        ll_k = -0.5 * (nis + log(s) + LOG_2PI)
        y0 = x0 + c0 * gain
        y1 = x1 + c1 * gain
        y2 = x2 + c2 * gain
        y3 = x3 + c3 * gain
        if iterations > 1:
            # Iterated EKF: relinearise at the latest estimate y (the gain column is that of
            # the last linearisation; NIS and log-likelihood stay those of the first).  The
            # linearisation repeats the EKF's above, at y instead of x, on purpose: a helper
            # shared by both costs the plain EKF ~3 % per step (measured), it is the hot path.
            # Both mirror ExtendedKalmanFilter's iterated update (filters/ekf.py); pinned equal
            # by tests/test_filters.py::test_bearing_kernels_equal_the_general_path.
            ok = True
            for _ in range(iterations - 1):
                ex = y0 - sxs[k]
                ey = y1 - sys_[k]
                e2 = ex * ex + ey * ey
                if not (e2 > 0.0 and math.isfinite(e2)):
                    break
                g0 = ey / e2
                g1 = -ex / e2
                b0 = p00 * g0 + p01 * g1
                b1 = p01 * g0 + p11 * g1
                b2 = p02 * g0 + p12 * g1
                b3 = p03 * g0 + p13 * g1
                gpg = g0 * b0 + g1 * b1
                si = gpg + vs[k]
                if not (gpg >= 0.0 and si > 0.0 and math.isfinite(si)):
                    ok = False
                    break
                nui = remainder(zs[k] - atan2(ex, ey), TWO_PI)
                if nui == -math.pi:
                    nui = math.pi
                nui -= g0 * (x0 - y0) + g1 * (x1 - y1)
                gi = nui / si
                z0 = x0 + b0 * gi
                z1 = x1 + b1 * gi
                step = math.hypot(z0 - y0, z1 - y1)
                y0, y1, y2, y3 = z0, z1, x2 + b2 * gi, x3 + b3 * gi
                c0, c1, c2, c3, inv = b0, b1, b2, b3, 1.0 / si
                ez0 = y0 - sxs[k]
                ez1 = y1 - sys_[k]
                if step <= IEKF_TOL * math.sqrt(ez0 * ez0 + ez1 * ez1):
                    break
            if not ok:
                break
        n00 = p00 - c0 * c0 * inv
        n01 = p01 - c0 * c1 * inv
        n02 = p02 - c0 * c2 * inv
        n03 = p03 - c0 * c3 * inv
        n11 = p11 - c1 * c1 * inv
        n12 = p12 - c1 * c2 * inv
        n13 = p13 - c1 * c3 * inv
        n22 = p22 - c2 * c2 * inv
        n23 = p23 - c2 * c3 * inv
        n33 = p33 - c3 * c3 * inv
        if not _pd4(n00, n01, n02, n03, n11, n12, n13, n22, n23, n33):
            break
        # Plain assignments: a tuple assignment builds and unpacks a tuple (slower here).
        x0 = y0
        x1 = y1
        x2 = y2
        x3 = y3
        p00 = n00
        p01 = n01
        p02 = n02
        p03 = n03
        p11 = n11
        p12 = n12
        p13 = n13
        p22 = n22
        p23 = n23
        p33 = n33
        ll += ll_k
        tout.append(t)
        states.append((x0, x1, x2, x3))
        covs.append((p00, p01, p02, p03, p11, p12, p13, p22, p23, p33))
        nis_out.append(nis)
        ll_out.append(ll)
        k += 1
    else:
        predicted = False
    return _finish(k, predicted, [x0, x1, x2, x3],
                   [p00, p01, p02, p03, p11, p12, p13, p22, p23, p33], t, ll, tout, states, covs,
                   nis_out, ll_out)
