"""Gauss–Newton on the 7-parameter vector of the Doppler-tracking lecture notes.

``x = [X_N Y_N Z_N V_x V_y V_z f_o]`` from received frequencies ("Linearize the Nonlinear
Model", "Iterating to the Solution"), with tmakit's sign conventions (physical velocity and
Doppler sign).  With one receiver ``H^T R^-1 H`` has rank 4 of 7: the update is the
minimum-norm solution on the observable subspace and the result says ``unobservable``.  It
stops when ``sqrt(dx^T H^T R^-1 H dx) < tol``; ranges growing 1e4-fold mean ``diverged``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..core.arrays import Array
from ..core.linalg import normalised_eigh
from ..data import MeasurementSet
from ..motion import ConstantVelocity, MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..results.estimate import EstimateResult, assemble_result
from ..results.observability import RANK_TOL
from ..results.status import UNOBSERVABLE
from .estimator import Init, PaperMethod
from .gu_direct import DIVERGENCE_FACTOR, initial_theta


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
    rel = obs.motion.states(theta, obs.meas.time) - obs.meas.sensor_state
    return float(np.max(np.linalg.norm(rel[:, :3], axis=1)))


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

    ``motion`` must be ``ConstantVelocity(3, ref_time=t_N)``, ``t_N`` the last sample time.

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

