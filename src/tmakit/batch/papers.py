"""The papers' local iterations, started from ``init`` or from tmakit's likelihood grid point.

Gu et al. (2007): §3, the direct iterative least squares (:class:`GuDirect`), the nuisance
C/C_0 and c/f_s in the parameter vector, power rows (eqs. 9-11) and Doppler rows (eqs. 14-16)
linearised and iterated ``theta = D^-1 N``, its columns equilibrated and solved by SVD
(``normal_equations=True``: as printed); §4, ratios of neighbouring power (eqs. 19-25) and
Doppler (eqs. 26-32) samples, stacked (eqs. 33-34) (:class:`RatioMethod`; eqs. 27-28 where eq.
31 prints the opposite sign, ``covariance="paper"`` the printed covariance whose power
off-diagonal lacks a minus sign: docs/references.md).  Both share the sensor-side geometry
(:class:`PlanarGeometry`, eqs. 7-8, 12, 16).  The Doppler-tracking lecture notes' Gauss–Newton
on ``[X_N Y_N Z_N V_x V_y V_z f_o]`` ("Linearize the Nonlinear Model", "Iterating to the
Solution"; :class:`LectureGaussNewton`): with one receiver ``H^T R^-1 H`` has rank 4 of 7, the
update the minimum-norm solution and the result ``unobservable``.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_solve_banded, cholesky_banded, solve_banded

from ..core.arrays import Array
from ..core.linalg import normalised_eigh
from ..core.units import SPEED_OF_LIGHT, free_space_constant
from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..results.estimate import (
    EstimateResult,
    assemble_result,
    diverged_result,
    result_from_covariance,
)
from ..results.observability import RANK_TOL
from ..results.status import CONVERGED, DIVERGED, NOT_CONVERGED, UNOBSERVABLE, Status
from .estimator import BatchEstimator, Init, Options, theta_from_init
from .init import grid_start

__all__ = ["GuDirect", "LectureGaussNewton", "PaperMethod", "PlanarGeometry", "RatioMethod",
           "doppler_bands", "nuisance_given_theta", "power_bands", "tridiagonal"]


GRID_START_NOTE = "started from tmakit's likelihood-grid point (the papers' methods are local)"


def check_paper_options(method: str, options: Options) -> None:
    """Refuse nuisance models the papers do not have: carrier drift, path-loss exponent ≠ 2."""
    opts = dict(options or {})
    if opts.get("frequency", {}).get("drift", False):
        raise ValueError(f"{method}: the paper's model has no carrier drift; use method 'ml' "
                         "for drift")
    exponent = opts.get("power", {}).get("exponent", 2.0)
    if exponent is None or float(exponent) != 2.0:  # type: ignore[arg-type]
        raise ValueError(f"{method}: the paper's model has the path-loss exponent 2; use "
                         "method 'ml' for another or an unknown exponent")


@dataclass(frozen=True, eq=False)
class PaperMethod(BatchEstimator):
    """A local method of the papers, started from ``init`` or from tmakit's grid point."""

    init: Init = None
    options: Options = None

    start_kinds: ClassVar[tuple[str, ...]] = ()  # the kinds its grid start is scored on

    def __post_init__(self) -> None:
        """Refuse a nuisance model the papers do not have."""
        check_paper_options(self.name, self.options)

    @property
    def kinds_wanted(self) -> tuple[str, ...] | None:
        """The kinds asked for (None: every kind the method can use)."""
        kinds = getattr(self, "kinds", None)
        return None if kinds is None else (kinds,) if isinstance(kinds, str) else tuple(kinds)

    @abstractmethod
    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the paper's iteration from ``init``.

        Parameters
        ----------
        meas, motion, init
            The data, a constant-velocity model and the start (None raises ``ValueError``).

        Returns
        -------
        EstimateResult
        """

    def start_rows(self, meas: MeasurementSet) -> MeasurementSet:
        """Return the rows of the kinds the method uses (all when none), to score the start on."""
        kinds = [k for k in self.start_kinds if k in meas.kinds]
        wanted = self.kinds_wanted
        if wanted is not None:
            kinds = [k for k in kinds if k in wanted]
        return meas.take(np.isin(meas.kind, kinds)) if kinds else meas

    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Run the paper's iteration from ``init``, or from tmakit's grid point without one."""
        if self.init is not None:
            return self.iterate(meas, motion, self.init)
        start = grid_start(self.start_rows(meas), motion)
        result = self.iterate(meas, motion, start)
        result.extra["start"] = "grid"
        result.extra["start_point"] = [float(v) for v in np.asarray(start, dtype=float)]
        result.message = (f"{GRID_START_NOTE}; {result.message}" if result.message
                          else GRID_START_NOTE)
        return result


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


