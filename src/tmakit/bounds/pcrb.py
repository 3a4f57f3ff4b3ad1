"""The posterior (Bayesian) Cramér–Rao bound of a recursive tracker.

For nearly-constant-velocity dynamics ``x_{k+1} = F x_k + w_k``, ``w_k ~ N(0, Q_k)``
(003_e5155d4fe60daef8.txt §2.1) and measurements ``z_k = h_k(x_k) + v_k``,
``v_k ~ N(0, R_k)``, the Bayesian information about the state ``x_k`` obeys the Tichavský
recursion (004_590a452506c86051.txt eqs. 10-11):

    J_{k+1} = (Q_k + F J_k^{-1} F^T)^{-1} + Gamma_{k+1},
    Gamma_{k+1} = E_x[ H_{k+1}(x)^T R_{k+1}^{-1} H_{k+1}(x) ],

starting from the inverse of the prior covariance, ``J_0 = P_0^{-1}``.  ``H`` is the Jacobian
of the group's predicted values with respect to the state (Gaussian noise: eq. 13's Fisher
information ``Xi`` in closed form).  ``J_k^{-1}`` bounds the mean-square error matrix of any
estimator of ``x_k`` from the measurements up to ``k``, averaged over the prior and the process
noise.

**Numerics.**  The prediction is computed in information form: with ``A = F^{-T} J F^{-1}``
(``F^{-1}`` is the transition backwards in time, exact) and ``Q = G G^T``,
``(Q + A^{-1})^{-1} = A - A G (I + G^T A G)^{-1} G^T A`` (Woodbury).  ``I + G^T A G >= I`` is
always invertible, so there is no inverse of ``J`` or of ``Q`` (singular for NCV) and the
step reduces exactly to ``F^{-T} J F^{-1}`` when ``Q = 0``; nothing can raise a
``LinAlgError``.

**Expectation.**  ``Gamma`` is averaged over trajectories drawn from the model (Monte Carlo:
``x_0 ~ N(m_0, P_0)``, then the dynamics with process noise), vectorised over trajectories.
:func:`deterministic_pcrb` instead evaluates ``H`` along the prior-mean trajectory (no
sampling): the *deterministic-trajectory bound*, which for ``q = 0`` equals the batch CRLB of
the same data with the prior's information added.  The two differ, often a lot, when the prior
is wide: the information at the mean is not the mean information.  The expectation can be
heavy-tailed — a bearing's information grows as ``1/r^2``, so the few trajectories that pass
close to a sensor dominate it (in 2-D with a prior density at the sensor, ``E[1/r^2]`` even
diverges and the bound's regularity conditions fail).  Each Monte Carlo bound therefore carries
a standard error (batch means over 10 disjoint sets of trajectories) and the largest share of
one trajectory in ``Gamma_k``, and says so in its notes when one trajectory dominates.

**Measurements.**  Rows are grouped by time (one update per distinct time, as
:meth:`tmakit.filters.TrackingFilter.run` does) and predicted by
:class:`tmakit.filters.MeasurementGroup`: any kinds, any sensors (moving sensors need nothing
special: each row carries its sensor's state), range differences with the group's correlated
``R`` and their earlier sample back-propagated at constant velocity.  Nuisance parameters are
known values (as for the filters).  The recursion assumes the measurement noise of different
groups to be independent; range differences whose pulse intervals overlap across groups
violate that, which is reported in :attr:`PosteriorBound.notes` and by a warning.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..linalg import check_prior, symmetrise
from ..motion.dynamics import NearlyConstantVelocity, state_names
from ..observation.groups import MeasurementGroup, embedding, group_times
from ..observation.noise import NoiseModel

Array = NDArray[np.float64]

#: Number of disjoint sets of trajectories whose separate recursions give the Monte Carlo
#: standard error of the bound (batch means).
BATCHES = 10
#: A single trajectory carrying more than this share of the expected information at an update
#: is reported (heavy-tailed expectation).
DOMINANCE = 0.2


@dataclass
class PosteriorBound:
    """The posterior CRB after each update.

    ``times`` (K,) s: the update times; ``information`` (K, n, n) the Bayesian information
    ``J_k`` and ``covariance`` (K, n, n) its inverse, the bound on the state's mean-square
    error matrix (SI: m, m/s); ``std`` (K, n) the square roots of its diagonal;
    ``position_rms`` (K,) m the square root of the trace of its position block (the bound on
    the RMS position error).  ``mode`` is ``"monte-carlo"`` (``trajectories`` sampled) or
    ``"deterministic"`` (the prior-mean trajectory).

    Monte Carlo only: ``position_rms_se`` (K,) m, an approximate standard error of
    ``position_rms`` from the spread of the same recursion run on 10 disjoint sets of the
    trajectories (batch means); ``max_share`` (K,), the largest share of one trajectory in
    ``Gamma_k`` (each component weighted by the predicted information; ``1/trajectories``
    when all trajectories see alike, near 1 when one close pass to a sensor dominates).
    ``notes`` says when the expectation is dominated by single trajectories.
    """

    state_names: tuple[str, ...]
    times: Array
    information: Array
    covariance: Array
    std: Array
    position_rms: Array
    prior_time: float
    q: tuple[float, ...]
    trajectories: int
    mode: str
    n_measurements: int
    notes: list[str] = field(default_factory=list)
    position_rms_se: Array | None = None
    max_share: Array | None = None

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def dim(self) -> int:
        return len(self.state_names) // 2

    def index_at(self, time: float) -> int:
        """Index of the last update at or before ``time`` (s)."""
        k = int(np.searchsorted(self.times, float(time) + 1e-9, side="right")) - 1
        if k < 0:
            raise ValueError(f"no update at or before t={time} s (the first is at "
                             f"t={self.times[0]} s)")
        return k

    def at(self, time: float) -> dict[str, object]:
        """The bound after the last update at or before ``time`` (s): time, std per state
        component and the position RMS bound (m)."""
        k = self.index_at(time)
        out: dict[str, object] = {
            "time": float(self.times[k]),
            "std": dict(zip(self.state_names, self.std[k].tolist(), strict=True)),
            "position_rms": float(self.position_rms[k])}
        if self.position_rms_se is not None:
            out["position_rms_se"] = float(self.position_rms_se[k])
        return out

    def as_dict(self) -> dict[str, object]:
        """The JSON form (SI units)."""
        return {
            "bound": "posterior CRB (Tichavsky recursion)",
            "mode": self.mode,
            "trajectories": self.trajectories,
            "state": list(self.state_names),
            "prior_time": self.prior_time,
            "q": list(self.q),
            "n_measurements": self.n_measurements,
            "time": self.times.tolist(),
            "std": self.std.tolist(),
            "position_rms": self.position_rms.tolist(),
            "position_rms_se": _nan_to_none(self.position_rms_se),
            "max_share": _nan_to_none(self.max_share),
            "covariance": self.covariance.tolist(),
            "information": self.information.tolist(),
            "notes": list(self.notes),
        }

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.as_dict(), indent=indent)

    def summary(self, times: ArrayLike | None = None) -> str:
        """A table of the bound's standard deviations and position RMS at ``times`` (default:
        five times spread over the track)."""
        if times is None:
            idx = np.unique(np.linspace(0, len(self) - 1, min(5, len(self))).round().astype(int))
        else:
            idx = np.array([self.index_at(t) for t in np.atleast_1d(times)], dtype=int)
        what = (f"{self.trajectories} sampled trajectories" if self.mode == "monte-carlo"
                else "the prior-mean trajectory")
        se = self.position_rms_se
        lines = [f"Posterior CRB, q = {', '.join(f'{v:g}' for v in self.q)} m/s^2, "
                 f"{self.n_measurements} measurements, expectation over {what}",
                 f"  {'time (s)':>10}" + "".join(f"{'std ' + s:>12}" for s in self.state_names)
                 + f"{'pos. RMS':>12}" + ("" if se is None else f"{'+-':>10}")]
        for k in idx:
            lines.append(f"  {self.times[k]:10.6g}" + "".join(f"{v:12.5g}" for v in self.std[k])
                         + f"{self.position_rms[k]:12.5g}"
                         + ("" if se is None else f"{se[k]:10.2g}"))
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)


def _nan_to_none(values: Array | None) -> list[float | None] | None:
    if values is None:
        return None
    return [float(v) if np.isfinite(v) else None for v in values]


# -- numerics -------------------------------------------------------------------------------
def _noise_factor(q_mat: Array) -> Array:
    """``G`` (n, r) with ``G G^T = Q`` (eigen-decomposition; rounding negatives dropped)."""
    evals, evecs = np.linalg.eigh(symmetrise(q_mat))
    top = float(evals.max()) if evals.size else 0.0
    if top <= 0.0:
        return np.zeros((q_mat.shape[0], 0))
    keep = evals > 1e-14 * top
    return evecs[:, keep] * np.sqrt(evals[keep])


def predict_information(info: Array, f_inv: Array, g: Array) -> Array:
    """Information after a dynamics step, ``(Q + F J^{-1} F^T)^{-1}`` with ``Q = G G^T``,
    in the Woodbury form that never inverts ``J`` or ``Q`` (see the module docstring).

    ``info``: (..., n, n); ``f_inv``: ``F^{-1}`` (n, n); ``g``: (n, r), r may be 0."""
    a = symmetrise(f_inv.T @ info @ f_inv)
    if g.shape[1] == 0:
        return a
    ag = a @ g
    s = np.eye(g.shape[1]) + g.T @ ag  # >= I: Cholesky always succeeds
    chol = np.linalg.cholesky(symmetrise(s))
    half = np.linalg.solve(chol, np.swapaxes(ag, -1, -2))  # L^{-1} G^T A
    return symmetrise(a - np.swapaxes(half, -1, -2) @ half)


def information_inverse(info: Array) -> Array:
    """Inverse of symmetric positive-definite information matrices ``(..., n, n)``, computed
    in coordinates normalised by the diagonal (units do not matter); eigenvalues that rounding
    pushed to or below zero are floored at ``n * eps`` of the largest."""
    d = np.sqrt(np.clip(np.einsum("...ii->...i", info), 1e-300, None))
    norm = info / (d[..., :, None] * d[..., None, :])
    evals, evecs = np.linalg.eigh(symmetrise(norm))
    floor = info.shape[-1] * np.finfo(float).eps * np.max(evals, axis=-1, keepdims=True)
    evals = np.maximum(evals, floor)
    inv = (evecs / evals[..., None, :]) @ np.swapaxes(evecs, -1, -2)
    return symmetrise(inv / (d[..., :, None] * d[..., None, :]))


def _target6(x: Array, dt: Array, dim: int) -> Array:
    """Target 6-vectors ``(N, m, 6)`` at ``dt`` (m,) after states ``x`` (N, 2 dim)."""
    out = np.zeros((x.shape[0], dt.shape[0], 6))
    out[..., :dim] = x[:, None, :dim] + dt[:, None] * x[:, None, dim:]
    out[..., 3:3 + dim] = x[:, None, dim:]
    return out


def group_jacobians(group: MeasurementGroup, x: ArrayLike) -> Array:
    """``d predict / d x`` ``(N, m, 2 dim)`` of a measurement group at ``N`` states ``x``
    ``(N, 2 dim)``: :meth:`MeasurementGroup.jacobian` vectorised over states, built from the
    measurement models' analytic Jacobians (rows at other times than the group's and the
    earlier samples of range differences are reached at constant velocity)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    dim = group.dim
    rows = group.rows
    out = np.empty((x.shape[0], len(group), 2 * dim))
    for kind, model in group.models.items():
        idx = group.index[kind]
        rel = _target6(x, group.dt[idx], dim) - rows.sensor_state[idx]
        rel_ref = None
        if model.uses_reference:
            rel_ref = _target6(x, group.dt_ref[idx], dim) - rows.ref_sensor_state[idx]
        jac = model.jacobian(rel, rows.time[idx], group.nuisance[kind], rel_ref)
        h = np.einsum("...mi,mij->...mj", jac.rel, embedding(group.dt[idx], dim))
        if jac.rel_ref is not None:
            h = h + np.einsum("...mi,mij->...mj", jac.rel_ref,
                              embedding(group.dt_ref[idx], dim))
        out[:, idx] = h
    return out


