"""The Gaussian-sum filter's hot loops, compiled: components moved, split, updated, reduced.

The one implementation of the arithmetic of :class:`tmakit.filters.GaussianSumFilter`.

References
----------
Leong, Arulampalam, Lamahewa & Abhayapala (2014), IEEE SPL 21(5); DeMars, Bishop & Jah
(2013), J. Guid. Control Dyn. 36(4); Salmond (1990), SPIE 1305; Peach (1995).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.arrays import Array, BoolArray, IntArray
from .ekf import IEKF_TOL, LOG_2PI

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

SPLIT_WEIGHT = 0.2252246249
SPLIT_OFFSET = 1.0575154615
SPLIT_VARIANCE = 1.0 - 2.0 * SPLIT_WEIGHT * SPLIT_OFFSET**2
TWO_PI = 2.0 * math.pi


@_jit
def predict_sum(m: Array, p: Array, count: int, dt: float, dim: int, qa: Array,
                qd: Array) -> None:  # pragma: no cover - compiled
    """Move ``count`` components ``dt`` s forward (nearly constant velocity, in place)."""
    dt2 = dt * dt
    for i in range(count):
        for a in range(dim):
            m[i, a] += dt * m[i, dim + a]
        n = 2 * dim
        # P <- Phi P Phi^T: rows then columns (position += dt velocity).
        for a in range(dim):
            for c in range(n):
                p[i, a, c] += dt * p[i, dim + a, c]
        for a in range(dim):
            for r in range(n):
                p[i, r, a] += dt * p[i, r, dim + a]
        for a in range(dim):
            q2 = qa[a] * qa[a]
            p[i, a, a] += 0.25 * dt2 * dt2 * q2 + dt2 * dt / 3.0 * qd[a]
            cross = 0.5 * dt2 * dt * q2 + 0.5 * dt2 * qd[a]
            p[i, a, dim + a] += cross
            p[i, dim + a, a] += cross
            p[i, dim + a, dim + a] += dt2 * q2 + dt * qd[a]


@_inline
def _principal(p: Array, i: int, dim: int) -> tuple[float, Array]:  # pragma: no cover
    """Give the largest variance of the position block of ``p[i]`` and its unit axis."""
    block = np.empty((dim, dim))
    for a in range(dim):
        for b in range(dim):
            block[a, b] = p[i, a, b]
    vals, vecs = np.linalg.eigh(block)
    return vals[dim - 1], vecs[:, dim - 1].copy()


@_jit
def split_sum(w: Array, m: Array, p: Array, origin: IntArray, count: int, sensor: Array,
              dim: int, threshold: float, capacity: int) -> int:  # pragma: no cover - compiled
    """Split the components too spread for their range (children keep their ``origin``)."""
    if threshold <= 0.0 or count + 2 > capacity:
        return count
    order = np.argsort(-w[:count])
    n = 2 * dim
    start = count
    for k in range(start):
        if count + 2 > capacity:
            break
        i = order[k]
        r2 = 0.0
        for a in range(dim):
            d = m[i, a] - sensor[a]
            r2 += d * d
        var, axis = _principal(p, i, dim)
        if not (var > threshold * threshold * r2):
            continue
        sd = math.sqrt(var)
        s = np.zeros(n)
        for r in range(n):
            acc = 0.0
            for a in range(dim):
                acc += p[i, r, a] * axis[a]
            s[r] = acc / sd
        shrink = 1.0 - SPLIT_VARIANCE
        for r in range(n):
            for c in range(n):
                p[i, r, c] -= shrink * s[r] * s[c]
        wi = w[i]
        for side in range(2):
            j = count + side
            sign = 2.0 * side - 1.0
            w[j] = SPLIT_WEIGHT * wi
            origin[j] = origin[i]
            for r in range(n):
                m[j, r] = m[i, r] + sign * SPLIT_OFFSET * s[r]
                for c in range(n):
                    p[j, r, c] = p[i, r, c]
        w[i] = (1.0 - 2.0 * SPLIT_WEIGHT) * wi
        count += 2
    return count


@_inline
def _copy_component(m: Array, p: Array, i: int, to_m: Array, to_p: Array,
                    j: int) -> None:  # pragma: no cover - compiled
    # element by element: an array assignment compiles numba's shape check and its message
    n = m.shape[1]
    for r in range(n):
        to_m[j, r] = m[i, r]
        for c in range(n):
            to_p[j, r, c] = p[i, r, c]


@_inline
def _prune(w: Array, m: Array, p: Array, origin: IntArray, count: int,
           prune: float) -> int:  # pragma: no cover - compiled
    """Drop the components lighter than ``prune`` of the heaviest; give the new count."""
    top = 0.0
    for i in range(count):
        top = max(top, w[i])
    keep = 0
    for i in range(count):
        if w[i] >= prune * top and w[i] > 0.0:
            if keep != i:
                w[keep] = w[i]
                _copy_component(m, p, i, m, p, keep)
                origin[keep] = origin[i]
            keep += 1
    return keep


@_inline
def _whitened_distance2(chol: Array, m: Array, i: int, j: int,
                        d: Array) -> float:  # pragma: no cover - compiled
    """Give ``|L^-1 (m_j - m_i)|^2`` (``L L^T = P_i``) by forward substitution, ``d`` its work."""
    d2 = 0.0
    for r in range(m.shape[1]):
        acc = m[j, r] - m[i, r]
        for c in range(r):
            acc -= chol[r, c] * d[c]
        d[r] = acc / chol[r, r]
        d2 += d[r] * d[r]
    return d2


@_inline
def _members_moments(w: Array, m: Array, p: Array, members: list[int], mean: Array, cov: Array,
                     d: Array) -> float:  # pragma: no cover - compiled
    """Write the moments of the members' mixture (law of total covariance); give their weight."""
    n = m.shape[1]
    wt = 0.0
    mean[:] = 0.0
    for j in members:
        wt += w[j]
        for r in range(n):
            mean[r] += w[j] * m[j, r]
    for r in range(n):
        mean[r] /= wt
    cov[:, :] = 0.0
    for j in members:
        for r in range(n):
            d[r] = m[j, r] - mean[r]
        for r in range(n):
            for c in range(n):
                cov[r, c] += w[j] * (p[j, r, c] + d[r] * d[c])
    for r in range(n):
        cov[r, r] /= wt
        for c in range(r + 1, n):
            v = 0.5 * (cov[r, c] + cov[c, r]) / wt
            cov[r, c] = v
            cov[c, r] = v
    return wt


