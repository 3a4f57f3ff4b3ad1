"""The posterior CRB as a recursion object, one step at a time.

``J_{k+1} = (Q_k + F J_k^{-1} F^T)^{-1} + Gamma_{k+1}``, ``Gamma = E[H^T R^-1 H]``
(Tichavský, Muravchik & Nehorai (1998); Hurtado & Nehorai (2008), eqs. 10-11), the prediction
in information form by Woodbury; :func:`pcrb_over_runs` runs it over a Monte Carlo's runs.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.linalg import symmetrise
from ..motion.dynamics import NearlyConstantVelocity
from ..observation import MeasurementGroup

#: A prediction over less than this (s) is no step (the state stays where it is).
MIN_STEP = 1e-12
#: The states of :meth:`PosteriorInformation.expected_information` must be at the group's
#: time within this (s).
TIME_MATCH = 1e-6


def noise_factor(q_mat: Array) -> Array:
    """Return ``G`` (n, r) with ``G G^T = Q`` (eigen-decomposition; rounding negatives dropped)."""
    evals, evecs = np.linalg.eigh(symmetrise(q_mat))
    top = float(evals.max()) if evals.size else 0.0
    if top <= 0.0:
        return np.zeros((q_mat.shape[0], 0))
    keep = evals > 1e-14 * top
    return cast(Array, evecs[:, keep] * np.sqrt(evals[keep]))


def predict_information(info: Array, f_inv: Array, g: Array) -> Array:
    """Return the information after a dynamics step, ``(Q + F J^{-1} F^T)^{-1}`` (eq. 10)."""
    a = symmetrise(f_inv.T @ info @ f_inv)
    if g.shape[1] == 0:
        return a
    ag = a @ g
    s = np.eye(g.shape[1]) + g.T @ ag  # >= I: Cholesky always succeeds
    chol = np.linalg.cholesky(symmetrise(s))
    half = np.linalg.solve(chol, np.swapaxes(ag, -1, -2))  # L^{-1} G^T A
    return symmetrise(a - np.swapaxes(half, -1, -2) @ half)


def information_inverse(info: Array) -> Array:
    """Invert SPD information matrices (..., n, n), diagonal-normalised, eigenvalues floored."""
    # A floored full inverse (the prior gives full rank), not the pseudo-inverse of
    # results.bound: the PCRB figures and the planners' choices depend on these numerics.
    d = np.sqrt(np.clip(np.einsum("...ii->...i", info), 1e-300, None))
    norm = info / (d[..., :, None] * d[..., None, :])
    evals, evecs = np.linalg.eigh(symmetrise(norm))
    floor = info.shape[-1] * np.finfo(float).eps * np.max(evals, axis=-1, keepdims=True)
    evals = np.maximum(evals, floor)
    inv = (evecs / evals[..., None, :]) @ np.swapaxes(evecs, -1, -2)
    return symmetrise(inv / (d[..., :, None] * d[..., None, :]))


class PosteriorInformation:
    """One immutable state of the Tichavský recursion: Bayesian information and target states.

    Parameters
    ----------
    information : array_like
        ``J`` (..., n, n) about ``[x, y, (z), vx, vy, (vz)]``, SI; leading axes are independent
        recursions.
    dynamics : NearlyConstantVelocity
    time : float
        The time of ``information`` and ``states``, s.
    states : array_like, optional
        Target states (N, n) to average over (a prior sample, or the mean as (1, n)).
    rng : numpy.random.Generator, optional
        When given, :meth:`predict` adds process noise to ``states``.

    Raises
    ------
    ValueError
        When ``information`` is not ``(..., n, n)`` with ``n = 2 dim``.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998); Hurtado & Nehorai (2008), eqs. 10-11 and 13.
    """

    def __init__(self, information: ArrayLike, dynamics: NearlyConstantVelocity,
                 time: float = 0.0, states: ArrayLike | None = None,
                 rng: np.random.Generator | None = None,
                 _steps: dict[float, tuple[Array, Array, Array]] | None = None) -> None:
        self.information = np.asarray(information, dtype=float)
        n = 2 * dynamics.dim
        if self.information.shape[-2:] != (n, n):
            raise ValueError(f"information must be ({n}, {n}) for a {dynamics.dim}-D state; "
                             f"got shape {self.information.shape}")
        self.dynamics = dynamics
        self.time = float(time)
        self.states = None if states is None else np.atleast_2d(np.asarray(states, float))
        self.rng = rng
        self._steps = {} if _steps is None else _steps  # dt (rounded) -> F, F^-1, G

    @classmethod
    def from_prior(cls, prior_cov: ArrayLike, dynamics: NearlyConstantVelocity,
                   time: float = 0.0, states: ArrayLike | None = None,
                   rng: np.random.Generator | None = None) -> PosteriorInformation:
        """Start the recursion, ``J_0 = P_0^{-1}``.

        Parameters
        ----------
        prior_cov : array_like
            ``P_0`` (n, n), SI.
        dynamics, time, states, rng
            As for the constructor.

        Returns
        -------
        PosteriorInformation
        """
        return cls(information_inverse(np.asarray(prior_cov, dtype=float)), dynamics, time,
                   states, rng)

    @property
    def dim(self) -> int:
        """The state's dimension, 2 or 3."""
        return int(self.dynamics.dim)

    def _replace(self, information: Array, time: float, states: Array | None
                 ) -> PosteriorInformation:
        return PosteriorInformation(information, self.dynamics, time, states, self.rng,
                                    self._steps)

    def _step(self, dt: float) -> tuple[Array, Array, Array]:
        key = round(dt, 9)
        if key not in self._steps:
            self._steps[key] = (self.dynamics.transition(dt), self.dynamics.transition(-dt),
                                noise_factor(self.dynamics.noise(dt)))
        return self._steps[key]

    def step_factors(self, dt: float) -> tuple[Array, Array]:
        """Return ``(F^{-1}, G)`` of a ``dt``-second step (cached), ``G G^T = Q``.

        Parameters
        ----------
        dt : float
            s.

        Returns
        -------
        tuple of ndarray
        """
        _, f_inv, g = self._step(float(dt))
        return f_inv, g

    def predict(self, dt: float) -> PosteriorInformation:
        """Predict the information ``dt`` seconds later (below :data:`MIN_STEP`: unchanged).

        Parameters
        ----------
        dt : float
            s, >= 0.

        Returns
        -------
        PosteriorInformation

        Raises
        ------
        ValueError
            When ``dt`` is negative.
        """
        return self.predict_to(self.time + float(dt))

    def predict_to(self, time: float) -> PosteriorInformation:
        """Predict to the absolute ``time`` (s), as :meth:`predict`.

        Parameters
        ----------
        time : float
            Not before :attr:`time`.

        Returns
        -------
        PosteriorInformation

        Raises
        ------
        ValueError
            When ``time`` is before :attr:`time`.
        """
        dt = float(time) - self.time
        if dt < -MIN_STEP:
            raise ValueError(f"cannot predict backwards (from t={self.time} s to t={time} s)")
        if dt <= MIN_STEP:
            return self
        f, f_inv, g = self._step(dt)
        states = None
        if self.states is not None:
            states = self.states @ f.T
            if self.rng is not None and g.shape[1]:
                states = states + self.rng.standard_normal((states.shape[0], g.shape[1])) @ g.T
        return self._replace(predict_information(self.information, f_inv, g), float(time),
                             states)

    def update(self, information: ArrayLike) -> PosteriorInformation:
        """Return ``J + Gamma``, the information after a measurement update.

        Parameters
        ----------
        information : array_like
            ``Gamma`` (..., n, n), broadcastable; a (C, n, n) stack gives C candidate updates.

        Returns
        -------
        PosteriorInformation

        References
        ----------
        Hurtado & Nehorai (2008), eq. 10 (second term) and eq. 11.
        """
        return self._replace(symmetrise(self.information + np.asarray(information, float)),
                             self.time, self.states)

    @property
    def covariance(self) -> Array:
        """``J^{-1}`` (..., n, n), SI: the bound on the state's mean-square error matrix."""
        return information_inverse(self.information)

    @property
    def position_rms(self) -> Array:
        """The bound on the RMS position error (...,), m: ``sqrt(trace)`` of the position block."""
        cov = self.covariance[..., :self.dim, :self.dim]
        return cast(Array, np.sqrt(np.clip(np.einsum("...ii->...", cov), 0.0, None)))

    def _states_for(self, group: MeasurementGroup, states: ArrayLike | None) -> Array:
        if group.dim != self.dim:
            raise ValueError(f"the group is for a {group.dim}-D state, the recursion for "
                             f"{self.dim}-D")
        x = self.states if states is None else np.atleast_2d(np.asarray(states, float))
        if x is None:
            raise ValueError("no target states: give states here or to the constructor")
        if states is None and abs(group.time - self.time) > TIME_MATCH:
            raise ValueError(f"the group is at t={group.time} s, the states at "
                             f"t={self.time} s: predict to the group's time first")
        return x

    def state_information(self, group: MeasurementGroup, states: ArrayLike | None = None
                          ) -> Array:
        """Return the Fisher information of ``group`` at each target state (N, n, n), SI.

        Parameters
        ----------
        group : MeasurementGroup
            At :attr:`time`.
        states : array_like, optional
            (N, n); default :attr:`states`.

        Returns
        -------
        ndarray
            Their mean is ``Gamma``.

        Raises
        ------
        ValueError
            On a group of another dimension, no states, or states at another time.

        References
        ----------
        Hurtado & Nehorai (2008), eq. 13 (``Xi``, closed form for Gaussian noise).
        """
        return group.information(self._states_for(group, states))

    def expected_information(self, candidate_sensor_states: ArrayLike,
                             group: MeasurementGroup, states: ArrayLike | None = None
                             ) -> Array:
        """Return ``Gamma`` (C, n, n), SI, for each candidate sensor state, vectorised.

        Parameters
        ----------
        candidate_sensor_states : array_like
            (C, 6) or (C, m, 6) ENU sensor states, m and m/s, at the group's time.
        group : MeasurementGroup
            The measurements to plan, at :attr:`time`.
        states : array_like, optional
            Target states (N, n) or (n,); default :attr:`states`.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            On shapes that do not fit, or states at another time than the group's.

        References
        ----------
        Hurtado & Nehorai (2008), eqs. 12-13 (the predicted PCRB of a candidate manoeuvre).
        """
        x = self._states_for(group, states)
        cand = np.asarray(candidate_sensor_states, dtype=float)
        if cand.ndim == 2 and cand.shape[-1] == 6:
            cand = cand[:, None, :]
        if cand.ndim != 3 or cand.shape[-1] != 6 or cand.shape[1] not in (1, len(group)):
            raise ValueError(f"candidate_sensor_states must be (C, 6) or (C, {len(group)}, 6);"
                             f" got shape {np.shape(candidate_sensor_states)}")
        xi = group.information(x, cand[:, None, :, :])  # (C, N, n, n)
        return cast(Array, xi.mean(axis=1))


