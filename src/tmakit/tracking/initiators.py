"""How a track starts: initiators, the initial window of a batch start, and the start records.

:meth:`Initiator.initiate` starts a :class:`~.filter_setup.FilterSetup`'s filter and returns an
:class:`Initiation` (the typed start record and the track).  :class:`PriorInitiator` starts from a
given Gaussian; :class:`BearingInitiator` at the first bearing; :class:`BatchInitiator` (the
default) from a batch estimate over the shortest good window, replaced by one from a window at
least twice as long when the next updates' summed NIS is improbable (p below
``confirm_p_value``).  A window's estimate is a good start when it converged, every state
component is observable and the position's largest 1-sigma semi-axis is below
``max_relative_std`` times the range (``docs/tracking.md``): :func:`search_window` doubles the
window from ``min_window`` until it qualifies, then bisects down to the shortest that does (with
bearings a fit may start from a neighbouring window's estimate where that decides the window
clearly; the chosen window is fitted without a guess).  The filter starts from the window's
estimate with its covariance widened to the profile likelihood (:func:`likelihood_covariance`:
a short bearings-only window's linearised covariance is overconfident in range).  The records'
:meth:`as_dict` is the ``start`` of ``tma track --json``.
"""

from __future__ import annotations

import copy
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..batch.ml import MaximumLikelihood, plausible_chi2
from ..core import chi2
from ..core.arrays import Array
from ..core.units import REACH_M, SPEED_OF_LIGHT
from ..data import MeasurementSet
from ..filters import BearingPrior, FirstBearing, Track, TrackingFilter, first_bearing
from ..measurements import model_for
from ..motion import ConstantVelocity
from ..observation import NoiseModel, ObservationModel
from ..observation.groups import time_blocks
from ..results.estimate import EstimateResult
from ..rules import time_problem
from .errors import MissingNuisanceError, StartError, TrackingError
from .filter_setup import FilterSetup, state_vector

__all__ = ["CONFIRM_P_VALUE", "DEFAULT_MAX_RELATIVE_STD", "HELD_NUISANCE_CHI2",
           "LIKELIHOOD_GROWTH", "LIKELIHOOD_TOLERANCE", "MAX_PROFILE_WIDTH", "MIN_WINDOW",
           "BatchInitiator",
           "BatchStart", "BearingInitiator", "BearingStart", "Confirmation", "Initiation",
           "Initiator", "PriorInitiator", "PriorStart", "Rejection", "StartRecord",
           "Widening", "WindowChoice", "WindowEstimate", "likelihood_covariance", "search_window"]

#: Default start quality: the position's largest 1-sigma semi-axis over the range.
DEFAULT_MAX_RELATIVE_STD = 0.25
#: A batch start is rejected (and a longer window tried) when the innovations of the updates
#: that follow it are this improbable (chi-square test of their summed NIS).
CONFIRM_P_VALUE = 1e-3
#: The smallest initial window tried (distinct measurement times).
MIN_WINDOW = 8
#: A bisection fit started from a neighbouring window's estimate decides its window only when
#: its start quality is off the threshold by more than this fraction of it (the solver's
#: tolerance moved it by up to 0.5 % over the built-in scenarios); else the window is fitted
#: without a guess.
WARM_MARGIN = 0.02
#: A batch start's nuisance value, held fixed by the filter, biases the track beyond its
#: covariances when a one-sigma error in it adds more than this to the chi-square of the rows
#: that follow.
HELD_NUISANCE_CHI2 = 1.0
#: The profile likelihood of a batch start is followed out to this many linearised 95 %
#: half-widths along the major axes of position and velocity (:func:`likelihood_covariance`)
MAX_PROFILE_WIDTH = 100.0
#: A start whose covariance widened to the profile likelihood misses the start quality
#: (``likelihood_quality``) is replaced by one from a window at least this many times as long:
#: finer than the innovation test's doubling, since the width falls fast as the window grows
#: (on hoerst2010 a window 1.25 times as long usually meets it, where doubling started the
#: multiple-model filters 130 s later, just before the target's turn).
LIKELIHOOD_GROWTH = 1.25
#: ... and its covariance widened when an end of the profile lies outside its 95 % ellipsoid by
#: more than this factor.
LIKELIHOOD_TOLERANCE = 1.1
# The profile's end points (:func:`_profile_ends`): to this fraction of their distance (and of a
# quantile in chi-square), a step going up at most this many times as far, refused when it lands
# beyond the limit by more than this many quantiles (an end given up after so many refusals in
# a row), and so many steps at most.
_PROFILE_ACCURACY = 0.01
_PROFILE_GROWTH = 4.0
_PROFILE_SLACK = 0.5
_PROFILE_HALVINGS = 10
_PROFILE_ITERATIONS = 40
# Beyond each end the profile is checked for another valley (:func:`_valleys_beyond`) at so many
# points, closest near the end, out to this many times the end's distance (or the Gaussian end's,
# sqrt of the quantile, if further), again beyond each valley found, so many times; a valley's end
# is searched for in steps at most this many times as far.
_PROBES = 8
_PROBE_REACH = 2.0
_PROBE_ROUNDS = 3
_PROBE_GROWTH = 1.25
# A probe's fit stops after so many steps, or where its Gauss-Newton model's minimum lies more
# than so many quantiles above the limit: a probe from the held fit's tangent is near its own
# valley (those that found another valley in the built-in scenarios foresaw at most 2.1), one
# from the axis in a mirror image's valley starts far from it (those foresaw up to 60).
_PROBE_ITERATIONS = 15
_PROBE_FAR = 3.0
_PROBE_FAR_MIRROR = 100.0


@dataclass(frozen=True)
class Confirmation:
    """The innovation test of a start: the NIS of the next ``updates`` updates against chi-square.

    Parameters
    ----------
    updates : int
        Updates tested.
    nis : float
        Their summed NIS.
    dof : int
        Their summed degrees of freedom.
    p_value : float
        Chi-square survival probability of ``nis`` (1 when there are no degrees of freedom).
    """

    updates: int
    nis: float
    dof: int
    p_value: float

    def as_dict(self) -> dict[str, float | int]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``updates``, ``nis``, ``dof``, ``p_value``.
        """
        return {"updates": self.updates, "nis": self.nis, "dof": self.dof,
                "p_value": self.p_value}


@dataclass(frozen=True)
class Rejection:
    """A start that its innovation test rejected, or whose profile likelihood was too wide.

    Parameters
    ----------
    window : int
        Its initial window (distinct measurement times).
    time : float
        The window's last time (s).
    confirmation : Confirmation or None
        The failed test; ``None`` for a start rejected by its widened covariance.
    relative_position_std : float or None
        The position's largest 1-sigma semi-axis over the range by the covariance widened to
        the profile likelihood, when that rejected the start (it is above the start's
        ``max_relative_std``, which the linearised covariance met).
    """

    window: int
    time: float
    confirmation: Confirmation | None
    relative_position_std: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``window``, ``time`` (s) and the test's keys, or ``relative_position_std``.
        """
        if self.confirmation is None:
            return {"window": self.window, "time": self.time,
                    "relative_position_std": self.relative_position_std}
        return {"window": self.window, "time": self.time, **self.confirmation.as_dict()}

    def describe(self) -> str:
        """Describe the rejection in one sentence.

        Returns
        -------
        str
            The window and its test.
        """
        c = self.confirmation
        if c is None:
            return (f"window of {self.window} times (t <= {float(self.time):g} s): position "
                    f"std {self.relative_position_std:.1%} of the range by its profile "
                    f"likelihood")
        return (f"window of {self.window} times (t <= {float(self.time):g} s): NIS "
                f"{float(c.nis):.4g} on {c.dof} degrees of freedom over the next "
                f"{c.updates} updates (p = {float(c.p_value):.2g})")


