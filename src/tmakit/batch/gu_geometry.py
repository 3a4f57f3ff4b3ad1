"""The pieces shared by the papers' local methods.

These are Gu et al. (2007) §3 and §4 and the Doppler-tracking lecture notes' Gauss–Newton:
the sensor-side geometry of Gu et al. (2007), eqs. 7, 8, 12 and 16 (:class:`PlanarGeometry`),
the choice of rows and of the start, SNR from a power sigma, and the test that ends an
iteration.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..results.status import CONVERGED, DIVERGED, Status

PAPER_KINDS = ("power", "frequency")
"""The measurement kinds of Gu et al. (2007), in the column order of theta_pf."""

NUISANCE_NAMES = {"power": "power_constant_db", "frequency": "carrier"}
"""The name tmakit reports for the nuisance parameter each kind's column stands for."""
TEN_OVER_LN10 = 10.0 / np.log(10.0)
"""``10 / ln 10``: dB per unit of relative power change."""
DIVERGENCE_FACTOR = 1e4
"""An iterate whose largest range exceeds this multiple of the largest range at the start (or
of 1 km) is declared diverged."""


def iteration_stop(theta: NDArray[np.float64], step: NDArray[np.float64],
                   range2: NDArray[np.float64], far: float, tol: float
                   ) -> tuple[Status, str] | None:
    """Decide how an iteration of the papers' fixed-point methods ends after an update.

    References
    ----------
    Gu et al. (2007), §3 and §4.
    """
    if np.any(range2 <= 0):
        return DIVERGED, "a range became non-positive"
    if np.max(range2) > far ** 2:
        return DIVERGED, (f"the ranges grew more than {DIVERGENCE_FACTOR:g}-fold from the "
                          "start")
    if np.linalg.norm(step) <= tol * (1.0 + np.linalg.norm(theta)):
        return CONVERGED, ""
    return None


DEFAULT_CARRIER = 1.9e9
"""Carrier (Hz) assumed for C_0 when the data hold no frequency (Gu et al. (2007) §5)."""


def check_planar_cv(motion: MotionModel, method: str) -> ConstantVelocity:
    """Refuse a motion model other than 2-D constant velocity; give it back as one.

    References
    ----------
    Gu et al. (2007), eq. 1.
    """
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
    if isinstance(init, Mapping):
        return motion.theta({k: v for k, v in init.items() if k in motion.param_names})
    theta = np.asarray(init, dtype=float).reshape(-1)
    if theta.shape != (motion.n_params,):
        raise ValueError(f"{method}: init must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)})")
    return theta


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

    Parameters
    ----------
    t : ndarray, shape (n,)
        s from the motion's reference time.
    u, udot : ndarray, shape (n, 2)
        Horizontal position (m) and velocity (m/s).
    uz, uzdot : ndarray, shape (n,)
        Height (m) and vertical velocity (m/s).

    References
    ----------
    Gu et al. (2007), eqs. 7, 8, 12 and 16.
    """

    t: Array      # (n,)
    u: Array      # (n, 2)
    udot: Array   # (n, 2)
    uz: Array     # (n,)
    uzdot: Array  # (n,)

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
    """Return the carrier implied by the data.

    References
    ----------
    Gu et al. (2007), §5 (the 1.9 GHz carrier).
    """
    f = meas.value_si[meas.kind == "frequency"]
    return float(np.median(f)) if f.size else DEFAULT_CARRIER
