"""A regularised SIR particle filter, vectorised over particles.

Sampling importance resampling with the transitional prior as importance density (Hurtado &
Nehorai (2008), §3.1, eq. 8 with ``q = p(x_k | x_{k-1})``), systematic resampling when the
effective sample size falls below a fraction of ``N``, then regularisation (Musso, Oudjane & Le
Gland (2001); Liu & West (2001)).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Self, Unpack, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.linalg import nearest_psd, safe_cholesky, solve_spd, symmetrise
from ..motion.dynamics import NearlyConstantVelocity
from ..observation.groups import MeasurementGroup
from .base import FilterSettings, KindOptions, ProcessNoise, TrackingFilter, whole_number
from .bearing_prior import BearingPrior, FirstBearing
from .ekf import LOG_2PI
from .track import UpdateInfo

#: Log-weights this far below the largest are zero weights (:meth:`ParticleFilter._normalise`).
LOG_NEGLIGIBLE = -575.0


@dataclass(frozen=True)
class ParticleStep:
    """The weighted cloud after one update, and what the resampling after it did."""

    time: float  # (s)
    particles: Array  # (n, N) (m, m/s)
    weights: Array  # (N,), normalised
    shrink: float = 1.0  # the regularisation's shrinkage a (1: none)
    centre: Array | None = None  # the cloud's mean the shrinkage pulls towards
    jitter: Array | None = None  # the kernel's covariance h^2 C added after resampling


def optimal_bandwidth(n_particles: int, n_state: int) -> float:
    """Give the optimal Gaussian-kernel bandwidth (Musso, Oudjane & Le Gland 2001)."""
    return float((4.0 / (n_particles * (n_state + 2))) ** (1.0 / (n_state + 4)))


def systematic_resample(weights: Array, u: float) -> NDArray[np.int64]:
    """Draw a systematic resample of normalised weights."""
    n = weights.shape[0]
    cdf = np.cumsum(weights)
    cdf *= n / cdf[-1]
    cdf -= u
    np.floor(cdf, out=cdf)
    np.minimum(cdf, n - 1, out=cdf)
    cdf[-1] = n - 1  # cdf[j] + 1: the copies of particles 0..j
    counts = np.empty(n, np.int64)
    counts[0] = cdf[0] + 1
    np.subtract(cdf[1:], cdf[:-1], out=counts[1:], casting="unsafe")
    return np.repeat(np.arange(n), counts)


class ParticleFilter(TrackingFilter):
    """Regularised SIR particle filter.

    Parameters
    ----------
    mean, covariance, time
        The Gaussian prior the first cloud is drawn from, as for
        :class:`~tmakit.filters.TrackingFilter` (m, m/s; s).
    particles : int, optional
        Number of particles N (>= 2).
    bearing_start : tuple of (BearingPrior, FirstBearing), optional
        Draw the first cloud from this bearing prior instead (:meth:`from_first_bearing`).
    history : bool, optional
        Keep the weighted cloud after each update, for the particle smoother
        (:func:`tmakit.filters.smooth`); N x n floats per update.
    rng : numpy.random.Generator, int or None, optional
        Random source or seed.
    resample_threshold : float, optional
        Resample when the effective sample size is below this fraction of N, in (0, 1].
    regularise : bool, optional
        Move the particles by the regularisation kernel after each resampling.
    bandwidth : float, optional
        Multiple of the optimal kernel bandwidth (> 0; ``h`` must stay below 1).
    q, dynamics, options, nuisance
        As for :class:`~tmakit.filters.TrackingFilter`.

    Attributes
    ----------
    resamples : int
        Resampling steps made.
    h : float
        Kernel bandwidth (dimensionless).

    Raises
    ------
    ValueError
        A setting out of its range, a kernel bandwidth ``h`` >= 1, or a prior that is not valid.

    References
    ----------
    Hurtado & Nehorai (2008), §3.1, eqs. 7-8 (SIR with the transitional prior); Musso,
    Oudjane & Le Gland (2001) and Liu & West (2001) (regularisation).
    """

    name = "pf"
    takes_particles = True
    single_blas_thread = True
    takes_rng = True

    def __init__(self, mean: ArrayLike, covariance: ArrayLike, time: float = 0.0, *,
                 particles: int = 1000, rng: np.random.Generator | int | None = None,
                 resample_threshold: float = 0.5, regularise: bool = True,
                 bandwidth: float = 1.0, q: ProcessNoise = 0.0,
                 dynamics: NearlyConstantVelocity | None = None,
                 options: KindOptions | None = None,
                 nuisance: Mapping[str, float] | None = None,
                 history: bool = False,
                 bearing_start: tuple[BearingPrior, FirstBearing] | None = None) -> None:
        self._start_prior = bearing_start
        #: The weighted clouds after each update (with ``history=True``), for the smoother.
        self.history: list[ParticleStep] | None = [] if history else None
        self.n_particles = whole_number(particles, "particles", 2)
        if not (0.0 < float(resample_threshold) <= 1.0):
            raise ValueError("resample_threshold must be in (0, 1] (a fraction of the "
                             f"particle count); got {resample_threshold}")
        if not (math.isfinite(bandwidth) and bandwidth > 0):
            raise ValueError(f"bandwidth must be > 0; got {bandwidth}")
        self.rng = np.random.default_rng(rng)
        self.resample_threshold = float(resample_threshold)
        self.regularise = bool(regularise)
        self.bandwidth = float(bandwidth)
        self.resamples = 0
        super().__init__(mean, covariance, time, q=q, dynamics=dynamics, options=options,
                         nuisance=nuisance)
        self.h = self.bandwidth * optimal_bandwidth(self.n_particles, 2 * self.dim)
        if self.regularise and self.h >= 1.0:
            raise ValueError(f"bandwidth {bandwidth} gives a kernel bandwidth h = {self.h:.3g}"
                             " >= 1 (the shrinkage needs h < 1); use a smaller bandwidth or "
                             "more particles")
        axes, self._q_density = self.dynamics.axes()
        self._q = axes.copy()
        self._any_q = bool(np.any(axes > 0))
        self._any_density = bool(np.any(self._q_density > 0))
        self._equal_q = bool(np.all(axes == axes[0]))
        self._ncv = type(self.dynamics) is NearlyConstantVelocity
        # With white-noise-acceleration density the move is compiled, and every normal is then
        # drawn by numba from the same Generator (the same numbers as NumPy's fill, 2-3x
        # faster); other filters draw by NumPy and never load numba (~0.7 s the first time).
        self._compiled = self._ncv and self._any_density

    @classmethod
    def from_first_bearing(cls, prior: BearingPrior, first: FirstBearing, dim: int = 2,
                           **settings: Unpack[FilterSettings]) -> Self:
        """Start from particles drawn from a bearing prior (:meth:`BearingPrior.sample`).

        Takes the base's parameters (:meth:`TrackingFilter.from_first_bearing`), but
        ``bearing_start``.

        Raises
        ------
        TypeError
            If ``bearing_start`` is given too, or the class takes no keyword of that name.
        """
        if "bearing_start" in settings:
            raise TypeError("from_first_bearing() got bearing_start: the start is the prior "
                            "and first bearing given")
        mean, cov = prior.gaussian(first, dim)
        return cls._made(mean, cov, first.time, {**settings, "bearing_start": (prior, first)})

    # -- state --------------------------------------------------------------------------------
    def _init_state(self, mean: Array, covariance: Array) -> None:
        n, n_p = mean.shape[0], self.n_particles
        if self._start_prior is not None:
            prior, first = self._start_prior
            x = prior.sample(first, n_p, self.rng, n // 2).T
        else:
            x = safe_cholesky(covariance) @ self.rng.standard_normal((n, n_p))
            x += mean[:, None]
        self._x = np.ascontiguousarray(x)  # (n, N): one row per state component
        self._w = np.full(n_p, 1.0 / n_p)
        self._logw = np.full(n_p, -math.log(n_p))
        if self.history is not None:
            self.history.append(ParticleStep(self.time, self._x.copy(), self._w.copy()))
        self._uniform = True
        self._moments: tuple[Array, Array] | None = None
        # Work arrays, reused at every step: fresh ones for every operation cost more in
        # memory traffic than the arithmetic on 10^4 particles.
        self._work = np.empty((3, n_p))
        self._w_spare = np.empty(n_p)
        self._logw_spare = np.empty(n_p)
        self._dev = np.empty((n, n_p))
        self._x_spare = np.empty((n, n_p))
        self._devw = np.empty((n, n_p))
        self._noise = np.empty((self.dim, n_p))

    @property
    def particles(self) -> Array:
        """A copy of the particles ``(N, n)``."""
        return self._x.T.copy()

    @property
    def weights(self) -> Array:
        """Normalised weights ``(N,)``."""
        return self._w.copy()

    @property
    def effective_sample_size(self) -> float:
        """``1 / sum w^2``."""
        return float(1.0 / np.dot(self._w, self._w))

    def _compute_moments(self) -> tuple[Array, Array]:
        if self._moments is None:
            w = self._w
            mean = self._x @ w
            dev = np.subtract(self._x, mean[:, None], out=self._dev)
            devw = np.multiply(dev, w, out=self._devw)
            cov = symmetrise(devw @ dev.T)
            self._moments = (mean, cov)
        return self._moments

    @property
    def state(self) -> Array:
        """The weighted particle mean ``(n,)`` (m, m/s)."""
        return self._compute_moments()[0].copy()

    @property
    def covariance(self) -> Array:
        """The weighted particle covariance ``(n, n)`` (m^2, m^2/s, m^2/s^2), symmetric."""
        return self._compute_moments()[1].copy()

    # -- predict ------------------------------------------------------------------------------
    def _predict(self, dt: float) -> None:
        x = self._x
        d = self.dim
        if self._ncv:
            if self._any_density:
                self._predict_density(dt)
            elif self._any_q:
                # p += dt v + dt^2/2 w, v += dt w (Chen & Sun §2.1), with v moved in halves so
                # that p sees v + dt w / 2: five passes over the particles.
                half = self._normals(self._noise)
                if self._equal_q:
                    half *= 0.5 * dt * float(self._q[0])
                else:
                    half *= (0.5 * dt * self._q)[:, None]
                x[d:] += half
                x[:d] += np.multiply(x[d:], dt, out=self._dev[:d])
                x[d:] += half
            else:
                x[:d] += np.multiply(x[d:], dt, out=self._dev[:d])
        else:
            x = self.dynamics.transition(dt) @ x
            q = self.dynamics.noise(dt)
            if np.any(q != 0):
                x += psd_root(q) @ self.rng.standard_normal((x.shape[0], self.n_particles))
            self._x = np.ascontiguousarray(x)
        self._moments = None

    def _predict_density(self, dt: float) -> None:
        """Move the particles with a white-noise-acceleration density (and any held ``q``)."""
        q2, qd = self._q**2, self._q_density
        a = dt**4 / 4 * q2 + dt**3 / 3 * qd
        b = dt**3 / 2 * q2 + dt**2 / 2 * qd
        c = dt**2 * q2 + dt * qd
        l11 = np.sqrt(a)
        l21 = np.divide(b, l11, out=np.zeros(self.dim), where=l11 > 0)
        l22 = np.sqrt(np.clip(c - l21**2, 0.0, None))
        noise = getattr(self, "_density_noise", None)
        if noise is None:
            noise = self._density_noise = np.empty((2, self.dim, self.n_particles))
        _compiled(_move_density)(self._x, self._normals(noise), float(dt), l11, l21, l22)

    def _normals(self, out: Array) -> Array:
        """Fill ``out`` with ``rng.standard_normal(out.shape)``."""
        if self._compiled:
            _compiled(_fill_normals)(self.rng, out)
        else:
            self.rng.standard_normal(out=out)
        return out

    # -- update -------------------------------------------------------------------------------
    def _update(self, group: MeasurementGroup) -> UpdateInfo:
        if len(group) == 1 and group.dt[0] == 0.0 and "bearing" in group.models:
            info = self._update_bearing(group)
            if info is not None:
                return info
        loglik, nu = self._general_loglik(group)
        return self._weigh(loglik, nu, group.covariance)

    def _update_bearing(self, group: MeasurementGroup) -> UpdateInfo | None:
        """Update with one bearing at the update time in closed form."""
        sx, sy = (float(v) for v in group.sensor_state[0, :2])
        z, sigma = float(group.values[0]), float(group.sigmas[0])
        sz, cz = math.sin(z), math.cos(z)
        # s = sin z (y - sy) - cos z (x - sx), c = cos z (y - sy) + sin z (x - sx)
        s, c, r = self._work
        np.matmul(np.array([[-cz, sz], [sz, cz]]), self._x[:2], out=self._work[:2])
        s += cz * sx - sz * sy
        c -= cz * sy + sz * sx
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(s, c, out=r)
        np.arctan(r, out=r)
        neg = c < 0.0
        if neg.any():
            r[neg] += np.where(s[neg] >= 0.0, np.pi, -np.pi)
        uniform = self._uniform
        w_prior = self._w
        nu_bar = float(r.sum()) / self.n_particles if uniform else float(r @ w_prior)
        if not math.isfinite(nu_bar):
            return None
        r *= r
        second = float(r.sum()) / self.n_particles if uniform else float(r @ w_prior)
        var = max(second - nu_bar * nu_bar, 0.0) + sigma * sigma
        r *= -0.5 / (sigma * sigma)
        const = -math.log(sigma) - 0.5 * LOG_2PI
        return self._normalise(r, const, nu_bar * nu_bar / var, 1)

    def _normalise(self, total: Array, const: float, nis: float, dof: int) -> UpdateInfo:
        """Multiply the weights by the likelihoods ``exp(total + const)`` and normalise."""
        uniform = self._uniform
        if not uniform:
            total += self._logw
        top = float(total.max())
        if not math.isfinite(top):
            return self._skip()
        total -= top
        w = np.exp(total, out=self._w_spare)
        # Weights below e^-575 (1e-250) of the largest are set to zero: they carry no mass,
        # and subnormal numbers would slow every later pass over the particles ~100-fold.
        if float(total.min()) < LOG_NEGLIGIBLE:
            dead = total < LOG_NEGLIGIBLE
            w[dead] = 0.0
            total[dead] = -np.inf
        s = float(w.sum())
        log_s = math.log(s)
        increment = top + log_s + const - (math.log(self.n_particles) if uniform else 0.0)
        logw = np.subtract(total, log_s, out=self._logw_spare)
        w /= s
        self._w_spare, self._w = self._w, w
        self._logw_spare, self._logw = self._logw, logw
        self._uniform = False
        self._moments = None
        if self.history is not None:
            self.history.append(ParticleStep(self.time, self._x.copy(), w.copy()))
        if 1.0 / float(np.dot(w, w)) < self.resample_threshold * self.n_particles:
            self._resample()
        return UpdateInfo(nis, dof, increment)

    def _general_loglik(self, group: MeasurementGroup) -> tuple[Array, Array]:
        """Any kinds: per-particle log-likelihoods (N,) and residuals (N, m)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            nu = group.residual(group.predict(self._x.T))  # (N, m)
        r = group.covariance
        m = r.shape[0]
        if np.count_nonzero(r - np.diag(np.diagonal(r))) == 0:
            sig = np.sqrt(np.diagonal(r))
            white = nu / sig
            log_det_half = float(np.sum(np.log(sig)))
        else:
            chol = safe_cholesky(r)
            white = cast(Array, np.linalg.solve(chol, nu.T).T)
            log_det_half = float(np.sum(np.log(np.diagonal(chol))))
        loglik = -0.5 * np.einsum("ij,ij->i", white, white) - log_det_half - 0.5 * m * LOG_2PI
        return loglik, nu

    def _weigh(self, loglik: Array, nu: Array, r: Array) -> UpdateInfo:
        """Make the general update from per-particle log-likelihoods (N,) and residuals (N, m)."""
        bad = ~np.isfinite(loglik)
        wp = self._w  # the NIS from the predicted measurement moments (weights before)
        if bad.any():
            loglik = np.where(bad, -np.inf, loglik)
            wp = np.where(bad, 0.0, wp)
            wp = wp / max(float(np.sum(wp)), 1e-300)
            nu = np.where(bad[:, None], 0.0, nu)
        nu_bar = nu.T @ wp
        dev = nu - nu_bar
        s_pred = symmetrise((dev.T * wp) @ dev + r)
        sol, _ = solve_spd(s_pred, nu_bar)
        return self._normalise(np.array(loglik, dtype=float), 0.0, float(nu_bar @ sol),
                               int(nu.shape[1]))

    # -- resampling and regularisation -------------------------------------------------------
    def _carry(self, idx: NDArray[np.int64]) -> None:
        """Carry what a subclass keeps per particle through a resampling to ``idx``."""

    def _resample(self) -> None:
        mean, cov = self._compute_moments()
        idx = systematic_resample(self._w, float(self.rng.random()))
        self._carry(idx)
        x = np.take(self._x, idx, axis=1, out=self._x_spare, mode="clip")  # unbuffered
        if self.regularise:
            h = self.h
            a = math.sqrt(1.0 - h * h)
            chol = _kernel_factor(cov)
            x *= a
            x += ((1.0 - a) * mean)[:, None]
            x += np.matmul(h * chol, self._normals(self._devw), out=self._dev)
            if self.history:
                self.history[-1] = replace(self.history[-1], shrink=a, centre=mean.copy(),
                                           jitter=(h * h) * (chol @ chol.T))
        self._x_spare, self._x = self._x, x
        n = self.n_particles
        self._w.fill(1.0 / n)
        self._logw.fill(-math.log(n))
        self._uniform = True
        self.resamples += 1
        # The estimate at this time stays the pre-resampling weighted moments.
        self._moments = (mean, cov)


