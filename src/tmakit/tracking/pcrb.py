"""The posterior Cramér–Rao bound of a track: what any tracker started as it was could do."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..bounds.pcrb import deterministic_pcrb, posterior_crb
from ..data import MeasurementSet
from ..filters import Track
from .initiators import BatchStart, BearingStart
from .tracker import start_record

__all__ = ["track_pcrb"]


def track_pcrb(meas: MeasurementSet, tr: Track, truth: ArrayLike | None = None, *,
               trajectories: int = 200, rng: np.random.Generator | int | None = 0
               ) -> tuple[Any | None, str]:
    """Compute the posterior CRB of a tracker that starts where ``tr`` started.

    The same prior covariance, q, options and nuisance values as the track, over the same updates;
    the information along ``truth`` if given, else averaged over ``trajectories`` drawn from the
    start prior (docs/tracking.md).

    Parameters
    ----------
    meas : MeasurementSet
        The measurements the track was made from.
    tr : Track
        A track from :func:`tmakit.track`.
    truth : array_like, shape (K, n), optional
        True states at the track's times (m, m/s), as from :func:`tmakit.scenario.truth_states`.
    trajectories : int
        Trajectories of the Monte Carlo average (without ``truth``).
    rng : numpy.random.Generator or int, optional
        Generator or seed of that average.

    Returns
    -------
    tuple
        ``(bound, note)``: the :class:`~tmakit.bounds.pcrb.PosteriorBound`, or ``None`` and a note
        that says why it cannot be computed.

    References
    ----------
    Hurtado & Nehorai (2008), eqs. 10-11; Tichavský, Muravchik & Nehorai (1998).
    """
    start = start_record(tr)
    if start is None:
        return None, "PCRB not available (the track does not say how it started)"
    t0, cov, nuisance = start.time, start.covariance, start.nuisance
    if isinstance(start, BatchStart):
        rows = meas.take(meas.time > t0 + 1e-9)
    elif isinstance(start, BearingStart):  # the prior holds the first bearing already
        keep = np.ones(len(meas), dtype=bool)
        keep[start.first.row] = False
        rows = meas.take(np.flatnonzero(keep))
    else:
        rows = meas
    if len(rows) == 0:
        return None, "PCRB not available (no measurements after the start)"
    q = tr.extra.q if tr.extra.q is not None else 0.0
    density = tr.extra.q_density if tr.extra.q_density else 0.0
    options = tr.extra.options or None
    try:
        if truth is not None:
            truth = np.asarray(truth, dtype=float)
            at_start = truth[int(np.argmin(np.abs(tr.times - t0)))]
            bound = deterministic_pcrb(rows, at_start, cov, t0, q=q, options=options,
                                       nuisance=nuisance, q_density=density)
        else:
            bound = posterior_crb(rows, start.mean, cov, t0, q=q, trajectories=trajectories,
                                  rng=rng, options=options, nuisance=nuisance,
                                  q_density=density)
    except (ValueError, TypeError) as e:
        return None, f"PCRB not available ({e})"
    return bound, ""
