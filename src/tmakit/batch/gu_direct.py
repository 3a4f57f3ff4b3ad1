"""The direct iterative least squares of 000_bc54bd8c50e47249.txt §3 (Gu, Pachter, Chandler,
Schumacher), with the nuisance parameters C/C_0 and c/f_s in the parameter vector.

The paper linearises the power equation (eqs. 9-11) and the Doppler equation (eqs. 14-16) about
the current estimate and iterates ``theta_pf^(i+1) = D_i^-1 N_i`` with
``D_i = A^T Sigma^-1 A`` and ``N_i = A^T Sigma^-1 B`` where

* power rows (eq. 11): ``[2 (L_k - Q_k theta)^T, C_0 / P_k]``, right-hand side
  ``rho_k^2 - theta^T Q_k theta``, variance ``R_k^4 / SNR_p``;
* Doppler rows (eqs. 15-16 and the A_f, B_f of §3): ``[(dh_k/dtheta)^T, f_k]``, right-hand
  side ``(dh_k/dtheta)^T theta + c - v_k``, variance ``c^2 sigma_f^2 / f_s^2``;
* both (§3 "TMA estimation based on both measurements"):
  ``theta_pf = [x_0, y_0, v_x, v_y, C/C_0, c/f_s]``, the two row blocks stacked with zeros in
  the other kind's nuisance column.

Here ``P_k`` is the linear received power in watts, ``10**(P_dBW/10)``; tmakit stores power in
dBW.  ``C_0`` is the free-space constant ``(lambda/4 pi)^2`` at the carrier
(:func:`tmakit.units.free_space_constant`).  ``SNR_p`` comes from each power sample's sigma in
dB: ``SNR = (10 / ln 10 / sigma_dB)^2`` (the inverse of :func:`tmakit.units.snr_to_sigma_db`).

The paper's point ("It is important to point out that A_f is badly conditioned"): the column
``f_k ~ 1.9e9`` dwarfs the others.  Every iteration records the condition number of the
weighted A (``extra["condition_numbers"]``), of its Doppler and power parts separately, and of
A with its columns scaled to unit norm (``condition_numbers_equilibrated``): the conditioning
problem is largely a matter of column scaling.  The solve itself uses the equilibrated columns
and an SVD least-squares solution (mathematically ``D^-1 N``); ``normal_equations=True`` forms
and solves ``D_i theta = N_i`` literally, as printed, to show what the conditioning does to
that.

Measured on gu2007 (200 seeded runs from the paper's start (4900, 1200, 0, 0), both kinds):
every run converges; RMSE / CRLB (C and f_s unknown) = 1.00, 1.14, 1.18, 0.99 for x_0, y_0,
v_x, v_y, with a mean error of about (-1.8 m, +4.5 m, +0.074 m/s, 0) — a bias of up to 0.7 std
that tmakit's ML (dB domain) does not have.  Power only at SNR_p = 40 dB the iteration settles
about 1.1 km from the truth in x_0 and 0.75 km in y_0, near the same point for every noise
draw, though noise-free data give the truth: the paper's "fails to compute meaningful
estimates".  A plausible cause (not proven here) is that the noisy P_k sits inside A (errors
in variables), which matters where power alone observes the track weakly (CRLB with C unknown:
140 m in x_0); at SNR_p = 60 dB the offset falls to ~14 m.

The geometry helpers (:class:`PlanarGeometry`: ``Q_k``, ``L_k``, ``rho_k`` of eq. 7-8,
``Q_fk``, ``S_f``, ``phi_k`` of eq. 12, the derivatives of eq. 16) are shared with the ratio
method (:mod:`tmakit.batch.ratios`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..results.estimate import CONVERGED, DIVERGED, NOT_CONVERGED, EstimateResult
from ..units import SPEED_OF_LIGHT, free_space_constant

Array = NDArray[np.float64]

PAPER_KINDS = ("power", "frequency")
"""The measurement kinds of 000_bc54bd8c50e47249.txt, in the column order of theta_pf."""

_TEN_OVER_LN10 = 10.0 / np.log(10.0)
DIVERGENCE_FACTOR = 1e4


def iteration_stop(theta: NDArray[np.float64], step: NDArray[np.float64],
                   range2: NDArray[np.float64], far: float, tol: float
                   ) -> tuple[str, str] | None:
    """How an iteration of the papers' fixed-point methods ends after an update ``step`` to
    ``theta``: diverged (a range non-positive, or grown beyond ``far``), converged (the
    update below ``tol`` relative), or ``None`` to go on.  Shared by 000 §3 and §4."""
    if np.any(range2 <= 0):
        return DIVERGED, "a range became non-positive"
    if np.max(range2) > far ** 2:
        return DIVERGED, (f"the ranges grew more than {DIVERGENCE_FACTOR:g}-fold from the "
                          "start")
    if np.linalg.norm(step) <= tol * (1.0 + np.linalg.norm(theta)):
        return CONVERGED, ""
    return None
"""An iterate whose largest range exceeds this multiple of the largest range at the start (or
of 1 km) is declared diverged."""
DEFAULT_CARRIER = 1.9e9
"""Carrier (Hz) assumed for C_0 when the data hold no frequency (000 §5)."""


# -- shared pieces ---------------------------------------------------------------------------
def check_planar_cv(motion: MotionModel, method: str) -> None:
    """The papers' methods are written for 2-D constant velocity (000 eq. 1)."""
    if not isinstance(motion, ConstantVelocity) or motion.dim != 2:
        raise ValueError(f"{method}: written for 2-D constant velocity (000_bc54bd8c50e47249.txt"
                         f" eq. 1, motion cv2d, ConstantVelocity(2)); got {motion!r}")