def _cross_group_correlation(meas: MeasurementSet, groups: list[NDArray[np.int64]]) -> bool:
    """True if two range differences of one sensor in different groups share a pulse
    interval (overlapping ``(time_ref, time]`` spans): noise correlated across updates."""
    label = np.empty(len(meas), dtype=np.int64)
    for g, idx in enumerate(groups):
        label[idx] = g
    rd = meas.kind == "range_difference"
    for s in np.unique(meas.sensor[rd]):
        rows = np.flatnonzero(rd & (meas.sensor == s))
        order = rows[np.argsort(meas.time_ref[rows], kind="stable")]
        # Sweep by start time keeping the latest end seen in the two most recent distinct
        # groups: a row overlaps an earlier-starting row of another group iff that end is
        # later than its start.
        best = (-np.inf, -1)  # (latest end, its group)
        second = (-np.inf, -2)  # latest end among the other groups
        for r in order:
            start, end, g = meas.time_ref[r], meas.time[r], label[r]
            other = second if best[1] == g else best
            if other[0] > start + 1e-9:
                return True
            if g == best[1]:
                best = (max(best[0], end), g)
            elif end > best[0]:
                best, second = (end, g), best
            elif end > second[0]:
                second = (end, g)
    return False


# -- inputs ---------------------------------------------------------------------------------
def _resolve_source(source, prior_mean, options, nuisance
                    ) -> tuple[MeasurementSet, Array | None, dict, dict, object]:
    from ..scenario import Scenario

    if isinstance(source, str):
        from ..scenario_file import load_scenario

        source = load_scenario(source)
    if isinstance(source, Scenario):
        meas = source.simulate(rng=0, noise=False)  # the layout: times, sensors, sigmas
        opts = source.measurement_options if options is None else dict(options)
        nu = {**source.nuisance, **dict(nuisance or {})}
        return meas, None if prior_mean is None else prior_mean, opts, nu, source
    if isinstance(source, MeasurementSet):
        nu: dict[str, float] = {}
        if "nuisance" in source.metadata:
            nu.update(json.loads(source.metadata["nuisance"]))
        nu.update(dict(nuisance or {}))
        if prior_mean is None:
            raise ValueError("prior_mean is required for a measurement set (only a scenario "
                             "can default it to its true state)")
        return source, prior_mean, dict(options or {}), nu, None
    raise TypeError("posterior_crb() takes a Scenario, a built-in scenario name or a "
                    f"MeasurementSet; got {type(source).__name__}")


