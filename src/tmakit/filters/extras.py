"""What a filter's track records beside its rows: :class:`TrackExtras`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["TrackExtras"]


@dataclass
class TrackExtras:
    """What a track records beside its rows (:attr:`Track.extra`).

    Read as attributes; ``extra["q"]`` and ``extra.get("q")`` read the same fields (the form of the
    JSON output and of older code).

    Parameters
    ----------
    skipped_updates : int
        Updates the filter could not make (a degenerate group, :func:`tmakit.filters.ekf.skipped`).
    start : dict or None
        How the track started, in JSON form (``tmakit.tracking.track`` sets it).
    start_record : object or None
        The same as a typed record (``tmakit.tracking.records.PriorStart`` or ``BatchStart``; typed
        loosely here because the filters sit below the tracking layer).
    q : list of float or None
        Process noise acceleration std per axis (m/s^2) the track was run with.
    q_density : list of float or None
        White-noise acceleration density per axis (m^2/s^3) the track was run with.
    dim : int or None
        Spatial dimension of the state (2 or 3).
    options : dict
        The filter's options (``alpha``, ``iterations``, ...).
    components : list of int or None
        Components a Gaussian-sum filter held after each update.
    smoothed : object or None
        The smoothed track (:func:`tmakit.filters.smooth`), when asked for.
    history : list or None
        A particle filter's weighted clouds (``ParticleFilter(history=True)``), for its smoother.
    model_probabilities : list of list of float or None
        An IMM filter's model probabilities after each update.
    models : list of dict or None
        An IMM filter's models (``q``, ``q_density`` per axis, ``prior`` probability).
    transition : list of list of float or None
        An IMM filter's Markov matrix (row: from, column: to).
    """

    skipped_updates: int = 0
    start: dict[str, Any] | None = None
    start_record: Any = None
    q: list[float] | None = None
    q_density: list[float] | None = None
    dim: int | None = None
    options: dict[str, Any] = field(default_factory=dict)
    components: list[int] | None = None
    smoothed: Any = None
    history: Any = None
    model_probabilities: list[list[float]] | None = None
    models: list[dict[str, Any]] | None = None
    transition: list[list[float]] | None = None

    def __getitem__(self, key: str) -> Any:
        """Give field ``key``.

        Parameters
        ----------
        key : str
            A field name.

        Returns
        -------
        object
            Its value.

        Raises
        ------
        KeyError
            If ``key`` is not a field.
        """
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def get(self, key: str, default: Any = None) -> Any:
        """Give field ``key``, or ``default`` when it is not a field or is ``None``.

        Parameters
        ----------
        key : str
            A field name.
        default : object, optional
            What to give otherwise.

        Returns
        -------
        object
            The value or ``default``.
        """
        value = getattr(self, key, None) if key in self.__dataclass_fields__ else None
        return default if value is None else value