@dataclass(frozen=True)
class PriorStart:
    """A start from a given Gaussian prior; the filter updates with every row.

    Parameters
    ----------
    time : float
        Prior time (s).
    mean, std : ndarray
        Prior mean and standard deviations as given ``(n,)`` (m, m/s).
    covariance : ndarray
        ``diag(std**2)`` ``(n, n)``.
    nuisance : dict of str to float
        The known nuisance values given with it (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    """

    method: ClassVar[str] = "prior"

    time: float
    mean: Array
    std: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``method`` (``"prior"``), ``time`` (s), ``mean`` and ``std`` by name (m, m/s).
        """
        return {"method": self.method, "time": self.time,
                "mean": dict(zip(self.state_names, self.mean.tolist(), strict=True)),
                "std": dict(zip(self.state_names, self.std.tolist(), strict=True))}


@dataclass(frozen=True)
class Widening:
    """One end of a batch start's profile likelihood that widened its covariance.

    Parameters
    ----------
    axis : str
        ``"position"`` or ``"velocity"``: the major axis of that part of the fit's covariance.
    direction : dict of str to float
        The side of the end: the axis as a unit vector by state name (``x, y, (z)`` or
        ``vx, vy, (vz)``).
    factor : float
        How far outside the 95 % ellipsoid the end lay (its Mahalanobis distance over the
        ellipsoid's): the covariance's standard deviation along the end grew by this factor.
    converged : bool
        Whether the end point was found to its tolerance; if not, the widening is to a point
        beyond the likelihood region's limit (conservative).
    multimodal : bool
        Whether the profile left the likelihood region and came back into it (a second valley:
        another minimum of the fit, such as a mirror image or a ghost solution) before this end:
        the likelihood is multi-modal along the axis, and the widened covariance spans the
        valleys and the region between them, which the likelihood excludes.
    """

    axis: str
    direction: dict[str, float]
    factor: float
    converged: bool = True
    multimodal: bool = False

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``axis``, ``direction`` (unit vector by state name), ``factor``, ``converged``,
            ``multimodal``.
        """
        return {"axis": self.axis, "direction": dict(self.direction), "factor": self.factor,
                "converged": self.converged, "multimodal": self.multimodal}


@dataclass(frozen=True)
class BatchStart:
    """A start from a batch estimate over the first ``window`` measurement times.

    Parameters
    ----------
    time : float
        The window's last time (s), where the filter begins.
    mean, covariance : ndarray
        The filter's state ``(n,)`` (m, m/s) and covariance ``(n, n)`` at ``time``.
    nuisance : dict of str to float
        The nuisance values the filter holds, from the estimate (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    estimate : EstimateResult
        The batch estimate (constant velocity referenced at ``time``).
    window, rows : int
        Distinct measurement times and rows in the window.
    relative_position_std : float
        The position's largest 1-sigma semi-axis over the range to the nearest sensor.
    max_relative_std : float or None
        The start quality required (``None`` when the window was chosen).
    windows_tried : int
        Windows estimated by the search that found this one.
    confirmation : Confirmation or None
        The innovation test of this start.
    rejected : tuple of Rejection
        Earlier starts that their innovation tests rejected.
    held_nuisance : dict of str to float
        Per nuisance value the filter holds fixed at the estimate: the chi-square that a
        one-sigma error in it adds over the rows after the start.
    widened : tuple of Widening
        The ends of the estimate's profile likelihood that widened its covariance into
        ``covariance`` (:func:`likelihood_covariance`; empty: the linearised covariance).
    """

    method: ClassVar[str] = "batch"

    time: float
    mean: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]
    estimate: EstimateResult
    window: int
    rows: int
    relative_position_std: float
    max_relative_std: float | None
    windows_tried: int
    confirmation: Confirmation | None = None
    rejected: tuple[Rejection, ...] = field(default_factory=tuple)
    held_nuisance: dict[str, float] = field(default_factory=dict)
    widened: tuple[Widening, ...] = ()

    def held_nuisance_note(self) -> str:
        """Say which held nuisance values bias the track beyond its covariances.

        Returns
        -------
        str
            One sentence; "" when a one-sigma error in each adds at most
            :data:`HELD_NUISANCE_CHI2` to the chi-square of the rows after the start.
        """
        bad = {n: c for n, c in self.held_nuisance.items() if c > HELD_NUISANCE_CHI2}
        if not bad:
            return ""
        held = ", ".join(f"{n} = {v:.6g} ± {sd:.2g} (chi2 {bad[n]:.3g})"
                         for n, (v, sd) in self.estimate.nuisance.items() if n in bad)
        return (f"the filter holds the start's nuisance estimate fixed ({held}: the chi-square "
                "that a one-sigma error in it adds over the rows after the start); its error "
                "biases the track and is not in the track's covariances, so the ellipses may "
                "miss the truth: a batch estimate (tma estimate) eliminates it, or give it as "
                "known with a prior")

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``method`` (``"batch"``), ``window``, ``rows``, ``time`` (s), ``status``, ``chi2``,
            ``dof``, ``relative_position_std``, ``max_relative_std``, ``windows_tried``,
            ``nuisance`` (value and std by name), ``held_nuisance`` (chi-square by name),
            ``held_nuisance_note``, ``widened`` (the profile-likelihood ends that widened the
            covariance: ``axis``, ``direction``, ``factor``, ``converged``, ``multimodal``),
            ``confirmation`` and ``rejected``.
        """
        est = self.estimate
        out: dict[str, Any] = {
            "method": self.method,
            "window": self.window,
            "rows": self.rows,
            "time": self.time,
            "status": est.status,
            "chi2": float(est.chi2),
            "dof": int(est.dof),
            "relative_position_std": float(self.relative_position_std),
            "max_relative_std": self.max_relative_std,
            "windows_tried": self.windows_tried,
            "nuisance": {name: {"value": v, "std": sd}
                         for name, (v, sd) in est.nuisance.items()},
            "held_nuisance": dict(self.held_nuisance),
            "held_nuisance_note": self.held_nuisance_note(),
            "widened": [w.as_dict() for w in self.widened],
        }
        if self.confirmation is not None:
            out["confirmation"] = self.confirmation.as_dict()
        out["rejected"] = [r.as_dict() for r in self.rejected]
        return out


@dataclass(frozen=True)
class BearingStart:
    """A start at the first bearing from a prior in the user's terms (range, speed, height).

    Parameters
    ----------
    time : float
        The first bearing's time (s).
    mean, covariance : ndarray
        The prior's mean ``(n,)`` (m, m/s) and covariance ``(n, n)`` there.
    nuisance : dict of str to float
        Known nuisance values given with it (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    prior : BearingPrior
        The intervals.
    first : FirstBearing
        The bearing the prior is centred on (its row is not used again).
    confirmation : Confirmation, optional
        The innovation test of the start.
    rejected : tuple of Rejection
        Earlier bearings whose starts the test rejected (window 1: one bearing).
    unused : int
        Rows of other kinds before ``time``, which a filter started there cannot take.
    """

    method: ClassVar[str] = "first-bearing"

    time: float
    mean: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]
    prior: BearingPrior
    first: FirstBearing
    confirmation: Confirmation | None = None
    rejected: tuple[Rejection, ...] = ()
    unused: int = 0

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``method`` (``"first-bearing"``), ``time`` (s), ``bearing_deg``, ``row``, ``prior``,
            ``mean`` and ``std`` by name (m, m/s), ``confirmation``, ``rejected`` and
            ``unused_rows`` (rows of other kinds before the start).
        """
        std = [math.sqrt(max(float(v), 0.0)) for v in self.covariance.diagonal()]
        return {"method": self.method, "time": self.time,
                "bearing_deg": math.degrees(self.first.bearing) % 360.0,
                "row": self.first.row, "prior": self.prior.as_dict(),
                "mean": dict(zip(self.state_names, self.mean.tolist(), strict=True)),
                "std": dict(zip(self.state_names, std, strict=True)),
                "confirmation": None if self.confirmation is None
                else self.confirmation.as_dict(),
                "rejected": [r.as_dict() for r in self.rejected], "unused_rows": self.unused}


#: What an initiator returns.
StartRecord = PriorStart | BatchStart | BearingStart


@dataclass(frozen=True)
class WindowEstimate:
    """The batch estimate over one initial window.

    Parameters
    ----------
    window, rows : int
        Distinct measurement times and rows in the window.
    time : float
        Its last time (s), the estimate's reference time.
    estimate : EstimateResult or None
        The estimate; ``None`` when the estimator refused the window.
    relative_position_std : float
        Largest 1-sigma position semi-axis over the range (``inf``: not a start).
    problem : str
        Why the estimate is not a start ("" when it is converged and observable).
    """

    window: int
    time: float
    rows: int
    estimate: EstimateResult | None
    relative_position_std: float
    problem: str


@dataclass(frozen=True)
class WindowChoice:
    """The window a search chose, and how many it estimated.

    Parameters
    ----------
    chosen : WindowEstimate
        The window (its estimate is converged and observable).
    windows_tried : int
        Windows estimated by the search.
    """

    chosen: WindowEstimate
    windows_tried: int


def _relative_std(result: EstimateResult, rows: MeasurementSet, time: float, dim: int
                  ) -> float | None:
    """Give the position's largest 1-sigma semi-axis over the range to the nearest sensor."""
    theta = result.estimate
    motion = result.motion
    state = motion.states(theta, np.array([time]))[0]
    jac = motion.jacobian(theta, np.array([time]))[0][list(range(dim))]
    cov = jac @ result.covariance @ jac.T
    if not np.all(np.isfinite(cov)):
        return None
    last = np.abs(rows.time - rows.time.max()) < 1e-9
    ranges = np.linalg.norm(state[None, :dim] - rows.sensor_state[last][:, :dim], axis=1)
    rng = float(np.min(ranges))
    major = float(np.sqrt(max(np.max(np.linalg.eigvalsh(cov)), 0.0)))
    return major / rng if rng > 0 else np.inf


def likelihood_covariance(result: EstimateResult, rows: MeasurementSet, time: float, dim: int,
                          options: Mapping[str, Mapping[str, object]] | None = None
                          ) -> tuple[Array, tuple[Widening, ...]]:
    """Give the fit's covariance widened to its profile likelihood in position and velocity.

    The profile likelihood of ``rows`` (the other parameters re-fitted, the nuisance held) is
    followed along the major axis of the position's covariance at ``time`` and of the
    velocity's, on either side, out to where its chi-square has risen by the 95 % chi-square
    quantile for all ``p`` parameters: the end points of the likelihood region (Venzon &
    Moolgavkar 1988), found by Gauss-Newton steps on their two conditions (the chi-square at
    that limit, stationary in the other parameters).  Each end point outside the 95 % ellipsoid
    of the covariance (as widened so far) by more than ``LIKELIHOOD_TOLERANCE`` times widens it
    by a rank-one term along it until it lies on the ellipsoid: a Gaussian likelihood leaves the
    covariance as it is.  A linearised (Cramer-Rao type) covariance is overconfident where the
    likelihood is far from Gaussian, as in range on a short bearings-only window (Aidala &
    Hammel 1983).

    Parameters
    ----------
    result : EstimateResult
        A converged batch estimate over ``rows``.
    rows : MeasurementSet
        Its measurements.
    time : float
        The time of the position (s).
    dim : int
        Spatial dimension, 2 or 3.
    options : mapping, optional
        Per-kind measurement-model options.

    Returns
    -------
    covariance : ndarray
        The covariance of ``result.estimate``, ``(p, p)``: ``result.covariance`` when every end
        point lies within the tolerance of its ellipsoid (or the covariance is not positive
        definite).
    widened : tuple of Widening
        The end points that widened it, in the order applied.
    """
    theta, cov = result.estimate, result.covariance
    try:  # theta = estimate + scale @ z: z has the covariance I
        scale = np.asarray(np.linalg.cholesky(cov), dtype=np.float64)
    except np.linalg.LinAlgError:
        return cov, ()
    if not np.all(np.isfinite(scale)):
        return cov, ()
    states = result.motion.jacobian(theta, np.array([time]))[0]
    sides: list[tuple[str, dict[str, float]]] = []
    ups = []
    for axis, offset, names in (("position", 0, ("x", "y", "z")),
                                ("velocity", 3, ("vx", "vy", "vz"))):
        jac = states[offset:offset + dim] @ scale
        major = np.linalg.eigh(jac @ jac.T)[1][:, -1]
        for sign in (1.0, -1.0):
            sides.append((axis, dict(zip(names[:dim], (sign * major).tolist(), strict=True))))
            ups.append(sign * major @ jac / np.linalg.norm(major @ jac))
    quantile = float(chi2.ppf(0.95, len(theta)))
    obs = ObservationModel(rows, result.motion, options)
    nu = (obs.nuisance_vector({n: v for n, (v, _) in result.nuisance.items()})
          if obs.n_nuisance else None)
    mirrored = "z" in result.motion.param_names and rows.mirror_plane(1e-9) is not None
    ends, converged, multimodal = _profile_ends(lambda z: theta + z @ scale.T, scale,
                                                np.array(ups), obs, NoiseModel(rows), nu, quantile,
                                                mirrored=mirrored)
    wide_z, wide, widened = np.eye(len(theta)), cov, []
    for (axis, direction), z, sure, valleys in zip(sides, ends, converged, multimodal,
                                                   strict=True):
        m = float(z @ np.linalg.solve(wide_z, z)) if np.all(np.isfinite(z)) else np.nan
        if np.isfinite(m) and m > quantile * LIKELIHOOD_TOLERANCE ** 2:
            wider_z = wide_z + (m / quantile - 1.0) / m * np.outer(z, z)
            wider = scale @ wider_z @ scale.T
            if np.all(np.linalg.eigvalsh(wider) > 0):  # (not lost to rounding)
                wide_z, wide = wider_z, (wider + wider.T) / 2
                widened.append(Widening(axis, direction, math.sqrt(m / quantile), bool(sure),
                                        bool(valleys)))
    return wide, tuple(widened)


def _profile_ends(point: Callable[[Array], Array], scale: Array, dirs: Array,
                  obs: ObservationModel, noise: NoiseModel, nu: Array | None, quantile: float,
                  *, mirrored: bool = False) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_]]:
    """Give the ends ``(k, p)`` of the profiles up unit ``dirs[i] @ z``, converged, multi-modal.

    ``point(z)`` is theta; in ``z`` the fit's covariance is the identity.  The ends are iterated
    from ``z = 0`` together (one evaluation of the residuals and one of the Jacobians per step,
    for all of them): a Gauss-Newton step to where the linearised chi-square, minimised over the
    directions that keep ``dirs[i] @ z``, reaches the limit (:func:`_end_steps`), at most
    ``_PROFILE_GROWTH`` times as far up as before and at most ``MAX_PROFILE_WIDTH`` linearised
    ends up, within a trust radius (Nocedal & Wright 2006, ch. 4): a step is refused when it
    lands beyond the limit by more than ``_PROFILE_SLACK`` quantiles (from beyond it, when it
    does not lower the chi-square), and the radius halves; it grows after a step whose
    chi-square the model foresaw.  An end still short after ``_PROFILE_ITERATIONS`` steps (or
    ``_PROFILE_HALVINGS`` refusals), as in a curved valley, is finished by
    :func:`_profile_search`.  A local search follows one valley; the profile beyond each end is
    then checked for another (:func:`_valleys_beyond`): multi-modal, the ends beyond one.
    """
    k, p = dirs.shape

    def residuals(z: Array) -> Array:
        return np.asarray(noise.whiten(obs.residuals(point(z), nu)))

    def jacobians(z: Array) -> Array:  # of the whitened residuals, in z
        return -np.asarray(noise.whiten(obs.jacobian(point(z), nu)[0] @ scale, axis=-2))

    res0 = residuals(np.zeros(p))
    limit = float(res0 @ res0) + quantile
    cap = (1 - 1e-9) * MAX_PROFILE_WIDTH * math.sqrt(quantile)
    z = np.zeros((k, p))
    res, jac = np.repeat(res0[None], k, axis=0), np.repeat(jacobians(z[0])[None], k, axis=0)
    cost = np.full(k, limit - quantile)
    radius = np.full(k, _PROFILE_GROWTH * math.sqrt(quantile))
    finished = np.zeros(k, dtype=bool)
    halved = np.zeros(k, dtype=int)
    converged = np.zeros(k, dtype=bool)
    for _ in range(_PROFILE_ITERATIONS):
        steps, done, model = _end_steps(res, jac, dirs, z, cost, limit, quantile, radius)
        done &= ~finished
        z[done] += steps[done]
        done |= ~finished & (np.einsum("kp,kp->k", z, dirs) >= cap) & (cost < limit)
        finished |= done
        converged |= done
        if finished.all():
            break
        steps[finished] = 0.0
        trial = residuals(z + steps)
        new = np.einsum("kn,kn->k", trial, trial)
        ok = ~finished & np.isfinite(new) & np.where(
            cost <= limit, new <= limit + _PROFILE_SLACK * quantile, new < cost)
        length = np.sqrt(np.einsum("kp,kp->k", steps, steps))
        # the radius grows after a step the model foresaw, and halves after a refused one
        foreseen = np.abs(new - model) <= _PROFILE_SLACK * quantile
        radius = np.where(ok, np.where(foreseen, _PROFILE_GROWTH, 1.0) * length, length / 2)
        halved = np.where(ok, 0, halved + 1)
        finished |= halved >= _PROFILE_HALVINGS
        if ok.any():
            z[ok] += steps[ok]
            res[ok], cost[ok] = trial[ok], new[ok]
            jac[ok] = jacobians(z[ok])
    for i in np.flatnonzero(~converged):
        z[i], converged[i] = _profile_search(residuals, jacobians, dirs[i], z[i], limit, quantile,
                                             cap)
    multimodal = _valleys_beyond(residuals, jacobians, dirs, z, converged, limit, quantile, cap,
                                 mirrored)
    return z, converged, multimodal