def _posterior(source, prior_mean, prior_cov, time0, q, trajectories: int, sample: bool,
               rng, options, nuisance) -> PosteriorBound:
    meas, prior_mean, opts, nu, scn = _resolve_source(source, prior_mean, options, nuisance)
    if len(meas) == 0:
        raise ValueError("the measurement set is empty: nothing to bound")
    groups = group_times(meas)
    times = np.array([float(meas.time[idx[-1]]) for idx in groups])
    t0 = float(times[0]) if time0 is None else float(time0)
    if not np.isfinite(t0):
        raise ValueError(f"time0 must be a finite time (s); got {time0}")
    if t0 > times[0] + 1e-9:
        raise ValueError(f"time0={t0} s is after the first measurement (t={times[0]} s): the "
                         "prior must hold at or before the first update")
    if prior_mean is None:  # a scenario: its true state at time0
        dim0 = 3 if getattr(scn.motion, "dim", meas.dim) == 3 else 2
        keep = [0, 1, 2, 3, 4, 5] if dim0 == 3 else [0, 1, 3, 4]
        prior_mean = scn.target_states([t0])[0][keep]
    mean, cov = check_prior(prior_mean, prior_cov, "prior_mean", "prior_cov",
                            require_symmetric=True)
    n = mean.shape[0]
    dim = n // 2
    if np.ndim(q) and np.size(q) != dim:
        raise ValueError(f"q must be one value or {dim} values (one per axis) in m/s^2; "
                         f"got {np.size(q)}")
    dynamics = NearlyConstantVelocity(dim, float(q) if np.ndim(q) == 0 else tuple(
        float(v) for v in np.ravel(q)))
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)

    notes: list[str] = []
    if _cross_group_correlation(meas, groups):
        msg = ("range differences of one sensor share pulse intervals across updates: their "
               "noise is correlated between groups, which the recursion ignores (the bound is "
               "approximate; use lag-1 differences only for an exact bound)")
        notes.append(msg)
        warnings.warn(msg, stacklevel=3)

    info = information_inverse(cov)  # J_0 = P_0^{-1}
    if sample:
        x = mean + gen.standard_normal((trajectories, n)) @ np.linalg.cholesky(cov).T
    else:
        x = mean[None, :].copy()
    # Monte Carlo error: the same recursion run on BATCHES disjoint sets of trajectories,
    # stacked after the main one (row 0) so that one call predicts all.
    batches = min(BATCHES, trajectories) if sample else 0
    starts = (np.arange(batches) * trajectories) // batches if batches else np.zeros(0, int)
    sizes = np.diff(np.append(starts, trajectories))
    stack = np.broadcast_to(info, (1 + batches, n, n)).copy()
    steps: dict[float, tuple[Array, Array, Array]] = {}  # dt -> F, F^-1, G
    t_prev = t0
    infos = np.empty((len(groups), 1 + batches, n, n))
    share = np.full(len(groups), np.nan)
    for k, idx in enumerate(groups):
        dt = times[k] - t_prev
        if dt > 1e-12:
            key = round(dt, 9)
            if key not in steps:
                steps[key] = (dynamics.transition(dt), dynamics.transition(-dt),
                              _noise_factor(dynamics.noise(dt)))
            f, f_inv, g = steps[key]
            stack = predict_information(stack, f_inv, g)
            x = x @ f.T
            if sample and g.shape[1]:
                x = x + gen.standard_normal((x.shape[0], g.shape[1])) @ g.T
            t_prev = times[k]
        rows = meas.take(idx)
        group = MeasurementGroup(rows, times[k], dim, opts, nu)
        w = NoiseModel(rows).whiten(group_jacobians(group, x), axis=-2)  # R^{-1/2} H
        xi = np.einsum("tmi,tmj->tij", w, w)  # each trajectory's Fisher information (eq. 13)
        gamma = np.empty((1 + batches, n, n))
        gamma[0] = xi.mean(axis=0)
        if sample:
            gamma[1:] = np.add.reduceat(xi, starts, axis=0) / sizes[:, None, None]
            # Share of the largest single trajectory in Gamma, each component weighted by
            # the predicted information (dimensionless).
            gain = np.einsum("tii->t", xi / np.diag(stack[0]))
            total = float(gain.sum())
            share[k] = float(gain.max()) / total if total > 0 else 0.0
        stack = symmetrise(stack + gamma)
        infos[k] = stack
    covs_all = information_inverse(infos)
    infos, covs = infos[:, 0].copy(), covs_all[:, 0].copy()
    std = np.sqrt(np.clip(np.einsum("kii->ki", covs), 0.0, None))
    pos = np.sqrt(np.clip(np.einsum("kii->k", covs[:, :dim, :dim]), 0.0, None))
    pos_se = np.full(len(groups), np.nan)
    if batches >= 2:
        pos_b = np.sqrt(np.clip(np.einsum("kbii->kb", covs_all[:, 1:, :dim, :dim]), 0.0,
                                None))
        pos_se = np.std(pos_b, axis=1, ddof=1) / np.sqrt(batches)
        worst = float(np.nanmax(share))
        if worst > DOMINANCE:
            at = float(times[int(np.nanargmax(share))])
            notes.append(
                f"one trajectory carries {100 * worst:.0f} % of the expected information at "
                f"t={at:g} s (typically a trajectory passing close to a sensor): the Monte Carlo "
                "expectation is heavy-tailed and the bound uncertain (see position_rms_se); "
                "use more trajectories, or deterministic_pcrb for a fixed trajectory")
    elif sample:
        notes.append("one trajectory: no Monte Carlo error estimate")
    q_axes = tuple(float(v) for v in np.broadcast_to(np.asarray(q, dtype=float), (dim,)))
    return PosteriorBound(state_names(dim), times, infos, covs, std, pos, t0, q_axes,
                          trajectories if sample else 1,
                          "monte-carlo" if sample else "deterministic", len(meas), notes,
                          pos_se if sample else None, share if sample else None)


