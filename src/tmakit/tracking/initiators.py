"""How a track starts: initiators, objects with their settings in ``__init__``.

:meth:`Initiator.initiate` starts a :class:`~.filter_setup.FilterSetup`'s filter and returns an
:class:`Initiation` (the typed start record and the track).  :class:`PriorInitiator` starts from a
given Gaussian; :class:`BatchInitiator` (the default) from a batch estimate over the shortest
good window (:func:`.window.search_window`), replaced by one from a window at least twice as long
when the next updates' summed NIS is improbable (p below ``confirm_p_value``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..data import MeasurementSet
from ..filters import BearingPrior, Track, first_bearing
from ..measurements import model_for
from .errors import MissingNuisanceError, StartError, TrackingError
from .filter_setup import FilterSetup, state_vector
from .records import BatchStart, BearingStart, Confirmation, PriorStart, Rejection, StartRecord
from .window import MIN_WINDOW, search_window

__all__ = ["CONFIRM_P_VALUE", "DEFAULT_MAX_RELATIVE_STD", "BatchInitiator", "BearingInitiator",
           "Initiation", "Initiator", "PriorInitiator"]


#: Default start quality: the position's largest 1-sigma semi-axis over the range.
DEFAULT_MAX_RELATIVE_STD = 0.25
#: A batch start is rejected (and a longer window tried) when the innovations of the updates
#: that follow it are this improbable (chi-square test of their summed NIS).
CONFIRM_P_VALUE = 1e-3


@dataclass(frozen=True)
class Initiation:
    """A started track.

    Parameters
    ----------
    start : PriorStart or BatchStart
        How it started.
    track : Track
        The filter's track from the start on (after a batch start, its first row is the start).
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
        Known nuisance values (carrier Hz, power constant dBW, ...): required for the kinds
        that have nuisance parameters.

    Raises
    ------
    TrackingError
        From :meth:`initiate`: components missing, unknown or not finite (parameters
        ``prior``, ``prior_std``), a standard deviation <= 0.
    MissingNuisanceError
        From :meth:`initiate`: nuisance values the measurement kinds need are not given.
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
            A prior component missing, unknown or not finite, or a std <= 0.
        MissingNuisanceError
            Nuisance values the measurement kinds need are not given.
        """
        names = setup.state_names
        mean = state_vector(self.mean, names, "prior")
        std = state_vector(self.std, names, "prior_std")
        if np.any(std <= 0):
            raise TrackingError(f"prior_std: standard deviations must be > 0, got "
                                f"{std.tolist()}", "prior_std")
        _check_nuisance(meas, setup.options, self.nuisance)
        t0 = float(np.min(meas.time)) if self.time is None else self.time
        cov = np.diag(std**2)
        filt = setup.from_prior(mean, cov, t0, self.nuisance)
        start = PriorStart(t0, mean, std, cov, dict(self.nuisance), names)
        return Initiation(start, filt.run(meas))


class BearingInitiator(Initiator):
    """Start at the first bearing from a prior in the user's terms.

    The filter starts at the first bearing's time from ``prior`` centred on that bearing
    (:meth:`TrackingFilter.from_first_bearing <tmakit.filters.TrackingFilter.from_first_bearing>`)
    and updates with every other row; the track's first row is that start (NIS NaN).
    With ``confirm`` the start is tested as a batch start is (NIS of the next ``MIN_WINDOW``
    updates); a rejected bearing (clutter) is dropped and the next one starts.

    Parameters
    ----------
    prior : BearingPrior, optional
        Range, speed (and height) intervals; default :class:`~tmakit.filters.BearingPrior`'s
        defaults (said so in the start record).
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

        Parameters
        ----------
        meas : MeasurementSet
            The measurements (with at least one bearing; SI).
        setup : FilterSetup
            The filter and its settings.

        Returns
        -------
        Initiation
            The start record and the track (s, m, m/s).

        Raises
        ------
        StartError
            The set has no bearing, or every bearing's start was rejected.
        MissingNuisanceError
            Nuisance values the measurement kinds need are not given.
        """
        _check_nuisance(meas, setup.options, self.nuisance)
        rejected: list[Rejection] = []
        while True:
            try:
                first = first_bearing(meas)
            except ValueError as e:
                raise StartError(str(e) if not rejected else "every bearing's start was "
                                 "rejected by the innovations that followed it: " + "; ".join(
                                     r.describe() for r in rejected[:3]), "bearing_prior"
                                 ) from None
            filt = setup.from_first_bearing(self.prior, first, self.nuisance)
            mean, cov = filt.state, filt.covariance
            rest = np.flatnonzero(np.arange(len(meas)) != first.row)
            after = filt.run(meas.take(rest))
            check = _confirmation(after, MIN_WINDOW)
            if not self.confirm or check.p_value >= self.confirm_p_value:
                break
            rejected.append(Rejection(1, first.time, check))
            meas = meas.take(rest)
        start = BearingStart(first.time, mean, cov, dict(self.nuisance), setup.state_names,
                             self.prior, first, check, tuple(rejected))
        return Initiation(start, _prepend(after, first.time, mean, cov, setup.state_names))


def _check_nuisance(meas: MeasurementSet, options: Mapping[str, Mapping[str, object]],
                    nuisance: Mapping[str, float]) -> None:
    """With a prior, the nuisance parameters of the kinds present must be given."""
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
        Use the first ``init_window`` distinct measurement times (the estimate must converge and be
        observable; no innovation test). Default: search the shortest window that meets
        ``max_relative_std``.
    max_relative_std : float
        Start quality: the position's largest 1-sigma semi-axis must be below this fraction of the
        range to the nearest sensor (> 0).
    confirm : bool
        Test each start by its window's fit (chi-square p-value) and by the innovations of the
        updates that follow it; replace a rejected one by a start from a window at least twice as
        long.
    min_window : int
        The first window the search tries (distinct measurement times).
    confirm_p_value : float
        A start whose test has a smaller p-value is rejected.

    Raises
    ------
    TrackingError
        ``max_relative_std`` <= 0 (without ``init_window``), ``confirm_p_value`` outside 0 .. 1.
    """

    def __init__(self, init_window: int | None = None,
                 max_relative_std: float = DEFAULT_MAX_RELATIVE_STD, confirm: bool = True,
                 min_window: int = MIN_WINDOW, confirm_p_value: float = CONFIRM_P_VALUE
                 ) -> None:
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

    def initiate(self, meas: MeasurementSet, setup: FilterSetup) -> Initiation:
        """Search the window, start, test, and run (see :meth:`Initiator.initiate`).

        Raises
        ------
        StartError
            No window gives a start (the message lists the rejected starts).
        """
        rejected: list[Rejection] = []
        first = self.min_window
        while True:
            try:
                found = search_window(meas, setup.dim, setup.options or None,
                                      self.init_window, self.max_relative_std,
                                      min_window=first, fit_p_value=self.confirm_p_value
                                      if self.confirm else 0.0)
            except StartError as e:
                if not rejected:
                    raise
                raise e.extended("; earlier starts were rejected by the innovations that "
                                 "followed them: " + "; ".join(r.describe() for r in rejected)
                                 ) from None
            w = found.chosen
            assert w.estimate is not None
            filt = setup.from_estimate(w.estimate, w.time)
            mean, cov, nuisance = filt.state, filt.covariance, dict(filt.nuisance)
            after = filt.run(meas.take(meas.time > w.time + 1e-9))
            check = _confirmation(after, w.window)
            # (the whole data as window leaves no updates to test: p = 1, accepted)
            if not self.confirm or check.p_value >= self.confirm_p_value:
                break
            rejected.append(Rejection(w.window, w.time, check))
            first = 2 * w.window
        start = BatchStart(w.time, mean, cov, nuisance, setup.state_names, w.estimate,
                           w.window, w.rows, float(w.relative_position_std),
                           None if self.init_window is not None else self.max_relative_std,
                           found.windows_tried, check, tuple(rejected))
        return Initiation(start, _prepend(after, w.time, mean, cov, setup.state_names))


def _confirmation(after: Track, window: int) -> Confirmation:
    """Run the innovation test of a start."""
    from ..core import chi2

    m = min(len(after), max(window, MIN_WINDOW))
    nis = float(np.sum(after.nis[:m]))
    dof = int(np.sum(after.dof[:m]))
    p = float(chi2.sf(nis, dof)) if dof > 0 and np.isfinite(nis) else (1.0 if dof == 0
                                                                          else 0.0)
    return Confirmation(m, nis, dof, p)


def _prepend(tr: Track, time: float, state: Array, cov: Array, names: tuple[str, ...]
             ) -> Track:
    """Return the track with a first row for the start (NIS NaN, 0 degrees of freedom)."""
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
