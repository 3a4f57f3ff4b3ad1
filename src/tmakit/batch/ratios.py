"""The ratio method of Gu et al. (2007) §4: ratios of neighbouring measurements.

Ratios of consecutive power (eqs. 19-25) and Doppler (eqs. 26-32) samples of one sensor remove
the nuisance C and f_s; both blocks stack (eqs. 33-34) and iterate ``theta = D^-1 N``.  Eqs.
27-28 are used where eq. 31 prints the opposite overall sign.  ``covariance="derived"``
(default) weights by the first-order tri-diagonal covariance, ``"paper"`` by the printed one
(whose power off-diagonal lacks a minus sign) with a sandwich covariance; docs/references.md
lists the misprints.  The nuisance values are fitted afterwards by weighted linear least
squares given theta, their std including theta's propagated uncertainty.
"""


from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cho_solve_banded, cholesky_banded, solve_banded

from ..core.arrays import Array
from ..core.units import SPEED_OF_LIGHT
from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..observation import ObservationModel
from ..results.estimate import EstimateResult, diverged_result, result_from_covariance
from ..results.status import DIVERGED, NOT_CONVERGED, Status
from .estimator import Init, PaperMethod, kinds_tuple
from .gu_direct import (
    DIVERGENCE_FACTOR,
    NUISANCE_NAMES,
    PAPER_KINDS,
    PlanarGeometry,
    carrier_guess,
    check_planar_cv,
    initial_theta,
    iteration_stop,
    select_kinds,
    snr_from_sigma_db,
)

__all__ = ["RatioMethod", "doppler_ratio_covariance", "nuisance_given_theta",
           "power_ratio_covariance"]

COVARIANCES = ("derived", "paper")


@dataclass(frozen=True)
class RatioPairs:
    """Consecutive pairs of samples of one kind, and which neighbouring pairs are linked."""

    prev: NDArray[np.int64]  # (m,) rows of each pair's earlier sample
    cur: NDArray[np.int64]  # (m,) and its later one
    linked: NDArray[np.bool_]  # (m,) pairs j and j + 1 share a sample (correlated)


def ratio_pairs(meas: MeasurementSet, kind: str) -> RatioPairs:
    """Form the pairs of consecutive samples of ``kind`` per sensor, in time order."""
    prev, cur, linked = [], [], []
    for s in meas.sensors:
        rows = np.flatnonzero((meas.kind == kind) & (meas.sensor == s))
        if rows.size < 2:
            continue
        rows = rows[np.argsort(meas.time[rows], kind="stable")]
        if np.any(np.diff(meas.time[rows]) <= 0):
            raise ValueError(f"ratio method: {kind} samples of sensor {s!r} must have "
                             "distinct times (pairs are formed from consecutive samples)")
        prev.append(rows[:-1])
        cur.append(rows[1:])
        linked.append(chain(rows.size - 1))
    if not prev:
        empty = np.zeros(0, dtype=np.int64)
        return RatioPairs(empty, empty, np.zeros(0, dtype=bool))
    return RatioPairs(np.concatenate(prev), np.concatenate(cur), np.concatenate(linked))


def tridiagonal(diag: Array, off: Array) -> Array:
    """Build the dense symmetric tri-diagonal matrix of two bands."""
    out = np.diag(diag)
    idx = np.arange(diag.size - 1)
    out[idx, idx + 1] = off[:-1]
    out[idx + 1, idx] = off[:-1]
    return out


def power_bands(mu: Array, r2_prev: Array, r2_cur: Array, s_prev: Array, s_cur: Array,
                linked: NDArray[np.bool_], covariance: str) -> tuple[Array, Array]:
    """Return the bands of the power-ratio covariance (Gu et al. (2007), eq. 21, after eq. 25)."""
    diag = mu ** 2 * r2_cur ** 2 * s_prev + r2_prev ** 2 * s_cur
    off = np.zeros(mu.size)
    if mu.size > 1:
        # (k, k+1): mu_{k+1} R_{k-1}^2 R_{k+1}^2 s_k, negative when derived.
        off[:-1] = mu[1:] * r2_prev[:-1] * r2_cur[1:] * s_cur[:-1]
    sign = -1.0 if covariance == "derived" else 1.0
    return diag, np.where(linked, sign * off, 0.0)


