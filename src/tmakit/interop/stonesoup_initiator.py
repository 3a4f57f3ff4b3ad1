"""tmakit's starts as Stone Soup initiators: the batch estimate, the first bearing."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable, Mapping

import numpy as np
from stonesoup.base import Property
from stonesoup.initiator.base import GaussianInitiator
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track

from ..filters import BearingPrior
from ..filters.track import Track as TmakitTrack
from ..results.estimate import EstimateResult
from ..tracking import MIN_WINDOW, search_window
from ..tracking import BearingInitiator as _FirstBearingStart
from ..tracking import track as tmakit_track
from ..tracking.errors import StartError, TrackingError
from ..tracking.initiators import CONFIRM_P_VALUE, DEFAULT_MAX_RELATIVE_STD
from .stonesoup_detections import from_detections
from .stonesoup_models import EPOCH, cartesian_mapping

__all__ = ["BatchInitiator", "BearingInitiator"]


class BatchInitiator(GaussianInitiator):
    """Start a Stone Soup track from tmakit's batch estimate, with no initial guess.

    Detections accumulate over calls; once they span ``min_window`` distinct times the
    constant-velocity estimate over all of them is tried, and starts a track by the start rule of
    :func:`tmakit.tracking.window.search_window`, its fit's chi-square p-value at least
    ``confirm_p_value`` (else it is retried when the times have grown by ``growth``, and
    :attr:`problem` says why).  The track's first state is a ``GaussianState`` at the latest
    detection time.  One target: every detection is taken to be of it (use it after association).

    Parameters
    ----------
    *args, **kwargs
        Stone Soup properties, by position or name: ``dim``, ``max_relative_std``, ``min_window``,
        ``growth``, ``confirm_p_value``, ``options`` and ``epoch`` (documented with each below).
    """

    dim: int = Property(default=2, doc="Spatial dimension of the target, 2 or 3.")
    max_relative_std: float = Property(
        default=DEFAULT_MAX_RELATIVE_STD,
        doc="Start quality: largest position std (1 sigma) over range to the nearest sensor.")
    min_window: int = Property(default=MIN_WINDOW,
                               doc="Distinct measurement times before the first try.")
    growth: float = Property(default=1.25, doc="Factor by which the times grow between tries.")
    confirm_p_value: float = Property(
        default=CONFIRM_P_VALUE, doc="A fit whose chi-square p-value is below it is no start.")
    options: Mapping[str, Mapping[str, object]] | None = Property(
        default=None, doc="Per-kind model options, as for tmakit.batch.estimate.")
    epoch: dt.datetime = Property(default=EPOCH, doc="The timestamp of time 0 s.")

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        if self.dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {self.dim}")
        if not self.max_relative_std > 0 or not self.growth > 1 or self.min_window < 1:
            raise ValueError("max_relative_std must be > 0, growth > 1 and min_window >= 1; "
                             f"got {self.max_relative_std}, {self.growth}, {self.min_window}")
        self.detections: list[Detection] = []
        self.estimate: EstimateResult | None = None
        self.tries = 0
        self.problem = ""
        self._next_try = int(self.min_window)

    def initiate(self, detections: Iterable[Detection], timestamp: dt.datetime,
                 **kwargs: object) -> set[Track]:
        """Collect detections; return one track once the batch estimate is a good start."""
        self.detections.extend(detections)
        if len({d.timestamp for d in self.detections}) < self._next_try:
            return set()
        meas = from_detections(self.detections, epoch=self.epoch)
        times = np.unique(meas.time)
        self.tries += 1
        try:
            choice = search_window(meas, self.dim, self.options, init_window=times.size,
                                   fit_p_value=self.confirm_p_value)
            rel = choice.chosen.relative_position_std
            self.problem = "" if rel < self.max_relative_std else (
                f"position std {rel:.0%} of the range (a start needs < "
                f"{self.max_relative_std:.0%})")
        except StartError as e:
            self.problem = str(e)
        if self.problem:
            self._next_try = max(times.size + 1, int(np.ceil(self.growth * times.size)))
            return set()
        result = choice.chosen.estimate
        assert result is not None  # a chosen window always has its estimate
        self.estimate = result
        when = self.epoch + dt.timedelta(seconds=float(times[-1]))
        self.detections, self._next_try = [], int(self.min_window)
        return {Track([_stonesoup_state(result.estimate, result.covariance, self.dim, when)])}


def _stonesoup_state(mean: np.ndarray, cov: np.ndarray, dim: int, when: dt.datetime
                     ) -> GaussianState:
    """Give a tmakit state and covariance as a Stone Soup ``GaussianState``."""
    pos, vel = cartesian_mapping(dim)
    order = list(pos) + list(vel)
    m = np.zeros(2 * dim)
    p = np.zeros((2 * dim, 2 * dim))
    m[order] = mean
    p[np.ix_(order, order)] = cov
    return GaussianState(m, p, timestamp=when)


class BearingInitiator(GaussianInitiator):
    """Start a Stone Soup track at its first bearing: tmakit's Gaussian sum from a prior.

    Each call runs tmakit's Gaussian sum over the detections so far from the first bearing
    (:class:`tmakit.tracking.BearingInitiator`: its innovations reject a clutter bearing) and
    starts a track once the position's largest 1-sigma semi-axis is below ``max_relative_std``
    of the range: one ``GaussianState`` per detection time from the first bearing on.
    :attr:`track` keeps tmakit's track, :attr:`problem` says why no track yet.  One target.

    Parameters
    ----------
    *args, **kwargs
        Stone Soup properties, by position or name: ``prior``, ``dim``, ``q_density``,
        ``max_relative_std``, ``confirm_p_value``, ``options`` and ``epoch``.

    Raises
    ------
    ValueError
        For a ``dim`` other than 2 or 3, a prior that is not a ``BearingPrior``, or a start
        rule that cannot be met.
    """

    prior: BearingPrior = Property(default=None, doc="Range and speed intervals (default: "
                                                     "BearingPrior's defaults).")
    dim: int = Property(default=2, doc="Spatial dimension of the target, 2 or 3.")
    q_density: float = Property(default=0.0, doc="The target's continuous white-noise "
                                                 "acceleration density per axis, m^2/s^3.")
    max_relative_std: float = Property(
        default=DEFAULT_MAX_RELATIVE_STD,
        doc="Start quality: largest position std (1 sigma) over range to the sensor.")
    confirm_p_value: float = Property(
        default=CONFIRM_P_VALUE, doc="A start whose innovations' p-value is below it fails.")
    options: Mapping[str, Mapping[str, object]] | None = Property(
        default=None, doc="Per-kind model options, as for tmakit.track.")
    epoch: dt.datetime = Property(default=EPOCH, doc="The timestamp of time 0 s.")

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        if self.prior is None:
            self.prior = BearingPrior()
        if self.dim not in (2, 3) or not isinstance(self.prior, BearingPrior):
            raise ValueError(f"dim must be 2 or 3 and prior a tmakit.BearingPrior; got "
                             f"{self.dim}, {type(self.prior).__name__}")
        if not self.max_relative_std > 0 or not 0 <= self.confirm_p_value <= 1:
            raise ValueError("max_relative_std must be > 0 and confirm_p_value in 0..1; got "
                             f"{self.max_relative_std}, {self.confirm_p_value}")
        self.detections: list[Detection] = []
        self.track: TmakitTrack | None = None
        self.problem = ""

    def initiate(self, detections: Iterable[Detection], timestamp: dt.datetime,
                 **kwargs: object) -> set[Track]:
        """Collect detections; return one track once the Gaussian sum is a good start."""
        self.detections.extend(detections)
        if not self.detections:
            return set()
        meas = from_detections(self.detections, epoch=self.epoch)
        try:
            tr = tmakit_track(meas, "gsf", q_density=self.q_density, dim=self.dim,
                              options=self.options, initiator=_FirstBearingStart(
                                  self.prior, confirm_p_value=self.confirm_p_value))
        except TrackingError as e:
            self.problem, self.detections = str(e), []
            return set()
        cov = tr.covariances[-1, :self.dim, :self.dim]
        last = np.abs(meas.time - meas.time.max()) < 1e-9
        rng = float(np.min(np.linalg.norm(tr.states[-1, :self.dim]
                                          - meas.sensor_state[last][:, :self.dim], axis=1)))
        rel = float(np.sqrt(max(np.max(np.linalg.eigvalsh(cov)), 0.0))) / max(rng, 1e-9)
        if not rel < self.max_relative_std:
            self.problem = (f"position std {rel:.0%} of the range (a start needs < "
                            f"{self.max_relative_std:.0%})")
            return set()
        self.track, self.detections, self.problem = tr, [], ""
        return {Track([_stonesoup_state(m, c, self.dim,
                                        self.epoch + dt.timedelta(seconds=float(t)))
                       for t, m, c in zip(tr.times, tr.states, tr.covariances, strict=True)])}