def _valleys_beyond(residuals: Callable[[Array], Array], jacobians: Callable[[Array], Array],
                    dirs: Array, z: Array, converged: NDArray[np.bool_], limit: float,
                    quantile: float, cap: float, mirrored: bool) -> NDArray[np.bool_]:
    """Move each end ``z[i]`` out past any further valley of its profile (in place).

    A local search stops at the end of the valley it started in; where the fit has another
    minimum (a mirror image, a ghost solution) the profile may fall back inside the limit
    further out: the likelihood region along the axis is then not one interval.  The profile is
    fitted at ``_PROBES`` points beyond the end, ``t + (reach - t) (j / _PROBES)**2``, out to
    ``reach``, ``_PROBE_REACH`` times the end's distance ``t`` or the Gaussian end's
    (``sqrt(quantile)``), whichever is further, each from the point on the axis
    (:func:`_held_fits`); where one lies inside the limit, the end is searched for again from
    the outermost such point (:func:`_profile_search`) and the profile beyond the new end
    checked in turn, ``_PROBE_ROUNDS`` times at most.  A valley narrower than the probes'
    spacing (1.6 % of ``reach - t`` next to the end, 23 % at ``reach``) may be missed.  Gives
    whether each end moved past another valley.
    """
    multimodal = np.zeros(len(dirs), dtype=bool)
    todo = np.ones(len(dirs), dtype=bool)
    for _ in range(_PROBE_ROUNDS):
        owners, ts = [], []
        for i in np.flatnonzero(todo):
            up = max(float(dirs[i] @ z[i]), math.sqrt(quantile) / _PROFILE_GROWTH)
            reach = min(_PROBE_REACH * max(up, math.sqrt(quantile)), cap)
            if reach > up:
                ts += (up + (reach - up) * (np.arange(1, _PROBES + 1) / _PROBES) ** 2).tolist()
                owners += [i] * _PROBES
        if not owners:
            break
        own, t = np.array(owners), np.array(ts)
        jac = jacobians(z)
        hess = jac.transpose(0, 2, 1) @ jac
        tangent = _solve_each(hess, dirs)  # (the way the held fit moves as dirs @ z grows)
        tangent /= np.einsum("kp,kp->k", tangent, dirs)[:, None]
        starts = z[own] + (t - np.einsum("mp,mp->m", z[own], dirs[own]))[:, None] * tangent[own]
        far = np.full(len(own), _PROBE_FAR)
        if mirrored:
            own, t = np.concatenate([own, own]), np.concatenate([t, t])
            starts = np.concatenate([starts, t[len(starts):, None] * dirs[own[len(starts):]]])
            far = np.concatenate([far, np.full(len(far), _PROBE_FAR_MIRROR)])
        order = np.lexsort((t, own))
        own, t = own[order], t[order]
        points, costs = _held_fits(residuals, jacobians, dirs[own], starts[order], limit,
                                   quantile, far[order])
        todo[:] = False
        for i in np.unique(own[costs < limit]):
            j = np.flatnonzero((own == i) & (costs < limit))[-1]  # (the outermost)
            z[i], converged[i] = _profile_search(residuals, jacobians, dirs[i], points[j], limit,
                                                 quantile, cap, _PROBE_GROWTH)
            if not converged[i] and j + 1 < len(own) and own[j + 1] == i:
                z[i] = points[j + 1]  # (the next point out, beyond the limit: conservative)
            multimodal[i] = todo[i] = True
    return multimodal