@_inline
def _merge(w: Array, m: Array, p: Array, origin: IntArray, count: int,
           merge: float) -> int:  # pragma: no cover - compiled
    """Merge, heaviest first, the components near each (Salmond 1990); give the new count.

    A merged component's ``origin`` is its heaviest member's.
    """
    n = m.shape[1]
    order = np.argsort(-w[:count])
    used = np.zeros(count, dtype=np.bool_)
    nw = np.empty(count)
    nm = np.empty((count, n))
    npp = np.empty((count, n, n))
    norigin = np.empty(count, dtype=origin.dtype)
    d = np.empty(n)
    out = 0
    for oi in range(count):
        i = order[oi]
        if used[i]:
            continue
        used[i] = True
        chol = np.linalg.cholesky(p[i])
        members = [i]
        for oj in range(oi + 1, count):
            j = order[oj]
            if not used[j]:
                if _whitened_distance2(chol, m, i, j, d) < merge:
                    used[j] = True
                    members.append(j)
        nw[out] = _members_moments(w, m, p, members, nm[out], npp[out], d)
        norigin[out] = origin[i]
        out += 1
    for i in range(out):
        w[i] = nw[i]
        _copy_component(nm, npp, i, m, p, i)
        origin[i] = norigin[i]
    return out


@_jit
def reduce_sum(w: Array, m: Array, p: Array, origin: IntArray, count: int, prune: float,
               merge: float) -> int:  # pragma: no cover - compiled
    """Prune, merge and normalise."""
    total = 0.0
    for i in range(count):
        total += w[i]
    if not total > 0.0:
        return 0
    count = _prune(w, m, p, origin, count, prune)
    if merge > 0.0 and count > 1:
        count = _merge(w, m, p, origin, count, merge)
    total = 0.0
    for i in range(count):
        total += w[i]
    for i in range(count):
        w[i] /= total
    return count