def pcrb_over_runs(information: ArrayLike, times: ArrayLike, prior_cov: ArrayLike,
                   dynamics: NearlyConstantVelocity, time0: float) -> Array:
    """Return the posterior CRB ``J_k^{-1}`` (D, n, n), SI, per update, ``Gamma`` the runs' mean.

    Parameters
    ----------
    information : array_like, shape (R, D, n, n)
        ``Xi`` of run ``r`` at update ``k``, at its true target and sensor states, SI.
    times : array_like, shape (D,)
        s, increasing, not before ``time0``.
    prior_cov : array_like, shape (n, n)
        ``P_0`` at ``time0``, SI.
    dynamics : NearlyConstantVelocity
    time0 : float
        s.

    Returns
    -------
    ndarray

    Raises
    ------
    ValueError
        If the shapes do not agree.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998); Hurtado & Nehorai (2008), eqs. 10-11.
    """
    xi = np.asarray(information, dtype=float)
    t = np.asarray(times, dtype=float)
    n = 2 * dynamics.dim
    if xi.ndim != 4 or xi.shape[1:] != (t.shape[0], n, n):
        raise ValueError(f"information must be (runs, {t.shape[0]}, {n}, {n}) for "
                         f"{t.shape[0]} update times; got {xi.shape}")
    gamma = xi.mean(axis=0)
    post = PosteriorInformation.from_prior(prior_cov, dynamics, time0)
    out = np.empty((t.shape[0], n, n))
    for k in range(t.shape[0]):
        post = post.predict_to(t[k]).update(gamma[k])
        out[k] = post.covariance
    return out