def _held_fits(residuals: Callable[[Array], Array], jacobians: Callable[[Array], Array],
               dirs: Array, z: Array, limit: float, quantile: float, far: Array
               ) -> tuple[Array, Array]:
    """Fit each ``z[i]`` with ``dirs[i] @ z`` held, until inside ``limit``; give them, their costs.

    Levenberg-Marquardt steps (Nocedal & Wright 2006, ch. 10) in the complement of each
    direction, all points together; a point stops once its chi-square is below ``limit`` (a
    valley there), or when a Gauss-Newton step foresees less than ``_PROFILE_ACCURACY``
    quantiles of decrease in a step shorter than ``_PROFILE_ACCURACY`` of the point's distance
    (a minimum above the limit; a long step that foresees little crosses a flat stretch), or
    foresees a minimum more than ``far[i]`` quantiles above the limit, or after
    ``_PROBE_ITERATIONS`` steps.
    """
    basis = np.linalg.svd(dirs[:, None, :])[2][:, 1:, :]  # (m, p - 1, p): the held-free moves
    z = np.array(z, dtype=np.float64)
    res = residuals(z)
    cost = np.einsum("mn,mn->m", res, res)
    active = np.isfinite(cost) & (cost >= limit)
    jac, stale = np.zeros((*res.shape, z.shape[1])), np.ones(len(z), dtype=bool)
    damping = np.full(len(z), 1e-3)
    for _ in range(_PROBE_ITERATIONS):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        if stale[idx].any():
            jac[idx[stale[idx]]] = jacobians(z[idx[stale[idx]]])
            stale[idx] = False
        j, b = jac[idx], basis[idx]
        grad = (b @ (res[idx][:, None, :] @ j)[:, 0, :, None])[..., 0]
        hess = b @ (j.transpose(0, 2, 1) @ j) @ b.transpose(0, 2, 1)
        gn = _solve_each(hess, grad)
        length = np.sqrt(np.einsum("aq,aq->a", gn, gn))
        dist = np.sqrt(np.einsum("ap,ap->a", z[idx], z[idx]))
        foreseen = np.einsum("aq,aq->a", grad, gn)
        flat = ~(((foreseen > _PROFILE_ACCURACY * quantile) | (length > _PROFILE_ACCURACY * dist))
                 & (cost[idx] - foreseen <= limit + far[idx] * quantile))  # (or not finite)
        active[idx[flat]] = False
        idx, grad, hess = idx[~flat], grad[~flat], hess[~flat]
        if not len(idx):
            break
        diag = np.einsum("aqq->aq", hess)
        step = -_solve_each(hess + (damping[idx] * diag.max(axis=1))[:, None, None]
                            * np.eye(len(grad[0])), grad)
        trial = z[idx] + np.einsum("aq,aqp->ap", step, basis[idx])
        tres = residuals(trial)
        new = np.einsum("an,an->a", tres, tres)
        ok = np.isfinite(new) & (new < cost[idx])
        damping[idx] = np.where(ok, damping[idx] / 10, damping[idx] * 10)
        good = idx[ok]
        # (a short step that lowered the chi-square by less than the accuracy: at a minimum)
        short = np.sqrt(np.einsum("aq,aq->a", step[ok], step[ok])) <= (
            _PROFILE_ACCURACY * dist[~flat][ok])
        small = short & (cost[good] - new[ok] <= _PROFILE_ACCURACY * quantile)
        z[good], res[good], cost[good], stale[good] = trial[ok], tres[ok], new[ok], True
        active[good[(new[ok] < limit) | small]] = False
        # (a refused step whose model foresaw less than the accuracy: damping more will not do)
        hopeless = -(2 * np.einsum("aq,aq->a", grad, step)
                     + np.einsum("aq,aqr,ar->a", step, hess, step)) <= _PROFILE_ACCURACY * quantile
        active[idx[(~ok & hopeless) | (damping[idx] > 1e8)]] = False
    return z, cost