def select_kinds(meas: MeasurementSet, kinds: str | Sequence[str] | None, method: str
                 ) -> tuple[tuple[str, ...], MeasurementSet]:
    """The kinds to use (in :data:`PAPER_KINDS` order) and the rows of those kinds.

    ``kinds=None`` takes every power and frequency row and refuses data of other kinds.
    """
    if kinds is None:
        other = sorted(set(meas.kinds) - set(PAPER_KINDS))
        if other:
            raise ValueError(f"{method}: uses power and frequency only, the data also hold "
                             f"{', '.join(other)}; pass kinds= or select the rows")
        chosen = [k for k in PAPER_KINDS if k in meas.kinds]
    else:
        wanted = (kinds,) if isinstance(kinds, str) else tuple(kinds)
        for k in wanted:
            if k not in PAPER_KINDS:
                raise ValueError(f"{method}: kind {k!r} not usable; expected power and/or "
                                 "frequency")
            if k not in meas.kinds:
                raise ValueError(f"{method}: the data hold no {k} measurements")
        chosen = [k for k in PAPER_KINDS if k in wanted]
    if not chosen:
        raise ValueError(f"{method}: the data hold no power or frequency measurements")
    return tuple(chosen), meas.take(np.isin(meas.kind, chosen))


def initial_theta(motion: MotionModel, init: Mapping[str, float] | ArrayLike | None,
                  method: str) -> Array:
    """A starting parameter vector from a mapping by name or a vector."""
    if init is None:
        raise ValueError(f"{method}: a local method, it needs a starting point (init=...); "
                         "tmakit.batch.methods.estimate_with supplies a grid start")
    if isinstance(init, Mapping):
        return motion.theta({k: v for k, v in init.items() if k in motion.param_names})
    theta = np.asarray(init, dtype=float).reshape(-1)
    if theta.shape != (motion.n_params,):
        raise ValueError(f"{method}: init must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)})")
    return theta


def snr_from_sigma_db(sigma_db: ArrayLike) -> Array:
    """SNR_p (linear) of a power whose standard deviation in dB is ``sigma_db``: the first-order
    inverse of :func:`tmakit.units.snr_to_sigma_db`, ``(10 / ln 10 / sigma)^2``."""
    return (_TEN_OVER_LN10 / np.asarray(sigma_db, dtype=float)) ** 2


def power_watts(meas: MeasurementSet) -> Array:
    """Linear received power ``P = 10**(P_dBW / 10)`` (W) of the power rows, in row order."""
    return 10.0 ** (meas.value_si[meas.kind == "power"] / 10.0)


