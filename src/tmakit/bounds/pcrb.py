"""The posterior (Bayesian) Cramér–Rao bound of a recursive tracker on a measurement set.

The recursion of Tichavský, Muravchik & Nehorai (1998) (Hurtado & Nehorai (2008), eqs. 10-11)
for nearly-constant-velocity dynamics (Chen & Sun, §2.1), ``Gamma`` averaged over trajectories
from the prior or taken along its mean; one update per distinct time, nuisance known.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..data import MeasurementSet
from ..results.answers import finite

if TYPE_CHECKING:  # pragma: no cover
    from ..scenario.model import Scenario
from ..core.linalg import check_prior
from ..motion.dynamics import NearlyConstantVelocity, state_names
from ..observation import MeasurementGroup, group_times
from .pcrb_recursion import PosteriorInformation, information_inverse

__all__ = ["PosteriorBound", "deterministic_pcrb", "posterior_crb"]


@dataclass
class PosteriorBound:
    """The posterior CRB after each update (``K`` updates, ``n`` state components, SI units).

    Attributes
    ----------
    state_names : tuple of str
        ``x, y[, z], vx, vy[, vz]``.
    times : ndarray, shape (K,)
        s.
    information, covariance : ndarray, shape (K, n, n)
        ``J_k`` and its inverse, the MSE bound (m², m²/s, m²/s²).
    std : ndarray, shape (K, n)
        m, m/s.
    position_rms : ndarray, shape (K,)
        The RMS position error bound, m.
    prior_time : float
        Time of ``J_0 = P_0^{-1}``, s.
    q : tuple of float
        Acceleration noise std per axis, m/s² (Chen & Sun, §2.1).
    trajectories : int
        Trajectories sampled (Monte Carlo mode).
    mode : str
        ``"monte-carlo"`` or ``"deterministic"`` (along the prior mean).
    n_measurements : int
    notes : list of str
        Warnings, e.g. single trajectories dominating.
    position_rms_se : ndarray, shape (K,), or None
        Monte Carlo standard error of ``position_rms`` (10 batch means), m.
    max_share : ndarray, shape (K,), or None
        Largest share of one trajectory in ``Gamma_k``.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998) (the recursion); Hurtado & Nehorai (2008),
    eqs. 10-11.
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
        """Return the number of updates ``K``."""
        return int(self.times.shape[0])

    @property
    def dim(self) -> int:
        """The state's dimension, 2 or 3."""
        return len(self.state_names) // 2

    def index_at(self, time: float) -> int:
        """Return the index of the last update at or before ``time`` (s).

        Parameters
        ----------
        time : float

        Returns
        -------
        int

        Raises
        ------
        ValueError
            When ``time`` is before the first update.
        """
        k = int(np.searchsorted(self.times, float(time) + 1e-9, side="right")) - 1
        if k < 0:
            raise ValueError(f"no update at or before t={time} s (the first is at "
                             f"t={self.times[0]} s)")
        return k

    def at(self, time: float) -> dict[str, object]:
        """Return the bound after the last update at or before ``time`` (s).

        Parameters
        ----------
        time : float

        Returns
        -------
        dict
            ``time``, ``std`` per component, ``position_rms`` (and ``position_rms_se``).

        Raises
        ------
        ValueError
            When ``time`` is before the first update.
        """
        k = self.index_at(time)
        out: dict[str, object] = {
            "time": float(self.times[k]),
            "std": dict(zip(self.state_names, self.std[k].tolist(), strict=True)),
            "position_rms": float(self.position_rms[k])}
        if self.position_rms_se is not None:
            out["position_rms_se"] = float(self.position_rms_se[k])
        return out

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form.

        Returns
        -------
        dict
            Every attribute as plain lists and numbers (SI units), NaN as None.
        """
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
            "position_rms_se": None if self.position_rms_se is None else [
                finite(v) for v in self.position_rms_se],
            "max_share": None if self.max_share is None else [finite(v) for v in self.max_share],
            "covariance": self.covariance.tolist(),
            "information": self.information.tolist(),
            "notes": list(self.notes),
        }

    def to_json(self, indent: int | None = 2) -> str:
        """Return :meth:`as_dict` as JSON text.

        Parameters
        ----------
        indent : int or None, optional
            None: one line.

        Returns
        -------
        str
        """
        return json.dumps(self.as_dict(), indent=indent)

    def summary(self, times: ArrayLike | None = None) -> str:
        """Return a table of the std and position RMS (m, m/s) at some times, and the notes.

        Parameters
        ----------
        times : array_like, optional
            s; default five spread over the track.

        Returns
        -------
        str
        """
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


#: Number of disjoint sets of trajectories whose separate recursions give the Monte Carlo
#: standard error of the bound (batch means).
BATCHES = 10
#: A single trajectory carrying more than this share of the expected information at an update
#: is reported (heavy-tailed expectation).
DOMINANCE = 0.2


def _cross_group_correlation(meas: MeasurementSet, groups: list[NDArray[np.int64]]) -> bool:
    """Tell whether range differences of one sensor in two groups share a pulse interval."""
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


def _resolve_source(source: object, prior_mean: ArrayLike | None,
                    options: Mapping[str, Mapping[str, object]] | None,
                    nuisance: Mapping[str, float] | None
                    ) -> tuple[MeasurementSet, ArrayLike | None, dict[str, Any],
                               dict[str, float], Scenario | None]:
    from ..scenario.model import Scenario

    if isinstance(source, Scenario):
        meas = source.simulate(rng=0, noise=False)  # the layout: times, sensors, sigmas
        opts = source.measurement_options if options is None else dict(options)
        nu = {**source.nuisance, **dict(nuisance or {})}
        return meas, None if prior_mean is None else prior_mean, opts, nu, source
    if isinstance(source, MeasurementSet):
        nu = {}
        if "nuisance" in source.metadata:
            nu.update(json.loads(source.metadata["nuisance"]))
        nu.update(dict(nuisance or {}))
        if prior_mean is None:
            raise ValueError("prior_mean is required for a measurement set (only a scenario "
                             "can default it to its true state)")
        return source, prior_mean, dict(options or {}), nu, None
    if isinstance(source, str):
        raise TypeError("posterior_crb() takes a Scenario or a MeasurementSet; load a built-in "
                        f"scenario first (tmakit.load_scenario({source!r}))")
    raise TypeError("posterior_crb() takes a Scenario or a MeasurementSet; "
                    f"got {type(source).__name__}")


@dataclass
class _Setup:
    """What the recursion runs on: measurements grouped by time, prior and dynamics."""

    meas: MeasurementSet
    groups: list[NDArray[np.int64]]
    times: Array
    t0: float
    mean: Array
    cov: Array
    dynamics: NearlyConstantVelocity
    q_axes: tuple[float, ...]
    options: dict[str, Any]
    nuisance: dict[str, float]


def _dynamics(q: float | ArrayLike, dim: int, q_density: float | ArrayLike = 0.0
              ) -> tuple[NearlyConstantVelocity, tuple[float, ...]]:
    for name, value, unit in (("q", q, "m/s^2"), ("q_density", q_density, "m^2/s^3")):
        if np.ndim(value) and np.size(value) != dim:
            raise ValueError(f"{name} must be one value or {dim} values (one per axis) in "
                             f"{unit}; got {np.size(value)}")
    q_axes, density = (tuple(float(v) for v in np.broadcast_to(np.asarray(a, dtype=float), (dim,)))
                       for a in (q, q_density))
    return NearlyConstantVelocity(dim, q_axes[0] if np.ndim(q) == 0 else q_axes, density), q_axes


def _setup(source: object, prior_mean: ArrayLike | None, prior_cov: ArrayLike,
           time0: float | None, q: float | ArrayLike,
           options: Mapping[str, Mapping[str, object]] | None,
           nuisance: Mapping[str, float] | None, q_density: float | ArrayLike = 0.0
           ) -> _Setup:
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
        assert scn is not None  # (no prior mean: the source is a scenario)
        dim0 = 3 if getattr(scn.motion, "dim", meas.dim) == 3 else 2
        keep = [0, 1, 2, 3, 4, 5] if dim0 == 3 else [0, 1, 3, 4]
        prior_mean = scn.target_states([t0])[0][keep]
    mean, cov = check_prior(prior_mean, prior_cov, "prior_mean", "prior_cov",
                            require_symmetric=True)
    dynamics, q_axes = _dynamics(q, mean.shape[0] // 2, q_density)
    return _Setup(meas, groups, times, t0, mean, cov, dynamics, q_axes, opts, nu)


def _correlation_notes(setup: _Setup) -> list[str]:
    if not _cross_group_correlation(setup.meas, setup.groups):
        return []
    msg = ("range differences of one sensor share pulse intervals across updates: their "
           "noise is correlated between groups, which the recursion ignores (the bound is "
           "approximate; use lag-1 differences only for an exact bound)")
    warnings.warn(msg, stacklevel=4)
    return [msg]


def _batch_starts(trajectories: int, sample: bool) -> tuple[NDArray[np.intp], Array]:
    """Return the first trajectory and the size of each Monte Carlo batch (stacked after row 0)."""
    batches = min(BATCHES, trajectories) if sample else 0
    starts = (np.arange(batches) * trajectories) // batches if batches else np.zeros(0, int)
    return starts, np.diff(np.append(starts, trajectories))


def _recursion(setup: _Setup, trajectories: int, sample: bool, gen: np.random.Generator
               ) -> tuple[Array, Array]:
    """Run the recursion: information (K, 1 + batches, n, n), top trajectory share (K,)."""
    mean, cov, n = setup.mean, setup.cov, setup.mean.shape[0]
    if sample:
        x = mean + gen.standard_normal((trajectories, n)) @ np.linalg.cholesky(cov).T
    else:
        x = mean[None, :].copy()
    starts, sizes = _batch_starts(trajectories, sample)
    info0 = information_inverse(cov)  # J_0 = P_0^{-1}
    post = PosteriorInformation(np.broadcast_to(info0, (1 + starts.size, n, n)).copy(),
                                setup.dynamics, setup.t0, x, gen if sample else None)
    infos = np.empty((len(setup.groups), 1 + starts.size, n, n))
    share = np.full(len(setup.groups), np.nan)
    for k, idx in enumerate(setup.groups):
        post = post.predict_to(setup.times[k])
        group = MeasurementGroup(setup.meas.take(idx), setup.times[k], post.dim,
                                 setup.options, setup.nuisance)
        xi = post.state_information(group, post.states)  # each trajectory's (eq. 13)
        gamma = np.empty((1 + starts.size, n, n))
        gamma[0] = xi.mean(axis=0)
        if sample:
            gamma[1:] = np.add.reduceat(xi, starts, axis=0) / sizes[:, None, None]
            # Share of the largest single trajectory in Gamma, each component weighted by
            # the predicted information (dimensionless).
            gain = np.einsum("tii->t", xi / np.diag(post.information[0]))
            total = float(gain.sum())
            share[k] = float(gain.max()) / total if total > 0 else 0.0
        post = post.update(gamma)
        infos[k] = post.information
    return infos, share


def _bound(setup: _Setup, infos: Array, share: Array, trajectories: int, sample: bool,
           notes: list[str]) -> PosteriorBound:
    """Make the result (covariances, std, RMS and its error) from the stacked information."""
    dim, times = setup.mean.shape[0] // 2, setup.times
    covs_all = information_inverse(infos)
    infos, covs = infos[:, 0].copy(), covs_all[:, 0].copy()
    std = np.sqrt(np.clip(np.einsum("kii->ki", covs), 0.0, None))
    pos = np.sqrt(np.clip(np.einsum("kii->k", covs[:, :dim, :dim]), 0.0, None))
    pos_se = np.full(len(times), np.nan)
    batches = covs_all.shape[1] - 1
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
    return PosteriorBound(state_names(dim), times, infos, covs, std, pos, setup.t0,
                          setup.q_axes, trajectories if sample else 1,
                          "monte-carlo" if sample else "deterministic", len(setup.meas),
                          notes, pos_se if sample else None, share if sample else None)


def _posterior(source: object, prior_mean: ArrayLike | None, prior_cov: ArrayLike,
               time0: float | None, q: float | ArrayLike, trajectories: int, sample: bool,
               rng: np.random.Generator | int | None,
               options: Mapping[str, Mapping[str, object]] | None,
               nuisance: Mapping[str, float] | None, q_density: float | ArrayLike
               ) -> PosteriorBound:
    setup = _setup(source, prior_mean, prior_cov, time0, q, options, nuisance, q_density)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    notes = _correlation_notes(setup)
    infos, share = _recursion(setup, trajectories, sample, gen)
    return _bound(setup, infos, share, trajectories, sample, notes)


def posterior_crb(source: MeasurementSet | object, prior_mean: ArrayLike | None,
                  prior_cov: ArrayLike, time0: float | None = None, *,
                  q: float | ArrayLike = 0.0, trajectories: int = 200,
                  rng: np.random.Generator | int | None = None,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None,
                  q_density: float | ArrayLike = 0.0) -> PosteriorBound:
    """Compute the posterior CRB of a tracker, ``Gamma_k`` averaged over sampled trajectories.

    The tracker starts from ``N(prior_mean, prior_cov)`` at ``time0`` and updates once per distinct
    measurement time.

    Parameters
    ----------
    source : MeasurementSet or Scenario
        Times, sensors, kinds and sigmas (a scenario: ``prior_mean=None`` is its truth).
    prior_mean : array_like or None
        (n,) ``[x, y, (z), vx, vy, (vz)]``, m and m/s.
    prior_cov : array_like
        (n, n), SI.
    time0 : float, optional
        s; default the first measurement time.
    q : float or array_like
        Acceleration noise std per axis, m/s^2 (Chen & Sun, §2.1).
    trajectories : int
        Trajectories drawn from the prior and process noise.
    rng : Generator or int, optional
    options, nuisance : mapping, optional
        Per-kind model options and known nuisance values.
    q_density : float or array_like
        White-noise acceleration density per axis, m^2/s^3; adds to ``q``'s.

    Returns
    -------
    PosteriorBound

    Raises
    ------
    ValueError
        On a bad prior, q, time0 or trajectory count, or a missing nuisance value.
    TypeError
        On another kind of ``source``.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998); Hurtado & Nehorai (2008), eqs. 10-11 and 13.
    """
    if isinstance(trajectories, bool) or not isinstance(trajectories, (int, np.integer)) \
            or trajectories < 1:
        raise ValueError(f"trajectories must be a whole number >= 1; got {trajectories!r}")
    return _posterior(source, prior_mean, prior_cov, time0, q, int(trajectories), True, rng,
                      options, nuisance, q_density)


def deterministic_pcrb(source: MeasurementSet | object, prior_mean: ArrayLike | None,
                       prior_cov: ArrayLike, time0: float | None = None, *,
                       q: float | ArrayLike = 0.0,
                       options: Mapping[str, Mapping[str, object]] | None = None,
                       nuisance: Mapping[str, float] | None = None,
                       q_density: float | ArrayLike = 0.0) -> PosteriorBound:
    """Compute the bound with ``Gamma_k`` at the prior-mean trajectory (no sampling).

    With ``q = 0`` it is the batch CRLB plus the prior's information.

    Parameters
    ----------
    source, prior_mean, prior_cov, time0, q, options, nuisance, q_density
        As for :func:`posterior_crb`.

    Returns
    -------
    PosteriorBound

    Raises
    ------
    ValueError, TypeError
        As for :func:`posterior_crb`.

    References
    ----------
    Hurtado & Nehorai (2008), eq. 10 and, for ``Xi`` at the predicted state, section 4.2.
    """
    return _posterior(source, prior_mean, prior_cov, time0, q, 1, False, None, options,
                      nuisance, q_density)
