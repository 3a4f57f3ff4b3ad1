"""What a track gives beside its rows: its JSON form, its file's table, its posterior CRB.

The table is written by :mod:`tmakit.io`; the bound is that of a tracker started as it was.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..filters import Track
from ..filters.gaussian_sum import SumStep
from .initiators import BatchStart, BearingStart
from .tracker import start_record

__all__ = ["TrackTable", "track_dict", "track_pcrb", "track_table"]


def _clean(v: object) -> object:
    """Give ``v`` with non-finite floats as ``None``, through lists and dicts."""
    if isinstance(v, float):
        return v if np.isfinite(v) else None
    if isinstance(v, list):
        return [_clean(x) for x in v]
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    return v


def _sums(tr: Track) -> list[dict[str, object]]:
    """Give a Gaussian-sum track's kept sums as JSON rows, one per track row."""
    history = tr.extra.history
    if not isinstance(history, list) or not all(isinstance(h, SumStep) for h in history):
        raise ValueError(f"the {tr.filter_name} track kept no Gaussian sums: run the gsf "
                         "filter with history=True (settings={'history': True})")
    steps = history[len(history) - len(tr):] if len(history) >= len(tr) else []
    if len(steps) != len(tr) or not np.allclose([h.time for h in steps], tr.times):
        raise ValueError("the kept Gaussian sums do not match the track's rows")
    return [{"weights": h.weights.tolist(), "means": h.means.tolist(),
             "covariances": h.covariances.tolist()} for h in steps]


def track_dict(tr: Track, *, sums: bool = False) -> dict[str, object]:
    """Return the track as JSON-ready data.

    Parameters
    ----------
    tr : Track
        A track (from :func:`tmakit.track` or a filter's ``run``).
    sums : bool, optional
        Add a Gaussian-sum track's filtered sum per row (``weights`` (M,), ``means`` (M, n),
        ``covariances`` (M, n, n)) and, if smoothed, the smoothed sums; the track must have kept
        them (``settings={"history": True}``; docs/tracking.md).

    Returns
    -------
    dict
        :meth:`Track.as_dict` with ``start``, ``q``, ``q_density``, the Gaussian sum's
        ``components``, an IMM filter's ``model_probabilities``, ``models`` and ``transition``,
        and a smoothed track's ``smoothed``, ``smoothed_std``, ``smoothed_covariance``,
        ``smoother`` (and a multiple-model track's ``smoothed_model_probabilities``); with
        ``sums``, ``sums`` and ``smoothed_sums``; NaN and infinities as ``None``.

    Raises
    ------
    ValueError
        With ``sums``, if the track kept no Gaussian sums, or they do not match its rows.
    """
    data = tr.as_dict()
    data["start"] = tr.extra.start
    data["q"] = tr.extra.q
    data["q_density"] = tr.extra.q_density
    if tr.extra.components is not None:
        data["components"] = tr.extra.components
    if tr.extra.model_probabilities is not None:
        data["model_probabilities"] = tr.extra.model_probabilities
        data["models"] = tr.extra.models
        data["transition"] = tr.extra.transition
    sm = tr.extra.smoothed
    if sm is not None:
        data["smoothed"] = sm.states.tolist()
        data["smoothed_std"] = sm.std.tolist()
        data["smoothed_covariance"] = sm.covariances.tolist()
        data["smoother"] = sm.extra.options.get("smoother")
        if sm.extra.model_probabilities is not None:
            data["smoothed_model_probabilities"] = sm.extra.model_probabilities
    if sums:
        data["sums"] = _sums(tr)
        if sm is not None:
            data["smoothed_sums"] = _sums(sm)
    return _clean(data)  # type: ignore[return-value]


@dataclass(frozen=True)
class TrackTable:
    """The content of a track file.

    Parameters
    ----------
    columns : dict of str to ndarray
        :meth:`Track.table_columns`, one row per update (SI).
    metadata : dict of str to str
        ``filter``, ``start`` (JSON) and ``q`` (JSON), for formats that carry metadata.
    """

    columns: dict[str, NDArray[np.float64]]
    metadata: dict[str, str]


def track_table(tr: Track) -> TrackTable:
    """Return the table and metadata a track file holds.

    Parameters
    ----------
    tr : Track

    Returns
    -------
    TrackTable
    """
    meta = {"filter": str(tr.filter_name),
            "start": json.dumps(track_dict(tr)["start"]),
            "q": json.dumps(tr.extra.q)}
    return TrackTable(tr.table_columns(), meta)


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
    from ..bounds.pcrb import deterministic_pcrb, posterior_crb  # (not loaded by tk.track)

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
