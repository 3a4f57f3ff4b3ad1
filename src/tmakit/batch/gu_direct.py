"""The direct iterative least squares of Gu et al. (2007) §3, and what §3 and §4 share.

The nuisance C/C_0 and c/f_s join the parameter vector; power rows (eqs. 9-11) and Doppler rows
(eqs. 14-16) are linearised about the estimate and iterated, ``theta = D^-1 N``.  The columns
are equilibrated and solved by SVD (``normal_equations=True`` solves ``D theta = N`` as
printed); each iteration's condition numbers are in ``extra``.  The sensor-side geometry
(:class:`PlanarGeometry`, eqs. 7-8, 12, 16), the choice of rows and start and the test that
ends an iteration are shared with :mod:`tmakit.batch.ratios` and :mod:`tmakit.batch.lecture`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.units import SPEED_OF_LIGHT, free_space_constant
from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..results.estimate import EstimateResult, diverged_result, result_from_covariance
from ..results.status import CONVERGED, DIVERGED, NOT_CONVERGED, Status
from .estimator import Init, PaperMethod, kinds_tuple, theta_from_init

__all__ = ["GuDirect", "PlanarGeometry"]

#: The measurement kinds of Gu et al. (2007), in the column order of theta_pf.
PAPER_KINDS = ("power", "frequency")
#: The nuisance parameter each kind's column stands for, by tmakit's name.
NUISANCE_NAMES = {"power": "power_constant_db", "frequency": "carrier"}
TEN_OVER_LN10 = 10.0 / np.log(10.0)  # dB per unit of relative power change
#: Diverged: the largest range exceeds this multiple of the start's (or of 1 km).
DIVERGENCE_FACTOR = 1e4


def iteration_stop(theta: NDArray[np.float64], step: NDArray[np.float64],
                   range2: NDArray[np.float64], far: float, tol: float
                   ) -> tuple[Status, str] | None:
    """Decide how an iteration of the papers' fixed-point methods ends (Gu et al. (2007) §3-4)."""
    if np.any(range2 <= 0):
        return DIVERGED, "a range became non-positive"
    if np.max(range2) > far ** 2:
        return DIVERGED, (f"the ranges grew more than {DIVERGENCE_FACTOR:g}-fold from the "
                          "start")
    if np.linalg.norm(step) <= tol * (1.0 + np.linalg.norm(theta)):
        return CONVERGED, ""
    return None


DEFAULT_CARRIER = 1.9e9  # Hz, for C_0 when the data hold no frequency (Gu et al. (2007) §5)


def check_planar_cv(motion: MotionModel, method: str) -> ConstantVelocity:
    """Refuse a motion model other than 2-D constant velocity (Gu et al. (2007), eq. 1)."""
    if not isinstance(motion, ConstantVelocity) or motion.dim != 2:
        raise ValueError(f"{method}: written for 2-D constant velocity (Gu et al. "
                         f"(2007), eq. 1; motion cv2d, ConstantVelocity(2)); got {motion!r}")
    return motion


def select_kinds(meas: MeasurementSet, kinds: str | Sequence[str] | None, method: str
                 ) -> tuple[tuple[str, ...], MeasurementSet]:
    """Choose the kinds to use (in :data:`PAPER_KINDS` order) and the rows of those kinds."""
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
    """Return a starting parameter vector from a mapping by name or a vector."""
    if init is None:
        raise ValueError(f"{method}: a local method, it needs a starting point (init=...); "
                         "its estimator object without init (tmakit.batch.METHODS) starts "
                         "from tmakit's grid point")
    return theta_from_init(motion, init, f"{method}: ", named_only=True)


def snr_from_sigma_db(sigma_db: ArrayLike) -> Array:
    """Return SNR_p (linear) of a power whose standard deviation is ``sigma_db`` (dB)."""
    return (TEN_OVER_LN10 / np.asarray(sigma_db, dtype=float)) ** 2


def power_watts(meas: MeasurementSet) -> Array:
    """Return the linear received power of the power rows, in row order."""
    return 10.0 ** (meas.value_si[meas.kind == "power"] / 10.0)