def fixed_point(step: Callable[[Array], Array | str], theta: Array,
                range2: Callable[[Array], Array], max_iter: int, tol: float, norms: list[float]
                ) -> tuple[Array, Status, str, int]:
    """Iterate ``theta = step(theta)`` (a str: why it diverged) to :func:`iteration_stop`."""
    far = DIVERGENCE_FACTOR * max(float(np.sqrt(np.max(range2(theta)))), 1e3)
    for it in range(1, max_iter + 1):
        new = step(theta)
        if isinstance(new, str):
            return theta, DIVERGED, new, it
        norms.append(float(np.linalg.norm(new - theta)))
        stop = iteration_stop(new, new - theta, range2(new), far, tol)
        theta = new
        if stop is not None:
            return theta, stop[0], stop[1], it
    return theta, NOT_CONVERGED, "", max_iter


LEFT_THE_MODEL = "the iterate left the region where the model is defined"
NON_FINITE = "the iterate became non-finite"


DEFAULT_CARRIER = 1.9e9  # Hz, for C_0 when the data hold no frequency (Gu et al. (2007) §5)


def check_planar_cv(motion: MotionModel, method: str) -> ConstantVelocity:
    """Refuse a motion model other than 2-D constant velocity (Gu et al. (2007), eq. 1)."""
    if not isinstance(motion, ConstantVelocity) or motion.dim != 2:
        raise ValueError(f"{method}: written for 2-D constant velocity (Gu et al. "
                         f"(2007), eq. 1; motion cv2d, ConstantVelocity(2)); got {motion!r}")
    return motion