def _profile_search(residuals: Callable[[Array], Array], jacobians: Callable[[Array], Array],
                    direction: Array, z: Array, limit: float, quantile: float, cap: float,
                    growth: float = _PROFILE_GROWTH) -> tuple[Array, bool]:
    """Finish an end that Gauss-Newton left short: a bracketed root of the profile's chi-square.

    The profile at ``t = direction @ z`` is the fit with that coordinate held (Levenberg-
    Marquardt over the rest, from the fit at the bracket's inner end); its end is where it
    reaches ``limit``, bracketed by points inside and beyond the limit (from the Gauss-Newton
    point up past the secant's crossing, at most ``growth`` times as far a step, or down to
    ``z = 0``) and found by
    regula falsi (the Illinois variant) to within ``_PROFILE_ACCURACY`` of a quantile in
    chi-square.  Gives the end and whether it converged; if not (a fit failed, or the profile
    jumps across the limit between two valleys), the bracket's outer end: beyond the limit, so
    widening to it is conservative.
    """
    from scipy.linalg import null_space  # (here: few starts come here)

    basis = null_space(direction[None])

    def fit(t: float, start: Array) -> tuple[Array, float]:
        end, r = _held_fit(residuals, jacobians, t * direction, basis, start)
        value = float(r @ r) - limit
        if not math.isfinite(value):
            raise FloatingPointError
        return end, value

    tolerance = _PROFILE_ACCURACY * quantile
    up = float(direction @ z)
    outer = (up, z)
    try:
        inner = (0.0, np.zeros_like(z), -quantile)
        t = max(up, math.sqrt(quantile) / _PROFILE_GROWTH)
        point, value = fit(t, z)
        while value < 0:
            (t0, _, e0), inner = inner, (t, point, value)
            if t >= cap or value > -tolerance:
                return point, True  # (at the limit, or inside it up to the cap)
            # up to a little beyond the secant's crossing, 5 % to `growth` times as far
            guess = t - 1.2 * value * (t - t0) / (value - e0) if value > e0 else math.inf
            t = min(max(guess, 1.05 * t), growth * t, cap)
            point, value = fit(t, point)
        high = (t, point, value)
        outer = (t, point)
        if value <= tolerance:
            return point, True
        low, side = inner, 0
        for _ in range(_PROFILE_ITERATIONS):
            (t0, _, e0), (t1, _, e1) = low, high
            if t1 - t0 <= 1e-9 * t1:
                break  # (a jump across the limit: no end at the limit here)
            t = (t0 * e1 - t1 * e0) / (e1 - e0)
            point, value = fit(t, low[1])
            if abs(value) <= tolerance:
                return point, True
            if value < 0:
                low = (t, point, value)
                if side < 0:
                    high = (high[0], high[1], high[2] / 2)
                side = -1
            else:
                high = (t, point, value)
                outer = (t, point)
                if side > 0:
                    low = (low[0], low[1], low[2] / 2)
                side = 1
    except (FloatingPointError, np.linalg.LinAlgError):
        pass
    return outer[1], False


def _solve_each(a: Array, b: Array) -> Array:
    """Solve ``a[i] x[i] = b[i]`` for a stack, by the pseudo-inverse where ``a[i]`` is singular."""
    try:
        return np.asarray(np.linalg.solve(a, b[..., None])[..., 0])
    except np.linalg.LinAlgError:
        x = np.full_like(b, np.nan)
        for i in np.flatnonzero(np.isfinite(a).all(axis=(1, 2))):
            x[i] = np.linalg.lstsq(a[i], b[i], rcond=None)[0]
        return x


def _held_fit(residuals: Callable[[Array], Array], jacobians: Callable[[Array], Array],
              held: Array, basis: Array, start: Array) -> tuple[Array, Array]:
    """Give ``held + basis @ w`` at the least-squares ``w`` from ``start``'s, and its residuals.

    A trust-region reflective fit (``least_squares(method="trf")``, ``x_scale="jac"``; numpy
    and LAPACK, the same fit bit for bit in every process), the residuals at a point asked for
    twice computed once.  Not MINPACK's lmder (``leastsq``): with the same residuals and
    Jacobians its steps differed between processes, with the contents of memory it had not
    written (``MALLOC_PERTURB_`` changed them), and so did the profile's end.
    Raises ``FloatingPointError`` when it does not converge.
    """
    # (imported here: scipy.optimize takes 0.1-0.2 s to import, and few starts come here)
    from scipy.optimize import least_squares

    last: list[tuple[bytes, Array]] = []

    def res(w: Array) -> Array:
        key = w.tobytes()
        if not last or last[0][0] != key:
            last[:] = [(key, residuals(held + basis @ w))]
        return last[0][1]

    fit = least_squares(res, basis.T @ start, jac=lambda w: jacobians(held + basis @ w) @ basis,
                        method="trf", x_scale="jac", xtol=1e-6, ftol=1e-6, gtol=1e-8,
                        max_nfev=100 * basis.shape[1])
    if fit.status <= 0:
        raise FloatingPointError
    w = fit.x
    return held + basis @ w, res(w)


def _end_steps(res: Array, jac: Array, dirs: Array, z: Array, cost: Array, limit: float,
               quantile: float, radius: Array) -> tuple[Array, NDArray[np.bool_], Array]:
    """Give the Gauss-Newton steps ``(k, p)`` to the profiles' ends, which are done, their models.

    With ``H = J'J`` and ``g = J'r``, the step that moves ``a`` up ``v`` and minimises the
    model over the rest is ``fix + a * tangent``: ``fix = -H^-1 g + H^-1 v (v'H^-1 g) / k``,
    ``tangent = H^-1 v / k``, ``k = v'H^-1 v``; its model chi-square is the model's minimum
    plus ``(a + v'H^-1 g)**2 / k``.  An end is done when its chi-square is within
    ``_PROFILE_ACCURACY`` quantiles of the limit and its step below that fraction of its
    distance, or when it is near the limit and, a step's length further, still inside the
    tolerance (it widens nothing).
    """
    grad = np.einsum("knp,kn->kp", jac, res)
    rhs = np.stack([grad, dirs], axis=-1)
    hess = np.einsum("knp,knq->kpq", jac, jac)
    try:
        s = np.linalg.solve(hess, rhs)
    except np.linalg.LinAlgError:
        s = np.linalg.pinv(hess, hermitian=True) @ rhs
    vs0, kappa = np.einsum("kp,kpj->jk", dirs, s)
    stuck = ~(kappa > 1e-12)  # (H singular up v: no step)
    kappa[stuck] = 1.0
    first = math.sqrt(quantile)
    up = np.einsum("kp,kp->k", z, dirs)
    reach = np.minimum(_PROFILE_GROWTH * np.maximum(up, first), MAX_PROFILE_WIDTH * first)
    lowest = cost - np.einsum("kp,kp->k", grad, s[..., 0])
    a = np.clip(np.sqrt(np.maximum(limit - lowest, 0.0) * kappa) - vs0 + up,
                up / _PROFILE_GROWTH, reach) - up
    tangent = s[..., 1] / kappa[:, None]
    fix = tangent * vs0[:, None] - s[..., 0]
    steps = fix + a[:, None] * tangent
    length = np.sqrt(np.einsum("kp,kp->k", steps, steps))
    far = np.sqrt(np.einsum("kp,kp->k", z, z))
    gap = np.abs(cost - limit)
    stuck |= ~np.isfinite(length)
    done = stuck | ((gap <= _PROFILE_ACCURACY * quantile) & (length <= _PROFILE_ACCURACY * far)) | (
        (gap <= 0.25 * quantile) & (far + 2 * length <= LIKELIHOOD_TOLERANCE * first))
    steps[stuck] = 0.0
    cut = ~stuck & (length > radius)
    if cut.any():  # from inside the limit the fix first, then as far up as the radius allows
        fix, tangent, a, steps_cut = fix[cut], tangent[cut], a[cut], steps[cut]
        r2, fix2 = radius[cut] ** 2, np.maximum(np.einsum("kp,kp->k", fix, fix), 1e-300)
        t2, ft = np.einsum("kp,kp->k", tangent, tangent), np.einsum("kp,kp->k", fix, tangent)
        room = np.sqrt(np.maximum(ft * ft - t2 * (fix2 - r2), 0.0))
        a = np.where(fix2 >= r2, 0.0, (np.sign(a) * room - ft) / t2)
        inner = fix * np.minimum(1.0, np.sqrt(r2 / fix2))[:, None] + a[:, None] * tangent
        outer = steps_cut * (radius[cut] / length[cut])[:, None]  # both parts lower the cost
        steps[cut] = np.where((cost[cut] <= limit)[:, None], inner, outer)
    model = (cost + 2 * np.einsum("kp,kp->k", grad, steps)
             + np.einsum("kp,kpq,kq->k", steps, hess, steps))
    return steps, done, model