@dataclass(frozen=True)
class PlanarGeometry:
    """The sensor side of Gu et al. (2007), eqs. 7, 8, 12 and 16 for a set of samples.

    A sensor off the plane z = 0 adds ``U_z^2`` to ``rho_k^2`` and ``U_z dU_z/dt`` to eq. 12.
    """

    t: Array      # (n,) s from the motion's reference time
    u: Array      # (n, 2) horizontal position, m
    udot: Array   # (n, 2) horizontal velocity, m/s
    uz: Array     # (n,) height, m
    uzdot: Array  # (n,) vertical velocity, m/s

    @classmethod
    def from_rows(cls, meas: MeasurementSet, motion: ConstantVelocity) -> PlanarGeometry:
        """Build the geometry of the rows of ``meas``, times relative to ``motion.ref_time``."""
        s = meas.sensor_state
        return cls(meas.time - motion.ref_time, s[:, 0:2].copy(), s[:, 3:5].copy(),
                   s[:, 2].copy(), s[:, 5].copy())

    def take(self, idx: ArrayLike) -> PlanarGeometry:
        """Return the geometry of the samples ``idx``."""
        i = np.asarray(idx)
        return PlanarGeometry(self.t[i], self.u[i], self.udot[i], self.uz[i], self.uzdot[i])

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

    @property
    def Qf(self) -> Array:
        """``Q_fk`` (n, 4, 4) of eq. 12."""
        q = np.zeros((self.t.size, 4, 4))
        q[:, 0, 2] = q[:, 2, 0] = q[:, 1, 3] = q[:, 3, 1] = 0.5
        q[:, 2, 2] = q[:, 3, 3] = self.t
        return q

    @staticmethod
    def S_f() -> Array:
        """Return ``S_f`` (4, 4) of eq. 12 (dimensionless)."""
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
        """Return ``R_k^2 = theta^T Q_k theta - 2 L_k^T theta + rho_k^2`` (eq. 8)."""
        return (np.einsum("i,nij,j->n", theta, self.Q, theta) - 2.0 * self.L @ theta
                + self.rho2)

    def q_minus_l(self, theta: Array) -> Array:
        """Return ``Q_k theta - L_k``, half the gradient of ``R_k^2``."""
        return np.einsum("nij,j->ni", self.Q, theta) - self.L

    def radial_velocity(self, theta: Array) -> Array:
        """Return ``v_k`` of eq. 12 (= eq. 6), positive when the target recedes."""
        qf = self.Qf
        phi = self.phi
        num = (np.einsum("i,nij,j->n", theta, qf, theta)
               - np.einsum("ni,nij,j->n", phi, qf + self.S_f(), theta)
               + np.einsum("ni,ij,nj->n", phi, self.S_f(), phi) + self.uz * self.uzdot)
        return num / np.sqrt(self.range2(theta))

    def grad_radial_velocity(self, theta: Array) -> Array:
        """Return ``dh_k/dtheta = dv_k/dtheta`` of eq. 16."""
        r2 = self.range2(theta)
        r = np.sqrt(r2)
        v = self.radial_velocity(theta)
        qft = np.einsum("nij,j->ni", self.Qf, theta)
        return (2.0 * (qft - self.Lf) / r[:, None]
                - self.q_minus_l(theta) * (v / r2)[:, None])


def carrier_guess(meas: MeasurementSet) -> float:
    """Return the carrier implied by the data (else Gu et al. (2007) §5's 1.9 GHz)."""
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