def doppler_bands(nu: Array, sigma_prev: Array, sigma_cur: Array, linked: NDArray[np.bool_],
                  carrier: float, v_prev: Array | None, v_cur: Array | None,
                  covariance: str) -> tuple[Array, Array]:
    """Return the bands of the Doppler-ratio covariance (Gu et al. (2007), eq. 27, after 32)."""
    c = SPEED_OF_LIGHT
    scale = (c / carrier) ** 2
    off = np.zeros(nu.size)
    if covariance == "derived":
        diag = sigma_cur ** 2 + nu ** 2 * sigma_prev ** 2
        if nu.size > 1:
            off[:-1] = -nu[1:] * sigma_cur[:-1] ** 2
    else:
        if v_prev is None or v_cur is None:
            raise ValueError("the paper's Doppler covariance needs the radial velocities")
        a_cur, a_prev = (1.0 - v_cur / c) ** 2, (1.0 - v_prev / c) ** 2
        diag = a_cur * sigma_cur ** 2 + nu ** 2 * a_prev * sigma_prev ** 2
        if nu.size > 1:
            off[:-1] = -nu[1:] * a_cur[1:] * sigma_cur[:-1] ** 2  # (1 - v_{k+1}/c)^2
    return scale * diag, np.where(linked, scale * off, 0.0)


def power_ratio_covariance(mu: Array, r2_prev: Array, r2_cur: Array, s_prev: Array,
                           s_cur: Array, linked: NDArray[np.bool_] | None = None,
                           covariance: str = "derived") -> Array:
    """Return the dense covariance of the power-ratio noise terms (Gu et al. (2007), eq. 21)."""
    linked = chain(mu.size) if linked is None else linked
    return tridiagonal(*power_bands(mu, r2_prev, r2_cur, s_prev, s_cur, linked, covariance))


def doppler_ratio_covariance(nu: Array, sigma_prev: Array, sigma_cur: Array,
                             linked: NDArray[np.bool_] | None = None,
                             carrier: float = 1.0, v_prev: Array | None = None,
                             v_cur: Array | None = None, covariance: str = "derived") -> Array:
    """Return the dense covariance of the noise terms of ``c h_k`` (Gu et al. (2007), eq. 27)."""
    linked = chain(nu.size) if linked is None else linked
    return tridiagonal(*doppler_bands(nu, sigma_prev, sigma_cur, linked, carrier, v_prev,
                                        v_cur, covariance))


def chain(n: int) -> NDArray[np.bool_]:
    """Return ``linked`` of one chain of ``n`` pairs: each linked to the next, the last not."""
    linked = np.ones(n, dtype=bool)
    if n:
        linked[-1] = False
    return linked


class Banded:
    """Whitening by a positive-definite tri-diagonal ``Sigma`` (``off[j]`` at (j, j+1))."""

    def __init__(self, diag: Array, off: Array) -> None:
        ab = np.zeros((2, diag.size))
        ab[0] = diag
        ab[1, :-1] = off[:-1]
        self.factor = cholesky_banded(ab, lower=True)   # raises LinAlgError if not PD

    def whiten(self, x: Array) -> Array:
        """Return ``C^-1 x`` with ``Sigma = C C^T``."""
        return solve_banded((1, 0), self.factor, x)

    def solve(self, x: Array) -> Array:
        """Return ``Sigma^-1 x``."""
        return cho_solve_banded((self.factor, True), x)