def _move_density(x: Array, noise: Array, dt: float, l11: Array, l21: Array,
                  l22: Array) -> None:  # pragma: no cover - compiled
    """Move the particles ``x`` (n, N) one step of white-noise acceleration, in place."""
    dim = l11.shape[0]
    for a in range(dim):
        c11, c21, c22 = l11[a], l21[a], l22[a]
        for i in range(x.shape[1]):
            w0 = noise[0, a, i]
            x[a, i] += dt * x[dim + a, i] + c11 * w0
            x[dim + a, i] += c21 * w0 + c22 * noise[1, a, i]


def _fill_normals(rng: np.random.Generator, out: Array) -> None:  # pragma: no cover - compiled
    """Fill the contiguous ``out`` with standard normal draws of ``rng``, in C order."""
    flat = out.reshape(-1)
    for j in range(flat.shape[0]):
        flat[j] = rng.standard_normal()


@functools.cache
def _compiled(kernel: Callable[..., None]) -> Callable[..., None]:
    """Give ``kernel`` compiled (numba is imported at the first use)."""
    import numba

    return cast(Callable[..., None],
                numba.njit(cache=True, nogil=True, error_model="numpy")(kernel))


def _kernel_factor(cov: Array) -> Array:
    """Give a square-root factor of the particle covariance for the regularisation kernel."""
    try:
        return cast(Array, np.linalg.cholesky(cov))
    except np.linalg.LinAlgError:
        return psd_root(nearest_psd(cov))


def psd_root(q: Array) -> Array:
    """Give a square root ``L`` (``L L^T = q``) of a symmetric PSD matrix, by its eigenvectors."""
    evals, evecs = np.linalg.eigh(symmetrise(q))
    return cast(Array, evecs * np.sqrt(np.clip(evals, 0.0, None)))