# -- public API -----------------------------------------------------------------------------
def posterior_crb(source, prior_mean: ArrayLike | None, prior_cov: ArrayLike,
                  time0: float | None = None, *, q: float | ArrayLike = 0.0,
                  trajectories: int = 200,
                  rng: np.random.Generator | int | None = None,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None) -> PosteriorBound:
    """The posterior CRB (004_590a452506c86051.txt eqs. 10-11) of a tracker that starts from
    the Gaussian prior ``N(prior_mean, prior_cov)`` at ``time0`` (s; default: the first
    measurement time) and updates once per distinct measurement time.

    ``source``: a :class:`~tmakit.data.MeasurementSet` (only times, sensors, kinds and sigmas
    are used), a :class:`~tmakit.scenario.Scenario` or a built-in scenario name (its layout;
    ``prior_mean=None`` then means its true state at ``time0``).  ``prior_mean`` (n,) m, m/s
    and ``prior_cov`` (n, n) in state order ``[x, y, (z), vx, vy, (vz)]``.  ``q``: process
    noise, acceleration standard deviation per axis (m/s^2; 003_e5155d4fe60daef8.txt §2.1).
    ``trajectories``: number of trajectories, drawn from the prior and the process noise with
    ``rng`` (a Generator or a seed), over which ``Gamma_k`` is averaged.  ``options`` and
    ``nuisance``: per-kind model options and known nuisance values, as for the filters.
    """
    if isinstance(trajectories, bool) or not isinstance(trajectories, (int, np.integer)) \
            or trajectories < 1:
        raise ValueError(f"trajectories must be a whole number >= 1; got {trajectories!r}")
    return _posterior(source, prior_mean, prior_cov, time0, q, int(trajectories), True, rng,
                      options, nuisance)