class _Windows:
    """The batch estimates of the initial windows of one set, each computed once."""

    def __init__(self, meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None, fit_p_value: float = 0.0,
                 max_relative_std: float = DEFAULT_MAX_RELATIVE_STD) -> None:
        self.meas, self.dim, self.options, self.fit_p_value = meas, dim, options, fit_p_value
        self.max_relative_std = max_relative_std
        self.order, self.bounds = time_blocks(meas.time)  # time k: order[bounds[k]:bounds[k + 1]]
        self.tried: dict[int, WindowEstimate] = {}
        self.warm: set[int] = set()  # windows whose fit started from another's estimate
        # With bearings the search without a guess keeps the fit from its best grid start when
        # that fit is plausible: as local as a warm start.  Without, it takes the best of
        # several starts' fits, and a warm start may end in another minimum.
        self.can_warm = "bearing" in meas.kinds

    def __len__(self) -> int:
        return len(self.bounds) - 1

    def __call__(self, k: int, near: int | None = None) -> WindowEstimate:
        """Give window ``k``'s estimate; ``near``: a fitted window whose estimate may start it.

        A fit from that guess stands when it decides the window clearly (see :meth:`_clear`);
        else, and for the chosen window (:meth:`choice`), the fit is the search without a
        guess, as if no guess had been tried.
        """
        if k not in self.tried:
            start = self.tried[near].estimate if near is not None and self.can_warm else None
            if start is not None:
                w = self._fit(k, start)
                if self._clear(w):
                    self.warm.add(k)
                    self.tried[k] = w
                    return w
            self.tried[k] = self._fit(k)
        return self.tried[k]

    def _fit(self, k: int, near: EstimateResult | None = None) -> WindowEstimate:
        """Fit the first ``k`` times without a guess, or from ``near`` moved to their end."""
        rows = self.meas.take(self.order[:self.bounds[k]])
        time = float(rows.time.max())
        init = None
        if near is not None:
            state = near.motion.states(near.estimate, np.array([time]))[0]
            init = np.concatenate([state[:self.dim], state[3:3 + self.dim]])
        try:  # (a start reports no separated solutions: not looked for)
            result = MaximumLikelihood(init, self.options, solutions=False).fit(
                rows, ConstantVelocity(self.dim, time))
        except ValueError as e:  # e.g. no finite starting point on a tiny window
            return WindowEstimate(k, time, len(rows), None, np.inf, f"failed: {e}")
        rel = (_relative_std(result, rows, time, self.dim)
               if result.status == "converged" else None)
        problem = "" if rel is not None else result.status + (
            f": {result.message}" if result.message else "")
        p = result.chi2_p_value
        if not problem and p is not None and p < self.fit_p_value:
            rel, problem = None, (f"an improbable fit (chi2 {result.chi2:.4g} on "
                                  f"{result.dof} dof, p = {p:.2g})")
        return WindowEstimate(k, time, len(rows), result, np.inf if rel is None else rel,
                              problem)

    def _clear(self, w: WindowEstimate) -> bool:
        """Tell whether a warm-started fit decides its window as the search without a guess.

        It must have converged to a fit the search would accept from its first start
        (observable, a plausible chi-square), with the start quality and the fit's p-value
        off their thresholds by more than the solver's tolerance can move them.
        """
        res = w.estimate
        if res is None or w.problem or not plausible_chi2(res.chi2, res.dof):
            return False
        p = res.chi2_p_value
        return (abs(w.relative_position_std / self.max_relative_std - 1.0) > WARM_MARGIN
                and (p is None or not self.fit_p_value / 2 <= p <= 2 * self.fit_p_value))

    def choice(self, k: int) -> WindowChoice | None:
        """Give window ``k`` fitted without a guess as the choice; None if it is then no start."""
        if k in self.warm:
            self.warm.discard(k)
            self.tried[k] = self._fit(k)
            if self.tried[k].relative_position_std >= self.max_relative_std:
                return None
        return WindowChoice(self(k), len(self.tried))

    def no_start(self, max_relative_std: float) -> StartError:
        """Build the error when no window qualifies: the best one, and the ways out."""
        usable = [(w.relative_position_std, k) for k, w in self.tried.items()
                  if np.isfinite(w.relative_position_std)]
        fits = [w.problem for w in self.tried.values() if w.problem.startswith("an impr")]
        tried = f"{len(self.tried)} windows of up to {len(self)} measurement times tried"
        if fits and not usable:
            return StartError(
                f"cannot start the filter from the data: every converged window's estimate is "
                f"{fits[-1]} ({tried}): the data are not one target in constant velocity with "
                "the stated sigmas; look for clutter or a manoeuvre, check the sigmas, or "
                "give a prior ({prior}/{prior_std})", "prior", ["prior", "prior_std"])
        if usable:
            rel, kk = min(usable)
            detail = (f"the best converged, observable window ({kk} measurement times) "
                      f"has a position std of {rel:.0%} of the range")
        else:
            detail = "no window gave a converged, observable estimate"
        flat = ("; the track is 3-D: if the sensors move on a surface the height is not "
                "observable, track in 2-D ({dim} 2)" if self.dim == 3 else "")
        return StartError(
            f"cannot start the filter from the data: {detail}, and the start needs less "
            f"than {max_relative_std:.0%} ({tried}); "
            "give a prior ({prior}/{prior_std}) or relax the start quality "
            "({max_relative_std})" + flat, "prior",
            ["prior", "prior_std", "max_relative_std", *(["dim"] if flat else [])])


def search_window(meas: MeasurementSet, dim: int,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  init_window: int | None = None, max_relative_std: float = 0.25, *,
                  min_window: int = MIN_WINDOW, fit_p_value: float = 0.0) -> WindowChoice:
    """Return the initial window a batch start uses.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    dim : int
        Spatial dimension, 2 or 3.
    options : mapping, optional
        Per-kind measurement-model options.
    init_window : int, optional
        Use exactly this many distinct measurement times; by default the shortest good one.
    max_relative_std : float
        The start quality: position std over range must be below it (the search).
    min_window : int
        The first window tried by the search (distinct measurement times).
    fit_p_value : float
        A window whose fit's chi-square p-value is below it is no start (0: no test).

    Returns
    -------
    WindowChoice
        The window and its estimate.

    Raises
    ------
    TrackingError
        An empty set, or ``init_window`` outside 1 .. the number of times.
    StartError
        The chosen window's estimate is no start, or no window qualifies.
    """
    windows = _Windows(meas, dim, options, fit_p_value, max_relative_std)
    n = len(windows)
    if n == 0:
        raise TrackingError("the measurement set is empty: nothing to track")
    if init_window is not None:
        if int(init_window) != init_window or not 1 <= init_window <= n:
            raise TrackingError(f"init_window: expected a whole number of measurement times "
                                f"from 1 to {n}, got {init_window}", "init_window")
        k = int(init_window)
        w = windows(k)
        if w.problem:
            verb = "" if w.problem.startswith("failed") else "is "
            raise StartError(f"the batch estimate over the first {k} measurement times "
                             f"(t <= {w.time:g} s) {verb}{w.problem}; use a longer window or "
                             "give a prior", "init_window")
        return WindowChoice(w, len(windows.tried))
    if not max_relative_std > 0:
        raise TrackingError(f"max_relative_std must be > 0, got {max_relative_std}",
                            "max_relative_std")
    found = _bisect(windows, min_window, warm=True)
    if found is None:  # the fit without a guess overturned a warm-started decision
        found = _bisect(_Windows(meas, dim, options, fit_p_value, max_relative_std),
                        min_window, warm=False)
    assert found is not None
    return found