@dataclass(frozen=True)
class PlanarGeometry:
    """The sensor side of 000_bc54bd8c50e47249.txt eqs. 7, 8, 12 and 16 for a set of samples.

    ``t`` are the sample times relative to the motion's reference time (the paper's t_0 = 0),
    ``u``/``udot`` the sensor's horizontal position and velocity.  A sensor off the plane z = 0
    (or moving vertically) is handled exactly by adding ``U_z^2`` to ``rho_k^2`` and
    ``U_z dU_z/dt`` to the numerator of eq. 12; the target stays at z = 0.
    """

    t: Array      # (n,)
    u: Array      # (n, 2)
    udot: Array   # (n, 2)
    uz: Array     # (n,)
    uzdot: Array  # (n,)

    @classmethod
    def from_rows(cls, meas: MeasurementSet, motion: ConstantVelocity) -> PlanarGeometry:
        s = meas.sensor_state
        return cls(meas.time - motion.ref_time, s[:, 0:2].copy(), s[:, 3:5].copy(),
                   s[:, 2].copy(), s[:, 5].copy())

    def take(self, idx: ArrayLike) -> PlanarGeometry:
        i = np.asarray(idx)
        return PlanarGeometry(self.t[i], self.u[i], self.udot[i], self.uz[i], self.uzdot[i])

    # eq. 7
    @property
    def Q(self) -> Array:
        """``Q_k`` (n, 4, 4) of eq. 7."""
        t = self.t
        q = np.zeros((t.size, 4, 4))
        q[:, 0, 0] = q[:, 1, 1] = 1.0
        q[:, 0, 2] = q[:, 2, 0] = q[:, 1, 3] = q[:, 3, 1] = t
        q[:, 2, 2] = q[:, 3, 3] = t * t
        return q

    @property
    def L(self) -> Array:
        """``L_k = [U_x, U_y, t U_x, t U_y]`` (n, 4) of eq. 7."""
        return np.column_stack([self.u, self.t[:, None] * self.u])

    @property
    def rho2(self) -> Array:
        """``rho_k^2 = U_x^2 + U_y^2`` (+ ``U_z^2``), eq. 8."""
        return np.einsum("ni,ni->n", self.u, self.u) + self.uz ** 2

    # eq. 12
    @property
    def Qf(self) -> Array:
        """``Q_fk`` (n, 4, 4) of eq. 12."""
        q = np.zeros((self.t.size, 4, 4))
        q[:, 0, 2] = q[:, 2, 0] = q[:, 1, 3] = q[:, 3, 1] = 0.5
        q[:, 2, 2] = q[:, 3, 3] = self.t
        return q

    @staticmethod
    def S_f() -> Array:
        """``S_f`` of eq. 12."""
        s = np.zeros((4, 4))
        s[0, 2] = s[2, 0] = s[1, 3] = s[3, 1] = 0.5
        return s

    @property
    def phi(self) -> Array:
        """``phi_k = [U_x, U_y, dU_x/dt, dU_y/dt]`` (n, 4)."""
        return np.column_stack([self.u, self.udot])

    @property
    def Lf(self) -> Array:
        """``L_fk = (Q_fk + S_f) phi_k / 2`` (n, 4), before eq. 16."""
        return 0.5 * np.einsum("nij,nj->ni", self.Qf + self.S_f(), self.phi)

    def range2(self, theta: Array) -> Array:
        """``R_k^2 = theta^T Q_k theta - 2 L_k^T theta + rho_k^2`` (eq. 8)."""
        return (np.einsum("i,nij,j->n", theta, self.Q, theta) - 2.0 * self.L @ theta
                + self.rho2)

    def q_minus_l(self, theta: Array) -> Array:
        """``Q_k theta - L_k`` (n, 4) = half the gradient of ``R_k^2``."""
        return np.einsum("nij,j->ni", self.Q, theta) - self.L

    def radial_velocity(self, theta: Array) -> Array:
        """``v_k`` of eq. 12 (= eq. 6, positive when the target recedes; tmakit's range
        rate)."""
        qf = self.Qf
        phi = self.phi
        num = (np.einsum("i,nij,j->n", theta, qf, theta)
               - np.einsum("ni,nij,j->n", phi, qf + self.S_f(), theta)
               + np.einsum("ni,ij,nj->n", phi, self.S_f(), phi) + self.uz * self.uzdot)
        return num / np.sqrt(self.range2(theta))

    def grad_radial_velocity(self, theta: Array) -> Array:
        """``dh_k/dtheta = dv_k/dtheta`` (n, 4), eq. 16."""
        r2 = self.range2(theta)
        r = np.sqrt(r2)
        v = self.radial_velocity(theta)
        qft = np.einsum("nij,j->ni", self.Qf, theta)
        return (2.0 * (qft - self.Lf) / r[:, None]
                - self.q_minus_l(theta) * (v / r2)[:, None])


def carrier_guess(meas: MeasurementSet) -> float:
    """The carrier implied by the data: median received frequency, or 1.9 GHz without any."""
    f = meas.value_si[meas.kind == "frequency"]
    return float(np.median(f)) if f.size else DEFAULT_CARRIER