class _RatioSystem:
    """Gu et al. (2007), eqs. 19-34, apart from theta; the linear system at a theta."""

    def __init__(self, sub: MeasurementSet, motion: ConstantVelocity, kinds: tuple[str, ...],
                 covariance: str) -> None:
        self.sub = sub
        self.kinds = kinds
        self.covariance = covariance
        self.geo = PlanarGeometry.from_rows(sub, motion)
        value = sub.value_si
        self.power = ratio_pairs(sub, "power") if "power" in kinds else None
        self.freq = ratio_pairs(sub, "frequency") if "frequency" in kinds else None
        if self.power is not None:
            pp = self.power
            self.mu = 10.0 ** ((value[pp.cur] - value[pp.prev]) / 10.0)       # eq. 19
            s = 1.0 / snr_from_sigma_db(sub.sigma_si)
            self.s_prev, self.s_cur = s[pp.prev], s[pp.cur]
            self.gp_prev, self.gp_cur = self.geo.take(pp.prev), self.geo.take(pp.cur)
        if self.freq is not None:
            fp = self.freq
            self.nu = value[fp.cur] / value[fp.prev]                          # eq. 26
            self.one_minus_nu = (value[fp.prev] - value[fp.cur]) / value[fp.prev]
            self.sig_prev, self.sig_cur = sub.sigma_si[fp.prev], sub.sigma_si[fp.cur]
            self.gf_prev, self.gf_cur = self.geo.take(fp.prev), self.geo.take(fp.cur)
            # Only the noise scale c/f_s needs the carrier: the median received frequency
            # gives it to ~1e-7.
            self.carrier = carrier_guess(sub)
        self.n = ((0 if self.power is None else self.power.cur.size)
                  + (0 if self.freq is None else self.freq.cur.size))

    def build(self, theta: Array, covariance: str | None = None
              ) -> tuple[Array, Array, Array, Array]:
        """Return ``L (n, 4)``, ``psi (n,)`` and the bands of ``Sigma`` at ``theta``."""
        cov_kind = covariance or self.covariance
        blocks_l, blocks_psi, blocks_d, blocks_o = [], [], [], []
        if self.power is not None:
            g0, g1, mu = self.gp_prev, self.gp_cur, self.mu
            dq = g0.Q - mu[:, None, None] * g1.Q                                # eq. 23
            dl = g0.L - mu[:, None] * g1.L
            drho = g0.rho2 - mu * g1.rho2
            blocks_l.append(2.0 * (dl - np.einsum("nij,j->ni", dq, theta)))   # L_p
            blocks_psi.append(drho - np.einsum("i,nij,j->n", theta, dq, theta))  # psi_p
            d, o = power_bands(mu, g0.range2(theta), g1.range2(theta), self.s_prev,
                                self.s_cur, self.power.linked, cov_kind)
            blocks_d.append(d)
            blocks_o.append(o)
        if self.freq is not None:
            g0, g1, nu = self.gf_prev, self.gf_cur, self.nu
            c = SPEED_OF_LIGHT
            v0, v1 = g0.radial_velocity(theta), g1.radial_velocity(theta)
            lf = g1.grad_radial_velocity(theta) - nu[:, None] * g0.grad_radial_velocity(theta)
            ch = v1 - nu * v0 - self.one_minus_nu * c                           # eq. 27 x c
            blocks_l.append(lf)                                                 # eq. 28-29
            blocks_psi.append(lf @ theta - ch)                                  # eq. 32
            d, o = doppler_bands(nu, self.sig_prev, self.sig_cur, self.freq.linked,
                                  self.carrier, v0, v1, cov_kind)
            blocks_d.append(d)
            blocks_o.append(o)
        return (np.concatenate(blocks_l), np.concatenate(blocks_psi), np.concatenate(blocks_d),
                np.concatenate(blocks_o))


#: The method's name by the kinds used (both: ``"ratio"``).
RATIO_NAMES: dict[tuple[str, ...], str] = {("power",): "ratio-power",
                                           ("frequency",): "ratio-doppler"}