@_jit
def sum_moments(w: Array, m: Array, p: Array, count: int, mean: Array,
                cov: Array) -> None:  # pragma: no cover - compiled
    """Write the sum's mean and covariance."""
    _members_moments(w, m, p, list(range(count)), mean, cov, np.empty(m.shape[1]))


@_inline
def _wrap(a: float) -> float:  # pragma: no cover - compiled
    r = a - TWO_PI * math.floor((a + math.pi) / TWO_PI)
    return math.pi if r == -math.pi else r


@_inline
def _ekf_bearing(m: Array, p: Array, i: int, z: float, var: float, sx: float, sy: float,
                 iterations: int) -> tuple[float, float, bool]:  # pragma: no cover - compiled
    """Update component ``i`` with one bearing, as ``ExtendedKalmanFilter.update_gaussian`` does.

    Iterated (Bell & Cathey 1993); innovation and variance are the last linearisation's.
    """
    prior = m[i].copy()
    x = prior.copy()
    nu0, s0 = 0.0, 0.0  # the last linearisation's
    k = np.zeros(4)
    c = np.zeros(4)
    for it in range(iterations):
        dx = x[0] - sx
        dy = x[1] - sy
        r2 = dx * dx + dy * dy
        if not (r2 > 0.0 and math.isfinite(r2)):
            if it == 0:
                return 0.0, 0.0, False
            break
        h0 = dy / r2
        h1 = -dx / r2
        ci = p[i, :, 0] * h0 + p[i, :, 1] * h1
        s = ci[0] * h0 + ci[1] * h1 + var
        if not (s > 0.0 and math.isfinite(s)):
            if it == 0:
                return 0.0, 0.0, False
            break
        nu = _wrap(z - math.atan2(dx, dy)) - h0 * (prior[0] - x[0]) - h1 * (prior[1] - x[1])
        nu0, s0 = nu, s
        c = ci
        k = c / s
        new = prior + k * nu
        move = math.hypot(new[0] - x[0], new[1] - x[1])
        x = new
        if move < IEKF_TOL * math.sqrt(r2):
            break
    for r in range(4):
        m[i, r] = x[r]
        for cc in range(4):
            p[i, r, cc] -= k[r] * c[cc]
    return nu0, s0, True


@_inline
def _sigma_bearing(m: Array, p: Array, i: int, z: float, var: float, sx: float, sy: float,
                   sp: Array) -> tuple[float, float, bool]:  # pragma: no cover - compiled
    """Update component ``i`` with one bearing (sigma points ``sp = (gamma, Wm0, Wc0, Wi)``)."""
    gamma, wm0, wc0, wi = sp[0], sp[1], sp[2], sp[3]
    n = 4
    for a in range(n):
        if not p[i, a, a] > 0.0:
            return 0.0, 0.0, False
    chol = np.linalg.cholesky(p[i])
    pts = np.empty((2 * n + 1, n))
    for a in range(n):
        pts[0, a] = m[i, a]
        for j in range(n):
            pts[1 + j, a] = m[i, a] + gamma * chol[a, j]
            pts[1 + n + j, a] = m[i, a] - gamma * chol[a, j]
    zs = np.empty(2 * n + 1)
    cs = 0.0
    sn = 0.0
    for j in range(2 * n + 1):
        zs[j] = math.atan2(pts[j, 0] - sx, pts[j, 1] - sy)
        wj = wm0 if j == 0 else wi
        cs += wj * math.cos(zs[j])
        sn += wj * math.sin(zs[j])
    if not cs * cs + sn * sn > 1e-24:
        return 0.0, 0.0, False
    zbar = math.atan2(sn, cs)
    s = var
    pxz = np.zeros(n)
    for j in range(2 * n + 1):
        e = _wrap(zs[j] - zbar)
        wj = wc0 if j == 0 else wi
        s += wj * e * e
        for a in range(n):
            pxz[a] += wj * e * (pts[j, a] - m[i, a])
    if not (s > 0.0 and math.isfinite(s)):
        return 0.0, 0.0, False
    nu = _wrap(z - zbar)
    k = pxz / s
    for r in range(n):
        m[i, r] += k[r] * nu
    for r in range(n):
        for c in range(n):
            p[i, r, c] -= k[r] * pxz[c]
    for r in range(n):
        for c in range(r + 1, n):
            v = 0.5 * (p[i, r, c] + p[i, c, r])
            p[i, r, c] = v
            p[i, c, r] = v
    return nu, s, True