class _DirectSystem:
    """Gu et al. (2007) §3 apart from theta; the weighted system at a theta (eqs. 11, 14-16)."""

    def __init__(self, sub: MeasurementSet, motion: ConstantVelocity, kinds: tuple[str, ...],
                 c0: float | None) -> None:
        self.sub = sub
        self.kinds = kinds
        self.power = sub.kind == "power"
        self.freq = sub.kind == "frequency"
        self.geo = PlanarGeometry.from_rows(sub, motion)
        self.gp = self.geo.take(np.flatnonzero(self.power))
        self.gf = self.geo.take(np.flatnonzero(self.freq))
        self.p_hat = power_watts(sub)
        self.snr = snr_from_sigma_db(sub.sigma_si[self.power])
        self.f_hat = sub.value_si[self.freq]
        self.sigma_f = sub.sigma_si[self.freq]
        self.fs = carrier_guess(sub)
        self.c0 = free_space_constant(self.fs) if c0 is None else float(c0)
        # Columns: theta (4), then C/C_0 if power, then c/f_s if frequency.
        self.cols = 4 + len(kinds)
        self.j_c = 4 if "power" in kinds else None
        self.j_f = self.cols - 1 if "frequency" in kinds else None

    def build(self, th: Array, fs_now: float) -> tuple[Array, Array]:
        """Weighted A and weighted B at ``th``, with ``f_s`` in Sigma_f at ``fs_now``."""
        c = SPEED_OF_LIGHT
        power, freq, gp, gf = self.power, self.freq, self.gp, self.gf
        n = len(self.sub)
        a = np.zeros((n, self.cols))
        b = np.zeros(n)
        w = np.zeros(n)
        r2p = gp.range2(th)
        if self.j_c is not None:
            a[power, :4] = -2.0 * gp.q_minus_l(th)                # 2 (L_k - Q_k theta)^T
            a[power, self.j_c] = self.c0 / self.p_hat             # C_0 / P_k
            b[power] = gp.rho2 - np.einsum("i,nij,j->n", th, gp.Q, th)
            w[power] = np.sqrt(self.snr) / np.where(r2p > 0, r2p, np.nan)  # Sigma_p^-1/2
        if self.j_f is not None:
            grad = gf.grad_radial_velocity(th)
            a[freq, :4] = grad
            a[freq, self.j_f] = self.f_hat
            b[freq] = grad @ th + c - gf.radial_velocity(th)
            w[freq] = fs_now / (c * self.sigma_f)                 # Sigma_f^-1/2
        return a * w[:, None], b * w

    def record(self, history: dict[str, list[float]], aw: Array) -> None:
        """Record the condition numbers of the weighted A, of its parts and equilibrated."""
        history["condition_numbers"].append(_condition(aw))
        if self.j_c is not None:
            history["condition_numbers_power"].append(
                _condition(aw[self.power][:, [0, 1, 2, 3, self.j_c]]))
        if self.j_f is not None:
            history["condition_numbers_doppler"].append(
                _condition(aw[self.freq][:, [0, 1, 2, 3, self.j_f]]))