def deterministic_pcrb(source, prior_mean: ArrayLike | None, prior_cov: ArrayLike,
                       time0: float | None = None, *, q: float | ArrayLike = 0.0,
                       options: Mapping[str, Mapping[str, object]] | None = None,
                       nuisance: Mapping[str, float] | None = None) -> PosteriorBound:
    """The deterministic-trajectory bound: the recursion of :func:`posterior_crb` with
    ``Gamma_k`` evaluated along the prior-mean trajectory only (no sampling; ``q`` still
    enters the prediction).  With ``q = 0`` it equals the batch CRLB of the same data at that
    trajectory plus the prior's information mapped to each time.  For a fixed true trajectory
    (filters started at the truth with a random error) pass the true state as ``prior_mean``.
    """
    return _posterior(source, prior_mean, prior_cov, time0, q, 1, False, None, options,
                      nuisance)


def final_position_rms(source="bearings-only-2d", prior_mean: ArrayLike | None = None,
                       prior_cov: ArrayLike | None = None, time0: float | None = None, *,
                       q: float | ArrayLike = 0.0, trajectories: int | None = 200,
                       rng: np.random.Generator | int | None = None) -> float:
    """The bound on the RMS position error (m) after the last update, for benchmarks: by
    default on ``bearings-only-2d`` with the prior centred on the truth at ``time0``.

    ``prior_cov`` is required.  ``trajectories=None`` gives the deterministic-trajectory
    bound (:func:`deterministic_pcrb`), otherwise the Monte Carlo expectation of
    :func:`posterior_crb`."""
    if prior_cov is None:
        raise ValueError("prior_cov is required (n x n, SI)")
    if trajectories is None:
        bound = deterministic_pcrb(source, prior_mean, prior_cov, time0, q=q)
    else:
        bound = posterior_crb(source, prior_mean, prior_cov, time0, q=q,
                              trajectories=trajectories, rng=rng)
    return float(bound.position_rms[-1])
