"""Tracking a measurement set with a recursive filter, in one call: :func:`track`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from ..core.keywords import NOT_GIVEN, NotGiven, renamed_keyword
from ..data import MeasurementSet
from ..filters import BearingPrior, GaussianSumFilter, ModifiedPolarEKF, Track
from ..measurements import options_with_metadata
from .errors import TrackingError
from .filter_setup import FilterSetup, filter_class, filter_dim
from .initiators import (
    DEFAULT_MAX_RELATIVE_STD,
    BatchInitiator,
    BatchStart,
    BearingInitiator,
    BearingStart,
    Initiator,
    PriorInitiator,
    PriorStart,
    StartRecord,
)

__all__ = ["start_record", "track"]

def _initiator(initiator: Initiator | None,
               prior: Mapping[str, float] | ArrayLike | None,
               prior_std: Mapping[str, float] | ArrayLike | None, prior_time: float | None,
               nuisance: Mapping[str, float] | None, init_window: int | None,
               max_relative_std: float | None, confirm: bool,
               bearing_prior: BearingPrior | None,
               tracker: str) -> Initiator:
    """Give the initiator given, or the one the start keywords of :func:`track` describe."""
    if initiator is not None or bearing_prior is not None:
        if any(v is not None for v in (prior, prior_std, prior_time, init_window)) \
                or (nuisance and initiator is not None) \
                or max_relative_std is not None or not confirm \
                or (initiator is not None and bearing_prior is not None):
            raise TrackingError("initiator: give the start as an initiator, as a "
                                "bearing_prior or by the start keywords (prior, prior_std, "
                                "prior_time, nuisance, init_window, max_relative_std, "
                                "confirm): one of them, not both", "initiator")
        return initiator if initiator is not None else BearingInitiator(bearing_prior,
                                                                        nuisance)
    if tracker in (GaussianSumFilter.name, ModifiedPolarEKF.name) and prior is None \
            and prior_std is None and init_window is None:
        return BearingInitiator(None, nuisance)
    if prior is not None or prior_std is not None:
        if prior is None or prior_std is None:
            raise TrackingError("a prior needs both its mean (prior) and its standard "
                                "deviations (prior_std)", "prior_std" if prior_std is None
                                else "prior")
        return PriorInitiator(prior, prior_std, prior_time, nuisance)
    if nuisance:
        raise TrackingError("nuisance values are taken from the batch estimate; give them "
                            "only with a prior", "nuisance")
    if max_relative_std is None:  # a multiple-model filter asks for a better start
        max_relative_std = getattr(filter_class(tracker), "start_relative_std",
                                   DEFAULT_MAX_RELATIVE_STD)
    return BatchInitiator(init_window, max_relative_std, confirm, likelihood_quality=getattr(
        filter_class(tracker), "start_by_likelihood", False))


def track(meas: MeasurementSet, tracker: str = "ekf", q: float | ArrayLike = 0.0,
          particles: int | None = None,
          prior: Mapping[str, float] | ArrayLike | None = None,
          prior_std: Mapping[str, float] | ArrayLike | None = None,
          prior_time: float | None = None, init_window: int | None = None,
          max_relative_std: float | None = None, confirm: bool = True,
          rng: np.random.Generator | int | None = None, dim: int | None = None,
          options: Mapping[str, Mapping[str, object]] | None = None,
          nuisance: Mapping[str, float] | None = None, *,
          initiator: Initiator | None = None,
          q_density: float | ArrayLike = 0.0,
          bearing_prior: BearingPrior | None = None,
          settings: Mapping[str, object] | None = None,
          filter: str | NotGiven = NOT_GIVEN) -> Track:
    """Track the emitter through ``meas`` with a recursive filter.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    tracker : str
        A name of :data:`tmakit.filters.FILTERS` (``ekf``, ``ukf``, ``ckf``, ``gsf``, ...).
    q, q_density : float or array_like
        Acceleration std (m/s^2) and white-noise acceleration density (m^2/s^3), one or per axis.
    particles : int, optional
        Particle count, for particle filters only.
    prior, prior_std : mapping or array_like, optional
        Short form of ``initiator=PriorInitiator(prior, prior_std, prior_time, nuisance)`` (m, m/s).
    prior_time : float, optional
        The prior's time (s; default the first measurement time).
    init_window, max_relative_std, confirm
        As ``BatchInitiator``'s; std 0.25 (imm, mmpf: 0.1, judged by the profile likelihood).
    rng : numpy.random.Generator or int, optional
        Generator or seed, for the filters that draw random numbers.
    dim : int, optional
        2 or 3 (default :func:`~.filter_setup.filter_dim`).
    options : mapping, optional
        Per-kind measurement-model options, as for :func:`tmakit.batch.estimate`.
    nuisance : mapping of str to float, optional
        Known nuisance values (Hz, dBW, ...), with a prior only.
    initiator : Initiator, optional
        The start policy (then none of the start keywords above).
    bearing_prior : BearingPrior, optional
        Short form of ``initiator=BearingInitiator(bearing_prior, nuisance)`` (``gsf``'s default).
    settings : mapping, optional
        Further filter settings (``{"component": "ckf"}`` for ``gsf``, ...).
    filter : str, optional
        Deprecated (it shadows a builtin): ``tracker``.

    Returns
    -------
    Track
        One row per update (SI); ``extra`` says how it started and with which settings. Its
        first row is the start (NIS NaN) after a batch or first-bearing start.

    Raises
    ------
    TypeError
        ``meas`` is not a MeasurementSet.
    TrackingError
        A refused argument or data that cannot start the filter; the error names the library
        parameter (:attr:`TrackingError.parameter`).
    """
    if not isinstance(meas, MeasurementSet):
        raise TypeError(f"meas must be a MeasurementSet, got {type(meas).__name__}")
    tracker = renamed_keyword("track", "filter", filter, "tracker", tracker, "ekf")
    filter_class(tracker)
    setup = FilterSetup.create(tracker, filter_dim(meas, dim), q, particles, rng,
                               options_with_metadata(meas.kinds, options, meas.metadata),
                               q_density, settings)
    if len(meas) == 0:
        raise TrackingError("the measurement set is empty: nothing to track")
    started = _initiator(initiator, prior, prior_std, prior_time, nuisance, init_window,
                         max_relative_std, confirm, bearing_prior, tracker).initiate(meas, setup)
    result = started.track
    result.extra = replace(result.extra, start=started.start.as_dict(),
                           start_record=started.start, q=list(setup.q),
                           q_density=list(setup.q_density), dim=setup.dim,
                           options=dict(setup.options))
    return result


def start_record(tr: Track) -> StartRecord | None:
    """How a track from :func:`track` started (``None`` for a track made otherwise).

    Parameters
    ----------
    tr : Track

    Returns
    -------
    PriorStart or BatchStart or BearingStart or None
    """
    record = tr.extra.start_record
    return record if isinstance(record, PriorStart | BatchStart | BearingStart) else None