@dataclass(frozen=True, eq=False)
class GuDirect(PaperMethod):
    """Gu et al. (2007) §3: iterative LS on ``theta_pf = [theta, C/C_0, c/f_s]``.

    Diverged when the iterate is non-finite, a range non-positive, or the ranges grow 1e4-fold.
    The covariance is ``D^-1`` at the last iterate; ``extra`` holds the condition numbers and
    update norms.

    Parameters
    ----------
    init, options : optional
        As for :class:`~tmakit.batch.estimator.PaperMethod`: ``[x_0, y_0, v_x, v_y]`` (m, m/s).
    max_iter : int, optional
        Default 50.
    kinds : str or sequence of str, optional
        ``"power"`` (eq. 11), ``"frequency"`` (eqs. 14-16) or both (default: what the data hold).
    c0 : float, optional
        ``C_0``; default the free-space constant at the carrier.
    tol : float, optional
        Converged when the update is below ``tol * (1 + |theta|)`` (default 1e-8).
    normal_equations : bool, optional
        Solve ``D_i theta = N_i`` as printed (default SVD on equilibrated columns).

    References
    ----------
    Gu et al. (2007), §3, eqs. 9-16.
    """

    max_iter: int = 50
    kinds: str | Sequence[str] | None = None
    c0: float | None = None
    tol: float = 1e-8
    normal_equations: bool = False

    name: ClassVar[str] = "gu-direct"
    start_kinds: ClassVar[tuple[str, ...]] = PAPER_KINDS

    @property
    def kinds_wanted(self) -> tuple[str, ...] | None:
        """The kinds asked for (None: both, as the data hold them)."""
        return kinds_tuple(self.kinds)

    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the iteration of Gu et al. (2007) §3 (eqs. 7, 8, 12, 16) from ``init``."""
        method = self.name
        cv = check_planar_cv(motion, method)
        kinds_used, sub = select_kinds(meas, self.kinds, method)
        theta = initial_theta(motion, init, method)
        system = _DirectSystem(sub, cv, kinds_used, self.c0)
        history: dict[str, list[float]] = {"condition_numbers": [],
                                           "condition_numbers_power": [],
                                           "condition_numbers_doppler": [],
                                           "condition_numbers_equilibrated": [],
                                           "update_norms": []}
        status: Status = NOT_CONVERGED
        message = ""
        x = np.full(system.cols, np.nan)
        iterations = 0
        fs = system.fs
        far = DIVERGENCE_FACTOR * max(float(np.sqrt(np.max(system.geo.range2(theta)))), 1e3)
        for it in range(1, self.max_iter + 1):
            iterations = it
            aw, bw = system.build(theta, fs)
            if not (np.all(np.isfinite(aw)) and np.all(np.isfinite(bw))):
                status, message = DIVERGED, ("the iterate left the region where the model is "
                                             "defined")
                break
            system.record(history, aw)
            a_eq, scale = _equilibrate(aw)
            history["condition_numbers_equilibrated"].append(_condition(a_eq))
            if self.normal_equations:
                try:
                    x = np.linalg.solve(aw.T @ aw, aw.T @ bw)     # D_i^-1 N_i as printed
                except np.linalg.LinAlgError:
                    status, message = DIVERGED, "D_i is singular to working precision"
                    break
            else:
                x = np.linalg.lstsq(a_eq, bw, rcond=None)[0] / scale
            new = np.asarray(x[:4], dtype=np.float64)
            if not np.all(np.isfinite(x)):
                status, message = DIVERGED, "the iterate became non-finite"
                break
            step = new - theta
            theta = new
            history["update_norms"].append(float(np.linalg.norm(step)))
            if system.j_f is not None and x[system.j_f] > 0:
                fs = SPEED_OF_LIGHT / x[system.j_f]
            stop = iteration_stop(theta, step, system.geo.range2(theta), far, self.tol)
            if stop is not None:
                status, message = stop
                break
        return _direct_result(system, motion, theta, x, fs, status, message, iterations,
                              history)


def _direct_result(system: _DirectSystem, motion: MotionModel, theta: Array, x: Array,
                   fs: float, status: Status, message: str, iterations: int,
                   history: dict[str, list[float]]) -> EstimateResult:
    """Build the result: covariance ``D^-1`` at the last iterate, nuisance values, conditions."""
    c = SPEED_OF_LIGHT
    j_c, j_f, c0 = system.j_c, system.j_f, system.c0
    names_nu = [NUISANCE_NAMES[k] for k in system.kinds]
    dof = len(system.sub) - system.cols
    extra: dict[str, object] = {k: v for k, v in history.items() if v}
    extra["theta_pf"] = [float(v) for v in x]
    extra["kinds"] = list(system.kinds)
    extra["c0"] = c0
    if status == DIVERGED or not np.all(np.isfinite(theta)):
        return diverged_result(motion, names_nu, iterations, dof, GuDirect.name,
                               message or "diverged", extra=extra)
    aw, bw = system.build(theta, fs)
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
                                         float(TEN_OVER_LN10 * std_all[j_c] / r))
        else:
            nuis["power_constant_db"] = (np.nan, np.nan)
            notes.append(f"C/C_0 came out non-positive ({r:.3g}), the failure §4 warns of")
    if j_f is not None:
        r = x[j_f]
        nuis["carrier"] = (float(c / r), float(c * std_all[j_f] / r ** 2))
    if status == NOT_CONVERGED:
        notes.insert(0, "the iteration limit was reached before the update became small")
    text = _conditioning_text(history)
    message = "; ".join([*notes, text]) if text else "; ".join(notes)
    return result_from_covariance(motion, theta, cov, nuis, status, iterations, chi2, dof,
                                  GuDirect.name, message, extra)


def _conditioning_text(history: dict[str, list[float]]) -> str:
    """Describe the condition numbers at the last iteration in words."""
    conds = history["condition_numbers"]
    text = (f"condition number of the weighted A at the last iteration: {conds[-1]:.3g}"
            if conds else "")
    if history["condition_numbers_doppler"]:
        text += f" (Doppler part {history['condition_numbers_doppler'][-1]:.3g})"
    if history["condition_numbers_equilibrated"]:
        text += (f"; {history['condition_numbers_equilibrated'][-1]:.3g} with its columns "
                 "scaled to unit norm")
    return text
