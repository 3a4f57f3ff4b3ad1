"""tmakit's no-guess batch estimate as a Stone Soup initiator (see :mod:`.stonesoup`)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable, Mapping

import numpy as np
from stonesoup.base import Property
from stonesoup.initiator.base import GaussianInitiator
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track

from ..results.estimate import EstimateResult
from ..tracking.errors import StartError
from ..tracking.initiators import DEFAULT_MAX_RELATIVE_STD
from ..tracking.window import MIN_WINDOW, search_window
from .stonesoup_detections import from_detections
from .stonesoup_models import EPOCH, cartesian_mapping

__all__ = ["BatchInitiator"]


class BatchInitiator(GaussianInitiator):
    """Start a Stone Soup track from tmakit's batch estimate, with no initial guess.

    Detections accumulate over calls; once they span ``min_window`` distinct times the
    constant-velocity estimate over all of them is tried, and starts a track by the start rule of
    :func:`tmakit.tracking.window.search_window` (else it is retried when the times have grown by
    ``growth``).  The track's first state is a ``GaussianState`` at the latest detection time.  One
    target: every detection is taken to be of it (use it after association).

    Parameters
    ----------
    *args, **kwargs
        Stone Soup properties, by position or name: ``dim``, ``max_relative_std``, ``min_window``,
        ``growth``, ``options`` and ``epoch`` (documented with each below).
    """

    dim: int = Property(default=2, doc="Spatial dimension of the target, 2 or 3.")
    max_relative_std: float = Property(
        default=DEFAULT_MAX_RELATIVE_STD,
        doc="Start quality: largest position std (1 sigma) over range to the nearest sensor.")
    min_window: int = Property(default=MIN_WINDOW,
                               doc="Distinct measurement times before the first try.")
    growth: float = Property(default=1.25, doc="Factor by which the times grow between tries.")
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
            choice = search_window(meas, self.dim, self.options, init_window=times.size)
        except StartError:
            choice = None
        if choice is None or not choice.chosen.relative_position_std < self.max_relative_std:
            self._next_try = max(times.size + 1, int(np.ceil(self.growth * times.size)))
            return set()
        result = choice.chosen.estimate
        assert result is not None  # a chosen window always has its estimate
        self.estimate = result
        pos, vel = cartesian_mapping(self.dim)
        order = list(pos) + list(vel)
        mean = np.zeros(2 * self.dim)
        cov = np.zeros((2 * self.dim, 2 * self.dim))
        mean[order] = result.estimate
        cov[np.ix_(order, order)] = result.covariance
        when = self.epoch + dt.timedelta(seconds=float(times[-1]))
        self.detections, self._next_try = [], int(self.min_window)
        return {Track([GaussianState(mean, cov, timestamp=when)])}