def select_kinds(meas: MeasurementSet, wanted: tuple[str, ...] | None, method: str
                 ) -> tuple[tuple[str, ...], MeasurementSet]:
    """Choose the kinds to use (in :data:`PAPER_KINDS` order) and the rows of those kinds."""
    if wanted is None:
        other = sorted(set(meas.kinds) - set(PAPER_KINDS))
        if other:
            raise ValueError(f"{method}: uses power and frequency only, the data also hold "
                             f"{', '.join(other)}; pass kinds= or select the rows")
        chosen = [k for k in PAPER_KINDS if k in meas.kinds]
    else:
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
    """The sensor side of Gu et al. (2007), eqs. 7, 8, 12 and 16 for a set of samples."""

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
    """Gu et al. (2007) §3: iterative LS on ``theta_pf = [theta, C/C_0, c/f_s]``, cov ``D^-1``.

    Parameters
    ----------
    init, options : optional
        As for :class:`PaperMethod`: ``[x_0, y_0, v_x, v_y]`` (m, m/s).
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

    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the iteration of Gu et al. (2007) §3 (eqs. 7, 8, 12, 16) from ``init``."""
        method = self.name
        cv = check_planar_cv(motion, method)
        kinds_used, sub = select_kinds(meas, self.kinds_wanted, method)
        theta = initial_theta(motion, init, method)
        system = _DirectSystem(sub, cv, kinds_used, self.c0)
        history: dict[str, list[float]] = {"condition_numbers": [],
                                           "condition_numbers_power": [],
                                           "condition_numbers_doppler": [],
                                           "condition_numbers_equilibrated": [],
                                           "update_norms": []}
        x = np.full(system.cols, np.nan)
        fs = system.fs

        def step(th: Array) -> Array | str:
            nonlocal x, fs
            aw, bw = system.build(th, fs)
            if not (np.all(np.isfinite(aw)) and np.all(np.isfinite(bw))):
                return LEFT_THE_MODEL
            system.record(history, aw)
            a_eq, scale = _equilibrate(aw)
            history["condition_numbers_equilibrated"].append(_condition(a_eq))
            if self.normal_equations:
                try:
                    x = np.linalg.solve(aw.T @ aw, aw.T @ bw)     # D_i^-1 N_i as printed
                except np.linalg.LinAlgError:
                    return "D_i is singular to working precision"
            else:
                x = np.linalg.lstsq(a_eq, bw, rcond=None)[0] / scale
            if not np.all(np.isfinite(x)):
                return NON_FINITE
            if system.j_f is not None and x[system.j_f] > 0:
                fs = SPEED_OF_LIGHT / x[system.j_f]
            return np.asarray(x[:4], dtype=np.float64)

        theta, status, message, iterations = fixed_point(
            step, theta, system.geo.range2, self.max_iter, self.tol, history["update_norms"])
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

    Parameters
    ----------
    init, options : optional
        As for :class:`PaperMethod`: ``[x_0, y_0, v_x, v_y]`` (m, m/s).
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

    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the iteration of Gu et al. (2007) §4 (eqs. 19-34) from ``init``."""
        cv = check_planar_cv(motion, "ratio method")
        kinds_used, sub = select_kinds(meas, self.kinds_wanted, "ratio method")
        theta = initial_theta(motion, init, "ratio method")
        system = _RatioSystem(sub, cv, kinds_used, self.covariance)
        if system.n < motion.n_params:
            raise ValueError(f"ratio method: {system.n} ratios cannot determine "
                             f"{motion.n_params} parameters")

        def step(th: Array) -> Array | str:
            lmat, psi, diag, off = system.build(th)
            if not (np.all(np.isfinite(lmat)) and np.all(np.isfinite(psi))
                    and np.all(np.isfinite(diag)) and np.all(np.isfinite(off))):
                return LEFT_THE_MODEL
            try:
                band = Banded(diag, off)
            except np.linalg.LinAlgError:
                return "the covariance Sigma is not positive definite"
            lw_eq, scale = _equilibrate(band.whiten(lmat))
            new = np.linalg.lstsq(lw_eq, band.whiten(psi), rcond=None)[0] / scale  # D^-1 N
            return new if np.all(np.isfinite(new)) else NON_FINITE

        steps: list[float] = []
        theta, status, message, iterations = fixed_point(
            step, theta, system.geo.range2, self.max_iter, self.tol, steps)
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


def _check(meas: MeasurementSet, motion: MotionModel) -> float:
    t_n = float(np.max(meas.time))
    if not isinstance(motion, ConstantVelocity) or motion.dim != 3:
        raise ValueError("lecture-gn: the Doppler-tracking lecture notes estimate "
                         "[X_N Y_N Z_N Vx Vy Vz f_o]: the motion must be "
                         f"ConstantVelocity(3, ref_time=t_N) (cv3d), got {motion!r}")
    if abs(motion.ref_time - t_n) > 1e-9 * max(1.0, abs(t_n)):
        raise ValueError(f"lecture-gn: the parameters are referenced at the final sample time "
                         f"t_N = {t_n:g} s; use ConstantVelocity(3, ref_time={t_n:g}) "
                         f"(got ref_time={motion.ref_time:g})")
    other = sorted(set(meas.kinds) - {"frequency"})
    if other:
        raise ValueError("lecture-gn: uses received frequencies only; the data also hold "
                         f"{', '.join(other)}")
    return t_n


def _max_range(obs: ObservationModel, theta: Array) -> float:
    return float(np.sqrt(np.max(obs.squared_ranges(theta))))


def _pinv_step(hw: Array, rw: Array) -> tuple[Array, int, Array]:
    """Return ``(H^T R^-1 H)^+ H^T R^-1 df`` (normalised coordinates), rank and information."""
    info = hw.T @ hw
    evals, evecs, scale = normalised_eigh(info)
    keep = evals > RANK_TOL * max(float(evals[-1]), np.finfo(float).tiny)
    # The pseudo-inverse of results.bound.pseudo_covariance applied to one vector, without
    # forming the matrix (rank by RANK_TOL, as results.observability.analyse counts it).
    g = scale * (hw.T @ rw)
    v = evecs[:, keep]
    step = scale * (v @ ((v.T @ g) / evals[keep]))
    return step, int(keep.sum()), info


def _start(obs: ObservationModel, noise: NoiseModel, init: Init) -> Array:
    """Return the starting ``x = [theta, f_o]``."""
    motion = obs.motion
    if init is None:
        raise ValueError("lecture-gn: a local method, it needs a starting point (init=...); "
                         "LectureGaussNewton() without init starts from tmakit's grid point")
    theta = initial_theta(motion, init, "lecture-gn")
    carrier = init.get("carrier") if isinstance(init, Mapping) else None
    if carrier is None:
        h0, a = obs.affine(theta)
        w = noise.whiten(a[:, 0])
        carrier = float(w @ noise.whiten(obs.values - h0) / (w @ w))
    return np.concatenate([theta, [float(carrier)]])


@dataclass(frozen=True, eq=False)
class LectureGaussNewton(PaperMethod):
    """The Doppler-tracking lecture notes: Gauss–Newton on ``[X_N Y_N Z_N V_x V_y V_z f_o]``.

    Parameters
    ----------
    init : Mapping[str, float] or array_like, optional
        The six motion parameters (m, m/s), a mapping may add ``carrier`` (Hz); default tmakit's
        grid point on the frequency rows.
    options : Mapping, optional
        Only the notes' model (no drift).
    max_iter : int, optional
        Default 50.
    tol : float, optional
        Converged when ``sqrt(dx^T H^T R^-1 H dx) < tol`` (default 1e-4).

    References
    ----------
    The Doppler-tracking lecture notes, "Linearize the Nonlinear Model" and "Iterating to the
    Solution".
    """

    max_iter: int = 50
    tol: float = 1e-4

    name: ClassVar[str] = "lecture-gn"
    start_kinds: ClassVar[tuple[str, ...]] = ("frequency",)

    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the notes' Gauss–Newton iteration from ``init``."""
        _check(meas, motion)
        obs = ObservationModel(meas, motion, {"frequency": {"drift": False}})
        noise = NoiseModel(meas)
        x = _start(obs, noise, init)
        x, iterations, converged, diverged, ranks, norms = self._gauss_newton(obs, noise, x)
        p = motion.n_params
        th, nu = x[:p], x[p:]
        cost = (0.5 * float(np.sum(noise.whiten(obs.values - obs.predict(th, nu)) ** 2))
                if np.all(np.isfinite(x)) else np.inf)
        res = assemble_result(obs, noise, th, nu, cost, iterations, converged,
                              self.name, 1, None)
        res.extra.update({"ranks": ranks, "update_norms_sigma": norms})
        if diverged:
            res.message = diverged
        if res.status == UNOBSERVABLE and res.bound is not None:
            res.message = (f"H^T R^-1 H has rank {res.bound.rank} of "
                           f"{len(res.bound.parameters)} (the lecture's admitted rank "
                           "deficiency); " + res.message)
        return res

    def _gauss_newton(self, obs: ObservationModel, noise: NoiseModel, x: Array
                      ) -> tuple[Array, int, bool, str, list[int], list[float]]:
        """Iterate; return the last ``x``, iterations, converged, why diverged, ranks, sizes."""
        p = obs.motion.n_params
        y = obs.values
        ranks: list[int] = []
        norms: list[float] = []
        converged = False
        far = DIVERGENCE_FACTOR * max(_max_range(obs, x[:p]), 1e3)
        diverged = ""
        iterations = 0
        for it in range(1, self.max_iter + 1):
            iterations = it
            th, nu = x[:p], x[p:]
            j_theta, j_nu = obs.jacobian(th, nu)
            hw = noise.whiten(np.concatenate([j_theta, j_nu], axis=1), axis=0)
            rw = noise.whiten(y - obs.predict(th, nu))
            if not (np.all(np.isfinite(hw)) and np.all(np.isfinite(rw))):
                x = np.full(x.shape, np.nan)
                break
            step, rank, info = _pinv_step(hw, rw)
            ranks.append(rank)
            x = x + step
            size = float(np.sqrt(max(float(step @ info @ step), 0.0)))
            norms.append(size)
            if not np.all(np.isfinite(x)):
                break
            if _max_range(obs, x[:p]) > far:
                diverged = (f"the ranges grew more than {DIVERGENCE_FACTOR:g}-fold from the "
                            "start (plain Gauss–Newton has no step control)")
                x = np.full(x.shape, np.nan)
                break
            if size < self.tol or np.all(np.abs(step) <= 1e-12 * (np.abs(x) + 1.0)):
                converged = True
                break
        return x, iterations, converged, diverged, ranks, norms