def _bisect(windows: _Windows, min_window: int, warm: bool) -> WindowChoice | None:
    """Double the window until it qualifies, then bisect down to the shortest that does.

    With ``warm``, each bisection fit may start from the estimate of the shortest good window so
    far (not a doubling fit from a shorter window's: that can end in another minimum); None
    when the chosen window's fit without a guess does not qualify.
    """
    n = len(windows)

    def good(k: int, near: int | None = None) -> bool:
        w = windows(k, near if warm else None)
        return w.relative_position_std < windows.max_relative_std

    k = min(max(int(min_window), 1), n)
    bad = k - 1
    while not good(k):
        if k == n:
            raise windows.no_start(windows.max_relative_std)
        bad = k
        k = min(2 * k, n)
    while k - bad > 1:
        mid = (k + bad) // 2
        if good(mid, k):
            k = mid
        else:
            bad = mid
    return windows.choice(k)


@dataclass(frozen=True)
class Initiation:
    """A started track.

    Parameters
    ----------
    start : StartRecord
        How it started.
    track : Track
        The filter's track from the start on (after a batch or bearing start, its first row is
        the start).
    """

    start: StartRecord
    track: Track


class Initiator(ABC):
    """The policy that starts a filter on a measurement set."""

    @abstractmethod
    def initiate(self, meas: MeasurementSet, setup: FilterSetup) -> Initiation:
        """Start the filter of ``setup`` on ``meas`` and run it.

        Parameters
        ----------
        meas : MeasurementSet
            The measurements (not empty).
        setup : FilterSetup
            The filter and its settings.

        Returns
        -------
        Initiation
            The start record and the track (s, m, m/s).
        """