@dataclass(frozen=True, eq=False)
class RatioMethod(PaperMethod):
    """Gu et al. (2007) §4: iterative LS on ratios of neighbouring measurements.

    Diverged when theta becomes non-finite, a range non-positive, or the ranges grow 1e4-fold.

    Parameters
    ----------
    init, options : optional
        As for :class:`~tmakit.batch.estimator.PaperMethod`: ``[x_0, y_0, v_x, v_y]`` (m, m/s).
    kinds : str or sequence of str, optional
        ``"power"`` (eqs. 19-25), ``"frequency"`` (eqs. 26-32) or both (eqs. 33-34, default).
    max_iter : int, optional
        Default 50.
    covariance : str, optional
        ``"derived"`` (default) or ``"paper"``.
    tol : float, optional
        Converged when the update is below ``tol * (1 + |theta|)`` (default 1e-9).

    Raises
    ------
    ValueError
        For an unknown ``covariance`` or a nuisance model other than the paper's.

    References
    ----------
    Gu et al. (2007), §4, eqs. 19-34.
    """

    kinds: str | Sequence[str] | None = ("power", "frequency")
    max_iter: int = 50
    covariance: str = "derived"
    tol: float = 1e-9

    start_kinds: ClassVar[tuple[str, ...]] = PAPER_KINDS

    def __post_init__(self) -> None:
        """Refuse an unknown ``covariance`` and a nuisance model the paper does not have."""
        if self.covariance not in COVARIANCES:
            raise ValueError(f"covariance must be one of {', '.join(COVARIANCES)}, got "
                             f"{self.covariance!r}")
        super().__post_init__()

    @property
    def name(self) -> str:  # type: ignore[override]
        """``ratio-power``, ``ratio-doppler`` or ``ratio``, by the kinds asked for."""
        wanted = self.kinds_wanted
        if wanted is None:
            return "ratio"
        return RATIO_NAMES.get(tuple(k for k in PAPER_KINDS if k in wanted), "ratio")

    @property
    def kinds_wanted(self) -> tuple[str, ...] | None:
        """The kinds asked for (None: both, as the data hold them)."""
        return kinds_tuple(self.kinds)

    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the iteration of Gu et al. (2007) §4 (eqs. 19-34) from ``init``."""
        cv = check_planar_cv(motion, "ratio method")
        kinds_used, sub = select_kinds(meas, self.kinds, "ratio method")
        theta = initial_theta(motion, init, "ratio method")
        system = _RatioSystem(sub, cv, kinds_used, self.covariance)
        if system.n < motion.n_params:
            raise ValueError(f"ratio method: {system.n} ratios cannot determine "
                             f"{motion.n_params} parameters")
        status: Status = NOT_CONVERGED
        message = ""
        far = DIVERGENCE_FACTOR * max(float(np.sqrt(np.max(system.geo.range2(theta)))), 1e3)
        steps: list[float] = []
        iterations = 0
        for it in range(1, self.max_iter + 1):
            iterations = it
            lmat, psi, diag, off = system.build(theta)
            if not (np.all(np.isfinite(lmat)) and np.all(np.isfinite(psi))
                    and np.all(np.isfinite(diag)) and np.all(np.isfinite(off))):
                status, message = DIVERGED, ("the iterate left the region where the model is "
                                             "defined")
                break
            try:
                band = Banded(diag, off)
            except np.linalg.LinAlgError:
                status, message = DIVERGED, "the covariance Sigma is not positive definite"
                break
            lw, pw = band.whiten(lmat), band.whiten(psi)
            scale = np.linalg.norm(lw, axis=0)
            scale = np.where(scale > 0, scale, 1.0)
            new = np.linalg.lstsq(lw / scale, pw, rcond=None)[0] / scale           # D^-1 N
            if not np.all(np.isfinite(new)):
                status, message = DIVERGED, "the iterate became non-finite"
                break
            step = new - theta
            theta = new
            steps.append(float(np.linalg.norm(step)))
            stop = iteration_stop(theta, step, system.geo.range2(theta), far, self.tol)
            if stop is not None:
                status, message = stop
                break
        extra: dict[str, object] = {"covariance": self.covariance, "kinds": list(kinds_used),
                                    "n_ratios": int(system.n), "update_norms": steps}
        return _ratio_result(system, motion, theta, status, message, iterations, extra)


def _ratio_result(system: _RatioSystem, motion: MotionModel, theta: Array, status: Status,
                  message: str, iterations: int, extra: dict[str, object]) -> EstimateResult:
    """Build the result at the last iterate."""
    method = RATIO_NAMES.get(system.kinds, "ratio")
    p = motion.n_params
    if status == DIVERGED:
        names_nu = [NUISANCE_NAMES[k] for k in system.kinds]
        return diverged_result(motion, names_nu, iterations, system.n - p, method, message,
                               extra=extra)
    lmat, psi, diag, off = system.build(theta)
    band = Banded(diag, off)
    lw, pw = band.whiten(lmat), band.whiten(psi)
    d_inv = np.linalg.inv(lw.T @ lw)
    if system.covariance == "derived":
        cov = d_inv
    else:
        sigma_true = tridiagonal(*system.build(theta, "derived")[2:])
        sl = band.solve(lmat)                                                  # Sigma^-1 L
        cov = d_inv @ (sl.T @ sigma_true @ sl) @ d_inv
        extra["covariance_d_inverse"] = d_inv.tolist()
    cov = 0.5 * (cov + cov.T)
    resid = pw - lw @ theta
    chi2 = float(resid @ resid)
    nuis = nuisance_given_theta(system.sub, motion, theta, cov)
    if status == NOT_CONVERGED:
        message = "the iteration limit was reached before the update became small"
    return result_from_covariance(motion, theta, cov, nuis, status, iterations, chi2,
                                  system.n - p, method, message, extra)


def nuisance_given_theta(meas: MeasurementSet, motion: MotionModel, theta: Array,
                         cov_theta: Array) -> dict[str, tuple[float, float]]:
    """Estimate power constant and carrier by weighted linear least squares given ``theta``."""
    options: dict[str, dict[str, object]] = {"power": {"exponent": 2.0},
                                             "frequency": {"drift": False}}
    obs = ObservationModel(meas, motion, {k: v for k, v in options.items() if k in meas.kinds})
    h0, a = obs.affine(theta)
    w = 1.0 / obs.sigmas ** 2
    ata = a.T @ (a * w[:, None])
    nu = np.linalg.solve(ata, a.T @ (w * (obs.values - h0)))
    j_theta, _ = obs.jacobian(theta, nu)
    g = -np.linalg.solve(ata, a.T @ (j_theta * w[:, None]))
    var = np.linalg.inv(ata) + g @ cov_theta @ g.T
    std = np.sqrt(np.clip(np.diag(var), 0.0, None))
    return {name: (float(nu[i]), float(std[i])) for i, name in enumerate(obs.nuisance_names)}