def _condition(a: Array) -> float:
    if a.size == 0:
        return float("nan")
    s = np.linalg.svd(a, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def _equilibrate(a: Array) -> tuple[Array, Array]:
    scale = np.linalg.norm(a, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return a / scale, scale


# -- the estimator ---------------------------------------------------------------------------
def gu_direct(meas: MeasurementSet, motion: MotionModel,
              init: Mapping[str, float] | ArrayLike | None, max_iter: int = 50,
              kinds: str | Sequence[str] | None = None, c0: float | None = None,
              tol: float = 1e-8, normal_equations: bool = False) -> EstimateResult:
    """000_bc54bd8c50e47249.txt §3: iterative LS on ``theta_pf = [theta, C/C_0, c/f_s]``.

    ``kinds`` selects power only (``"power"``, ``theta_p = [theta, C/C_0]``, eq. 11), Doppler
    only (``"frequency"``, ``theta_f = [theta, c/f_s]``, eqs. 14-16) or both (default: whatever
    the data hold).  ``init`` is the starting ``theta`` (by name or as a vector); the nuisance
    entries need no start (A and B depend on theta alone; Sigma_f takes f_s from the latest
    ``c/f_s``, at first from the median received frequency).  ``c0`` defaults to the free-space
    constant at that carrier (1.9 GHz without frequency data).

    Converged when the update of theta is below ``tol`` relative (``tol * (1 + |theta|)``,
    about 5e-5 m on gu2007); diverged when the iterate becomes non-finite, a range non-positive,
    or the ranges grow more than 1e4-fold.  The conditioning sets a floor under the update in
    double precision: on gu2007 it stalls at ~1e-5 m (equilibrated least squares) and at
    ~5e-4 m with ``normal_equations=True``, so a tighter ``tol`` reports "did not converge"
    although the estimate is settled far below its std (``extra["update_norms"]``).

    The covariance is ``D^-1`` at the last iterate (Sigma scaled with the actual noise, so std
    is in metres and m/s); the nuisance values are ``power_constant_db = 10 log10(C_0 C/C_0)``
    and ``carrier = c / (c/f_s)`` with delta-method std.  ``extra`` holds the condition numbers
    per iteration (see the module docstring) and the update norms.
    """
    method = "gu-direct"
    check_planar_cv(motion, method)
    kinds_used, sub = select_kinds(meas, kinds, method)
    theta = initial_theta(motion, init, method)
    c = SPEED_OF_LIGHT
    power = sub.kind == "power"
    freq = sub.kind == "frequency"
    geo = PlanarGeometry.from_rows(sub, motion)
    gp, gf = geo.take(np.flatnonzero(power)), geo.take(np.flatnonzero(freq))
    p_hat = power_watts(sub)
    snr = snr_from_sigma_db(sub.sigma_si[power])
    f_hat = sub.value_si[freq]
    sigma_f = sub.sigma_si[freq]
    fs = carrier_guess(sub)
    c0 = free_space_constant(fs) if c0 is None else float(c0)
    # Columns: theta (4), then C/C_0 if power, then c/f_s if frequency.
    cols = 4 + len(kinds_used)
    j_c = 4 if "power" in kinds_used else None
    j_f = cols - 1 if "frequency" in kinds_used else None

    def system(th: Array, fs_now: float) -> tuple[Array, Array, Array, Array]:
        """Weighted A, weighted B, the power-row mask, the power-range check."""
        a = np.zeros((len(sub), cols))
        b = np.zeros(len(sub))
        w = np.zeros(len(sub))
        r2p = gp.range2(th)
        if j_c is not None:
            a[power, :4] = -2.0 * gp.q_minus_l(th)                # 2 (L_k - Q_k theta)^T
            a[power, j_c] = c0 / p_hat                            # C_0 / P_k
            b[power] = gp.rho2 - np.einsum("i,nij,j->n", th, gp.Q, th)
            w[power] = np.sqrt(snr) / np.where(r2p > 0, r2p, np.nan)  # Sigma_p^-1/2
        if j_f is not None:
            grad = gf.grad_radial_velocity(th)
            a[freq, :4] = grad
            a[freq, j_f] = f_hat
            b[freq] = grad @ th + c - gf.radial_velocity(th)
            w[freq] = fs_now / (c * sigma_f)                      # Sigma_f^-1/2
        return a * w[:, None], b * w, w, r2p

    history: dict[str, list[float]] = {"condition_numbers": [], "condition_numbers_power": [],
                                       "condition_numbers_doppler": [],
                                       "condition_numbers_equilibrated": [],
                                       "update_norms": []}
    status, message = NOT_CONVERGED, ""
    x = np.full(cols, np.nan)
    iterations = 0
    far = DIVERGENCE_FACTOR * max(float(np.sqrt(np.max(geo.range2(theta)))), 1e3)
    for it in range(1, max_iter + 1):
        iterations = it
        aw, bw, _, _ = system(theta, fs)
        if not (np.all(np.isfinite(aw)) and np.all(np.isfinite(bw))):
            status, message = DIVERGED, "the iterate left the region where the model is defined"
            break
        history["condition_numbers"].append(_condition(aw))
        if j_c is not None:
            history["condition_numbers_power"].append(_condition(aw[power][:, [0, 1, 2, 3,
                                                                                j_c]]))
        if j_f is not None:
            history["condition_numbers_doppler"].append(_condition(aw[freq][:, [0, 1, 2, 3,
                                                                               j_f]]))
        a_eq, scale = _equilibrate(aw)
        history["condition_numbers_equilibrated"].append(_condition(a_eq))
        if normal_equations:
            try:
                x = np.linalg.solve(aw.T @ aw, aw.T @ bw)     # D_i^-1 N_i as printed
            except np.linalg.LinAlgError:
                status, message = DIVERGED, "D_i is singular to working precision"
                break
        else:
            x = np.linalg.lstsq(a_eq, bw, rcond=None)[0] / scale
        new = x[:4]
        if not np.all(np.isfinite(x)):
            status, message = DIVERGED, "the iterate became non-finite"
            break
        step = new - theta
        theta = new
        history["update_norms"].append(float(np.linalg.norm(step)))
        if j_f is not None and x[j_f] > 0:
            fs = c / x[j_f]
        stop = iteration_stop(theta, step, geo.range2(theta), far, tol)
        if stop is not None:
            status, message = stop
            break
    return _direct_result(theta, x, status, message, iterations, history, system, fs, sub,
                          motion, kinds_used, j_c, j_f, c0, cols)


def _direct_result(theta, x, status, message, iterations, history, system, fs, sub, motion,
                   kinds_used, j_c, j_f, c0, cols) -> EstimateResult:
    c = SPEED_OF_LIGHT
    p = motion.n_params
    names_nu = [{"power": "power_constant_db", "frequency": "carrier"}[k] for k in kinds_used]
    extra: dict[str, object] = {k: v for k, v in history.items() if v}
    extra["theta_pf"] = [float(v) for v in x]
    extra["kinds"] = list(kinds_used)
    extra["c0"] = c0
    if status == DIVERGED or not np.all(np.isfinite(theta)):
        nan = np.full(p, np.nan)
        return EstimateResult(motion.param_names, nan, nan, np.full((p, p), np.nan),
                              {n: (np.nan, np.nan) for n in names_nu}, DIVERGED, iterations,
                              np.inf, len(sub) - cols, "gu-direct", motion, None, 1,
                              message or "diverged", extra)
    aw, bw, _, _ = system(theta, fs)
    a_eq, scale = _equilibrate(aw)
    _, s, vt = np.linalg.svd(a_eq, full_matrices=False)
    extra["singular_values"] = [float(v) for v in np.linalg.svd(aw, compute_uv=False)]
    with np.errstate(divide="ignore"):
        cov_eq = (vt.T / s ** 2) @ vt                 # (A_w^T A_w)^-1 in scaled columns
    cov = cov_eq / np.outer(scale, scale)            # D^-1
    std_all = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    resid = aw @ x - bw
    chi2 = float(resid @ resid)
    nuis: dict[str, tuple[float, float]] = {}
    notes = []
    if j_c is not None:
        r = x[j_c]
        if r > 0:
            nuis["power_constant_db"] = (float(10.0 * np.log10(c0 * r)),
                                         float(_TEN_OVER_LN10 * std_all[j_c] / r))
        else:
            nuis["power_constant_db"] = (np.nan, np.nan)
            notes.append(f"C/C_0 came out non-positive ({r:.3g}), the failure §4 warns of")
    if j_f is not None:
        r = x[j_f]
        nuis["carrier"] = (float(c / r), float(c * std_all[j_f] / r ** 2))
    conds = history["condition_numbers"]
    text = (f"condition number of the weighted A at the last iteration: {conds[-1]:.3g}"
            if conds else "")
    if history["condition_numbers_doppler"]:
        text += f" (Doppler part {history['condition_numbers_doppler'][-1]:.3g})"
    if history["condition_numbers_equilibrated"]:
        text += (f"; {history['condition_numbers_equilibrated'][-1]:.3g} with its columns "
                 "scaled to unit norm")
    if status == NOT_CONVERGED:
        notes.insert(0, "the iteration limit was reached before the update became small")
    message = "; ".join([*notes, text]) if text else "; ".join(notes)
    return EstimateResult(motion.param_names, theta.copy(), std_all[:p], cov[:p, :p], nuis,
                          status, iterations, chi2, len(sub) - cols, "gu-direct", motion, None,
                          1, message, extra)