class PriorInitiator(Initiator):
    """Start from a Gaussian prior with independent components.

    Parameters
    ----------
    mean : mapping of str to float, or array_like
        Prior mean by state name (``x, y, (z), vx, vy, (vz)``; m, m/s) or in state order.
    std : mapping of str to float, or array_like
        Its standard deviations, likewise (> 0).
    time : float, optional
        Prior time (s); default the first measurement time.
    nuisance : mapping of str to float, optional
        Known nuisance values (Hz, dBW, ...): required for the kinds that have them.
    """

    def __init__(self, mean: Mapping[str, float] | ArrayLike,
                 std: Mapping[str, float] | ArrayLike, time: float | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self.mean = mean
        self.std = std
        self.time = None if time is None else float(time)
        self.nuisance = dict(nuisance or {})

    def initiate(self, meas: MeasurementSet, setup: FilterSetup) -> Initiation:
        """Start at the prior and update with every row (see :meth:`Initiator.initiate`).

        Raises
        ------
        TrackingError
            A prior component missing, unknown, not finite or beyond the rules' reach (1e9 m,
            light's speed), a std <= 0 or beyond that reach, or a prior time after the first
            measurement or more than 100 spans of the data before it.
        MissingNuisanceError
            Nuisance values the measurement kinds need are not given.
        """
        names = setup.state_names
        mean = state_vector(self.mean, names, "prior")
        std = state_vector(self.std, names, "prior_std")
        reach = np.where(np.arange(len(names)) < setup.dim, REACH_M, SPEED_OF_LIGHT)
        if np.any(np.abs(mean) > reach):
            raise TrackingError(f"prior: expected positions within {REACH_M:g} m of the origin "
                                f"and speeds below light's, got {mean.tolist()}", "prior")
        if np.any(std <= 0) or np.any(std > reach):
            raise TrackingError(f"prior_std: standard deviations must be > 0 and at most "
                                f"{REACH_M:g} m ({SPEED_OF_LIGHT:.0f} m/s for a velocity), got "
                                f"{std.tolist()}", "prior_std")
        _check_nuisance(meas, setup.options, self.nuisance)
        first = float(np.min(meas.time))
        t0 = first if self.time is None else self.time
        if t0 > first:
            raise TrackingError(f"{{prior_time}} {t0:g}: after the first measurement (t = "
                                f"{first:g} s); a filter runs forward from its prior: give a "
                                "time at or before it, or leave out the rows before it",
                                "prior_time", ["prior_time"])
        if (far := time_problem(t0, meas.time, "{prior_time}")) is not None:
            raise TrackingError(far, "prior_time", ["prior_time"])
        cov = np.diag(std**2)
        filt = setup.from_prior(mean, cov, t0, self.nuisance)
        start = PriorStart(t0, mean, std, cov, dict(self.nuisance), names)
        return Initiation(start, filt.run(meas))


class BearingInitiator(Initiator):
    """Start at the first bearing from a prior in the user's terms, and update with every other row.

    With ``confirm`` the start is tested as a batch start is (NIS of the next ``MIN_WINDOW``
    updates); a rejected bearing (clutter) is dropped and the next one starts.

    Parameters
    ----------
    prior : BearingPrior, optional
        Range, speed (and height) intervals; default :class:`~tmakit.filters.BearingPrior`'s.
    nuisance : mapping of str to float, optional
        Known nuisance values, for the kinds that have nuisance parameters.
    confirm : bool
        Test the start by the innovations that follow it.
    confirm_p_value : float
        A start whose test has a smaller p-value is rejected.
    """

    def __init__(self, prior: BearingPrior | None = None,
                 nuisance: Mapping[str, float] | None = None, confirm: bool = True,
                 confirm_p_value: float = CONFIRM_P_VALUE) -> None:
        self.prior = BearingPrior() if prior is None else prior
        if not isinstance(self.prior, BearingPrior):
            raise TrackingError(f"prior: expected a BearingPrior, got "
                                f"{type(self.prior).__name__}", "bearing_prior")
        self.nuisance = dict(nuisance or {})
        self.confirm, self.confirm_p_value = bool(confirm), float(confirm_p_value)

    def initiate(self, meas: MeasurementSet, setup: FilterSetup) -> Initiation:
        """Start at the first bearing and update with every other row.

        Raises
        ------
        StartError
            The set has no bearing, or every bearing's start was rejected.
        MissingNuisanceError
            Nuisance values the measurement kinds need are not given.
        """
        _check_nuisance(meas, setup.options, self.nuisance)
        rejected: list[Rejection] = []
        given = meas
        while True:
            try:
                first = first_bearing(meas)
            except ValueError as e:
                raise StartError(str(e) if not rejected else "every bearing's start was "
                                 "rejected by the innovations that followed it: " + "; ".join(
                                     r.describe() for r in rejected[:3])
                                 + f"; does the prior ({self.prior.describe()}) hold this "
                                 "emitter?", "bearing_prior") from None
            filt = setup.from_first_bearing(self.prior, first, self.nuisance)
            mean, cov = filt.state, filt.covariance
            rest = meas.take(np.flatnonzero((np.arange(len(meas)) != first.row)
                                            & (meas.time >= first.time)))  # runs forward
            if self.confirm:  # the verdict from the test's window only: linear in the bearings
                check = _confirmation(_window_run(filt, rest, MIN_WINDOW), MIN_WINDOW)
                if check.p_value < self.confirm_p_value:
                    rejected.append(Rejection(1, first.time, check))
                    meas = rest
                    continue
            after = filt.run(rest)
            check = _confirmation(after, MIN_WINDOW)
            break
        unused = int(np.count_nonzero((given.time < first.time) & ~given.kind_mask("bearing")))
        start = BearingStart(first.time, mean, cov, dict(self.nuisance), setup.state_names,
                             self.prior, first, check, tuple(rejected), unused)
        return Initiation(start, _prepend(after, first.time, mean, cov, setup.state_names))


def _check_nuisance(meas: MeasurementSet, options: Mapping[str, Mapping[str, object]],
                    nuisance: Mapping[str, float]) -> None:
    """Refuse a prior start without the nuisance values of the kinds present."""
    missing: dict[str, list[str]] = {}
    for kind in meas.kinds:
        model = model_for(kind, options.get(kind))
        tonals = ([] if meas.tonal is None or not model.nuisance_by_tonal
                  else sorted(set(meas.tonal[meas.kind_mask(kind)].tolist())))
        names = [n for n in (model.nuisance_names if len(tonals) < 2 else [
            f"{n}[{t}]" for t in tonals for n in model.nuisance_names]) if n not in nuisance]
        if names:
            missing[kind] = names
    if missing:
        raise MissingNuisanceError(missing)


class BatchInitiator(Initiator):
    """Start from a batch estimate over an initial window, confirmed by the innovations.

    Parameters
    ----------
    init_window : int, optional
        Use the first ``init_window`` distinct measurement times (no innovation test). Default:
        search the shortest window that meets ``max_relative_std``.
    max_relative_std : float
        Start quality: the position's largest 1-sigma semi-axis over the range (> 0).
    confirm : bool
        Test each start by its window's fit and by the innovations that follow it; replace a
        rejected one by a start from a window at least twice as long.
    min_window : int
        The first window the search tries (distinct measurement times).
    confirm_p_value : float
        A start whose test has a smaller p-value is rejected.
    likelihood_quality : bool
        Judge ``max_relative_std`` by the covariance widened to the window's profile
        likelihood (:func:`likelihood_covariance`), not only by the linearised one: a window
        that meets it only by its linearised covariance is rejected and a window
        ``LIKELIHOOD_GROWTH`` times as long tried (kept when no longer window meets the quality
        at all). The
        multiple-model filters ask for it (their ``start_by_likelihood``): to their turn
        models, a start's range error is a turn, not an error to correct.

    Raises
    ------
    TrackingError
        ``max_relative_std`` <= 0 (without ``init_window``), ``confirm_p_value`` outside 0 .. 1.
    """

    def __init__(self, init_window: int | None = None,
                 max_relative_std: float = DEFAULT_MAX_RELATIVE_STD, confirm: bool = True,
                 min_window: int = MIN_WINDOW, confirm_p_value: float = CONFIRM_P_VALUE,
                 likelihood_quality: bool = False) -> None:
        if init_window is None and not max_relative_std > 0:
            raise TrackingError(f"max_relative_std must be > 0, got {max_relative_std}",
                                "max_relative_std")
        if not 0.0 <= confirm_p_value <= 1.0:
            raise TrackingError(f"confirm_p_value must be a probability from 0 to 1, got "
                                f"{confirm_p_value}", "confirm_p_value")
        self.init_window = init_window
        self.max_relative_std = float(max_relative_std)
        self.confirm = bool(confirm) and init_window is None
        self.min_window = int(min_window)
        self.confirm_p_value = float(confirm_p_value)
        self.likelihood_quality = bool(likelihood_quality) and init_window is None

    def initiate(self, meas: MeasurementSet, setup: FilterSetup) -> Initiation:
        """Search the window, start, test, and run (see :meth:`Initiator.initiate`).

        Raises
        ------
        StartError
            No window gives a start (the message lists the rejected starts).
        """
        rejected: list[Rejection] = []
        first = self.min_window
        too_wide: tuple[WindowChoice, Array, tuple[Widening, ...]] | None = None
        while True:
            try:
                found = search_window(meas, setup.dim, setup.options or None,
                                      self.init_window, self.max_relative_std,
                                      min_window=first, fit_p_value=self.confirm_p_value
                                      if self.confirm else 0.0)
            except StartError as e:
                if too_wide is not None:  # no longer window will do: the wide start it is
                    found, wide, widened = too_wide
                    rejected = [r for r in rejected if r.window != found.chosen.window]
                    too_wide = None
                elif not rejected:
                    raise
                else:
                    raise e.extended("; earlier starts were rejected by the innovations that "
                                     "followed them" + ("" if all(r.confirmation for r in rejected)
                                                        else " or by their profile likelihood")
                                     + ": " + "; ".join(r.describe() for r in rejected)
                                     ) from None
            else:
                w = found.chosen
                assert w.estimate is not None
                rows = meas.take(meas.time <= w.time + 1e-9)
                wide, widened = likelihood_covariance(w.estimate, rows, w.time, setup.dim,
                                                      setup.options or None)
                honest = _relative_std(replace(w.estimate, covariance=wide), rows, w.time,
                                       setup.dim) if widened and self.likelihood_quality else None
                if honest is not None and honest > self.max_relative_std:
                    # the window met the quality only by its overconfident linearised covariance
                    rejected.append(Rejection(w.window, w.time, None, honest))
                    too_wide = (found, wide, widened)
                    first = max(w.window + 1, math.ceil(LIKELIHOOD_GROWTH * w.window))
                    continue
            w = found.chosen
            assert w.estimate is not None
            rows = meas.take(meas.time <= w.time + 1e-9)
            filt = setup.from_estimate(replace(w.estimate, covariance=wide,
                                               std=np.sqrt(np.diag(wide))), w.time)
            mean, cov, nuisance = filt.state, filt.covariance, dict(filt.nuisance)
            rest = meas.take(meas.time > w.time + 1e-9)
            after = filt.run(meas, after=w.time)  # (meas prepared once for every start)
            check = _confirmation(after, w.window)
            # (the whole data as window leaves no updates to test: p = 1, accepted)
            if not self.confirm or check.p_value >= self.confirm_p_value:
                break
            rejected.append(Rejection(w.window, w.time, check))
            first = 2 * w.window
        start = BatchStart(w.time, mean, cov, nuisance, setup.state_names, w.estimate,
                           w.window, w.rows, float(w.relative_position_std),
                           None if self.init_window is not None else self.max_relative_std,
                           found.windows_tried, check, tuple(rejected),
                           _held_nuisance(w.estimate, rest, setup.options), widened)
        return Initiation(start, _prepend(after, w.time, mean, cov, setup.state_names))


def _held_nuisance(result: EstimateResult, rows: MeasurementSet,
                   options: Mapping[str, Mapping[str, object]]) -> dict[str, float]:
    """Give per estimated nuisance the chi-square a one-sigma error in it adds over ``rows``."""
    if not result.nuisance or len(rows) == 0:
        return {}
    obs = ObservationModel(rows, result.motion, options or None)
    values = {n: v for n, (v, _) in result.nuisance.items()}
    _, j_nu = obs.jacobian(result.estimate, obs.nuisance_vector(values))
    return {n: float(np.sum((j_nu[:, j] * result.nuisance[n][1] / rows.sigma_si) ** 2))
            for j, n in enumerate(obs.nuisance_names)
            if n in result.nuisance and np.isfinite(result.nuisance[n][1])}


def _window_run(filt: TrackingFilter, rows: MeasurementSet, window: int) -> Track:
    """Run a copy of ``filt`` (its random generator too) over the first ``window`` updates."""
    order, bounds = time_blocks(rows.time)
    return copy.deepcopy(filt).run(rows.take(np.sort(order[:bounds[min(window,
                                                                          len(bounds) - 1)]])))


def _confirmation(after: Track, window: int) -> Confirmation:
    """Test the NIS of the first ``max(window, MIN_WINDOW)`` updates after a start."""
    m = min(len(after), max(window, MIN_WINDOW))
    nis = float(np.sum(after.nis[:m]))
    dof = int(np.sum(after.dof[:m]))
    p = float(chi2.sf(nis, dof)) if dof > 0 and np.isfinite(nis) else (1.0 if dof == 0
                                                                          else 0.0)
    return Confirmation(m, nis, dof, p)


def _prepend(tr: Track, time: float, state: Array, cov: Array, names: tuple[str, ...]
             ) -> Track:
    """Give the track with a first row for the start (NIS NaN, 0 degrees of freedom)."""
    extra = replace(tr.extra)
    if extra.model_probabilities is not None and extra.models is not None:
        extra.model_probabilities = [[m["prior"] for m in extra.models],
                                     *extra.model_probabilities]
    return Track(tr.filter_name or "", names,
                 np.concatenate([[time], tr.times]),
                 np.concatenate([state[None], tr.states]),
                 np.concatenate([cov[None], tr.covariances]),
                 np.concatenate([[np.nan], tr.nis]),
                 np.concatenate([np.zeros(1, dtype=np.int64), tr.dof]),
                 np.concatenate([[0.0], tr.log_likelihood]), extra)