#: Fewest runs for an interval of RMSE over the bound (a few runs of a heavy-tailed error
#: say nothing about its tail).
MIN_RUNS = 10
#: Bootstrap resamples of the runs.
RESAMPLES = 2000


def ratio_interval(errors: ArrayLike, bound: ArrayLike, level: float = 0.95,
                   seed: int = 0) -> tuple[float, float | None, float | None]:
    """Return the RMSE over the bound and its Monte Carlo interval, from the runs' errors."""
    from ..core import chi2

    e2 = np.asarray(errors, dtype=float) ** 2
    p = np.asarray(bound, dtype=float)
    tr = float(np.trace(p))
    r = e2.size
    ratio = float(np.sqrt(e2.mean() / tr))
    if r < MIN_RUNS:
        return ratio, None, None
    m = r * tr**2 / float(np.sum(p * p.T))
    hi_q, lo_q = chi2.ppf([(1 + level) / 2, (1 - level) / 2], m)
    rng = np.random.default_rng([seed, r])
    boot = np.sqrt(rng.multinomial(r, np.full(r, 1.0 / r), size=RESAMPLES) @ e2 / (r * tr))
    b_lo, b_hi = np.quantile(boot, [(1 - level) / 2, (1 + level) / 2])
    return (ratio, min(ratio * float(np.sqrt(m / hi_q)), float(b_lo)),
            max(ratio * float(np.sqrt(m / lo_q)), float(b_hi)))