@_inline
def _reweight(w: Array, nus: Array, ss: Array, oks: BoolArray,
              count: int) -> tuple[bool, float, float]:  # pragma: no cover - compiled
    """Multiply the weights by ``N(nu_i; 0, S_i)``; give ok, log-likelihood, NIS of the sum."""
    top = -np.inf
    for i in range(count):
        if oks[i]:
            top = max(top, math.log(w[i]) - 0.5 * (nus[i] * nus[i] / ss[i] + math.log(ss[i])))
    if not math.isfinite(top):
        return False, 0.0, np.nan
    nbar = 0.0
    for i in range(count):
        nbar += w[i] * nus[i] if oks[i] else 0.0
    sbar = 0.0
    for i in range(count):
        if oks[i]:
            d = nus[i] - nbar
            sbar += w[i] * (ss[i] + d * d)
    total = 0.0
    for i in range(count):
        if oks[i]:
            w[i] = math.exp(math.log(w[i]) - 0.5 * (nus[i] * nus[i] / ss[i] + math.log(ss[i]))
                            - top)
        else:
            w[i] = 0.0
        total += w[i]
    return True, top + math.log(total) - 0.5 * LOG_2PI, nbar * nbar / sbar


@_jit
def gsf_bearing_2d(w: Array, m: Array, p: Array, origin: IntArray, count: int, time: float,
                   times: Array, bearings: Array, variances: Array, sensors: Array, qa: Array,
                   qd: Array, sigma_points: Array, settings: Array, out_mean: Array,
                   out_cov: Array, out_nis: Array, out_ll: Array, out_count: Array,
                   kept: tuple[Array, Array, Array, IntArray]
                   ) -> tuple[int, float, int]:  # pragma: no cover - compiled
    """Run the Gaussian-sum filter over single bearings in 2-D, one call for a whole track.

    ``kept`` (weights, means, covariances, origins; each ``(K, capacity, ...)``, or empty)
    receives the sum after each update, its components' origins indexing the previous one's.
    """
    capacity = w.shape[0]
    threshold, prune, merge, iterations = settings[0], settings[1], settings[2], int(settings[3])
    ekf = sigma_points.shape[0] == 0
    t = time
    skipped = 0
    nus = np.empty(capacity)
    ss = np.empty(capacity)
    oks = np.empty(capacity, dtype=np.bool_)
    sensor = np.zeros(2)
    for k in range(times.shape[0]):
        dt = times[k] - t
        if dt > 0.0:
            predict_sum(m, p, count, dt, 2, qa, qd)
            t = times[k]
        sensor[0] = sensors[k, 0]
        sensor[1] = sensors[k, 1]
        for i in range(count):
            origin[i] = i
        count = split_sum(w, m, p, origin, count, sensor, 2, threshold, capacity)
        z, var = bearings[k], variances[k]
        for i in range(count):
            if ekf:
                nu, s, ok = _ekf_bearing(m, p, i, z, var, sensor[0], sensor[1], iterations)
            else:
                nu, s, ok = _sigma_bearing(m, p, i, z, var, sensor[0], sensor[1],
                                           sigma_points)
            nus[i], ss[i], oks[i] = nu, s, ok
        ok, ll, nis = _reweight(w, nus, ss, oks, count)
        out_ll[k], out_nis[k] = ll, nis
        if ok:
            count = reduce_sum(w, m, p, origin, count, prune, merge)
        else:
            skipped += 1
        sum_moments(w, m, p, count, out_mean[k], out_cov[k])
        out_count[k] = count
        if kept[0].shape[0]:
            for i in range(count):
                kept[0][k, i] = w[i]
                _copy_component(m, p, i, kept[1][k], kept[2][k], i)
                kept[3][k, i] = origin[i]
    return count, t, skipped
