"""A track as data for output: the JSON form and the table of a track file (written by ``io``)."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..filters import Track

__all__ = ["TrackTable", "track_dict", "track_table"]


def _clean(v: object) -> object:
    """Give ``v`` with non-finite floats as ``None``, through lists and dicts."""
    if isinstance(v, float):
        return v if np.isfinite(v) else None
    if isinstance(v, list):
        return [_clean(x) for x in v]
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    return v


def track_dict(tr: Track) -> dict[str, object]:
    """Return the track as JSON-ready data.

    Parameters
    ----------
    tr : Track
        A track (from :func:`tmakit.track` or a filter's ``run``).

    Returns
    -------
    dict
        :meth:`Track.as_dict` with ``start``, ``q``, ``q_density``, the Gaussian sum's
        ``components``, an IMM filter's ``model_probabilities``, ``models`` and ``transition``,
        and a smoothed track's ``smoothed``, ``smoothed_std``, ``smoothed_covariance`` and
        ``smoother``; NaN and infinities as ``None``.
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
        The track.

    Returns
    -------
    TrackTable
    """
    meta = {"filter": str(tr.filter_name),
            "start": json.dumps(track_dict(tr)["start"]),
            "q": json.dumps(tr.extra.q)}
    return TrackTable(tr.table_columns(), meta)
