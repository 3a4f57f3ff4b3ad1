"""A filter's output, :class:`Track` (one row per update), and what its run collects.

:meth:`Track.answer` gives the emitter after any update in the user's terms, as
:meth:`tmakit.results.EstimateResult.answer` does for a batch estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.linalg import symmetrise
from ..data import MeasurementSet
from ..results.answers import ELLIPSE_LEVEL, Answer, track_answer


@dataclass(frozen=True)
class UpdateInfo:
    """What one update saw.

    Parameters
    ----------
    nis : float
        Normalised innovation squared (NaN for a skipped update).
    dof : int
        Its degrees of freedom (measurement rows; 0 when skipped).
    log_likelihood : float
        Log-likelihood of the group given the past (nats).
    """

    nis: float
    dof: int
    log_likelihood: float


SKIPPED = UpdateInfo(float("nan"), 0, 0.0)


@dataclass
class TrackExtras:
    """What a track records beside its rows (:attr:`Track.extra`).

    Read as attributes; ``extra["q"]`` and ``extra.get("q")`` read the same fields.

    Parameters
    ----------
    skipped_updates : int
        Updates the filter could not make (a degenerate group).
    start : dict or None
        How the track started, in JSON form (``tmakit.tracking.track`` sets it).
    start_record : object or None
        The same as a typed record (``tmakit.tracking.PriorStart``, ``BatchStart``, ...).
    q : list of float or None
        Process noise acceleration std per axis (m/s^2).
    q_density : list of float or None
        White-noise acceleration density per axis (m^2/s^3).
    dim : int or None
        Spatial dimension of the state (2 or 3).
    options : dict
        The filter's options (``alpha``, ``iterations``, ...).
    components : list of int or None
        Components a Gaussian-sum filter held after each update.
    smoothed : object or None
        The smoothed track (:func:`tmakit.filters.smooth`), when asked for.
    history : list or None
        A particle filter's weighted clouds (``ParticleFilter(history=True)``).
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
        """Give field ``key`` (KeyError if it is not a field)."""
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
        """
        value = getattr(self, key, None) if key in self.__dataclass_fields__ else None
        return default if value is None else value


class Recorder:
    """Collects a run's per-update rows ``(time, state, cov, nis, dof, ll)`` and blocks."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.blocks: list[tuple[NDArray[Any], ...]] = []
        self.rows: list[tuple[float, Array, Array, float, int, float]] = []

    def add(self, time: float, state: Array, cov: Array, info: UpdateInfo,
            loglik: float) -> None:
        """Record one update."""
        self.rows.append((time, state, cov, info.nis, info.dof, loglik))

    def _flush(self) -> None:
        if self.rows:
            t, x, p, nis, dof, ll = zip(*self.rows, strict=True)
            self.blocks.append((np.array(t, dtype=float), np.array(x, dtype=float),
                                np.array(p, dtype=float), np.array(nis, dtype=float),
                                np.array(dof, dtype=np.int64), np.array(ll, dtype=float)))
            self.rows = []

    def add_block(self, *columns: NDArray[Any]) -> None:
        """Record updates run in one go: times, states, covariances, NIS, dof, log-likelihoods."""
        self._flush()
        self.blocks.append(columns)

    def parts(self) -> list[NDArray[Any]]:
        """Give the stacked outputs of every update recorded."""
        self._flush()
        n = self.n
        if not self.blocks:
            return [np.zeros(0), np.zeros((0, n)), np.zeros((0, n, n)), np.zeros(0),
                    np.zeros(0, dtype=np.int64), np.zeros(0)]
        parts = [np.concatenate([b[i] for b in self.blocks]) for i in range(6)]
        return [parts[0], parts[1].reshape(-1, n), parts[2].reshape(-1, n, n), parts[3],
                parts[4].astype(np.int64), parts[5]]


@dataclass
class Track:
    """A filter's output: one row per update.

    Parameters
    ----------
    filter_name : str
        Name of the filter (``"ekf"``, ``"ukf"``, ``"pf"``, ...).
    state_names : tuple of str
        Names of the state components (``x, y, vx, vy`` or ``x, y, z, vx, vy, vz``).
    times, nis, dof, log_likelihood : numpy.ndarray
        Per update ``(K,)``: time (s), NIS, degrees of freedom, cumulative log-likelihood (nats).
    states, covariances : numpy.ndarray
        State ``(K, n)`` and covariance ``(K, n, n)`` after each update (m, m/s).
    extra : TrackExtras, optional
        What the track records beside its rows (skipped updates, how it started, ...).
    """

    filter_name: str
    state_names: tuple[str, ...]
    times: Array
    states: Array
    covariances: Array
    nis: Array
    dof: NDArray[np.int64]
    log_likelihood: Array
    extra: TrackExtras = field(default_factory=TrackExtras)

    def __len__(self) -> int:
        """Give the number of updates K."""
        return int(self.times.shape[0])

    @property
    def std(self) -> Array:
        """Standard deviations ``(K, n)`` of the state components (m, m/s)."""
        return cast(Array, np.sqrt(np.clip(np.einsum("kii->ki", self.covariances), 0.0, None)))

    def errors(self, truth: ArrayLike) -> Array:
        """Give the estimate minus the truth ``(K, n)`` (m, m/s).

        Parameters
        ----------
        truth : array_like
            True states ``(K, n)`` at :attr:`times` (m, m/s).

        Returns
        -------
        numpy.ndarray
        """
        return cast(Array, self.states - np.asarray(truth, dtype=float))

    def nees(self, truth: ArrayLike) -> Array:
        """Give the normalised estimation error squared ``e^T P^-1 e`` per update ``(K,)``.

        Parameters
        ----------
        truth : array_like
            As for :meth:`errors`.

        Returns
        -------
        numpy.ndarray
            ``inf`` where a singular covariance (a collapsed particle cloud) says the error is
            impossible.
        """
        err = self.errors(truth)
        try:
            return cast(Array, np.einsum("ki,ki->k", err,
                             np.linalg.solve(self.covariances, err[..., None])[..., 0]))
        except np.linalg.LinAlgError:
            evals, evecs = np.linalg.eigh(symmetrise(self.covariances))
            proj = np.einsum("kji,kj->ki", evecs, err)  # error in the eigenbasis
            tiny = evals <= 1e-12 * np.max(np.abs(evals), axis=-1, keepdims=True)
            with np.errstate(divide="ignore", invalid="ignore"):
                terms = np.where(tiny, np.where(proj == 0, 0.0, np.inf), proj**2 / evals)
            return cast(Array, np.sum(terms, axis=-1))

    def as_dict(self) -> dict[str, object]:
        """Give the track as JSON-ready lists (the keys of ``tma track``'s JSON output).

        Returns
        -------
        dict
            ``filter``, ``state``, ``time`` (s), ``estimate`` and ``std`` (m, m/s), ``covariance``,
            ``nis``, ``dof``, ``log_likelihood`` (nats).
        """
        return {
            "filter": self.filter_name,
            "state": list(self.state_names),
            "time": self.times.tolist(),
            "estimate": self.states.tolist(),
            "std": self.std.tolist(),
            "covariance": self.covariances.tolist(),
            "nis": self.nis.tolist(),
            "dof": self.dof.tolist(),
            "log_likelihood": self.log_likelihood.tolist(),
        }

    def answer(self, meas: MeasurementSet | None = None, index: int = -1,
               sensor: str | None = None, level: float = ELLIPSE_LEVEL) -> Answer:
        """Return the emitter after one update in the user's terms (``tma track``'s answers).

        Parameters
        ----------
        meas, sensor, level
            As for :meth:`tmakit.EstimateResult.answer`.
        index : int
            The update (default the last).

        Returns
        -------
        Answer
        """
        return track_answer(self, meas, index, sensor, level)

    def table_columns(self) -> dict[str, Array]:
        """Give the columns of a CSV/Parquet track table.

        Returns
        -------
        dict of str to numpy.ndarray
            ``time`` (s), each state (m, m/s) and its ``std_*``, the covariance's upper triangle
            (``cov_x_y``, ...), ``nis``, ``dof`` and ``log_likelihood`` (nats).
        """
        names, std, n = self.state_names, self.std, len(self.state_names)
        cols: dict[str, Array] = {"time": self.times}
        cols.update({name: self.states[:, i] for i, name in enumerate(names)})
        cols.update({f"std_{name}": std[:, i] for i, name in enumerate(names)})
        cols.update({f"cov_{names[i]}_{names[j]}": self.covariances[:, i, j]
                     for i in range(n) for j in range(i, n)})
        cols["nis"] = self.nis
        cols["dof"] = self.dof.astype(float)
        cols["log_likelihood"] = self.log_likelihood
        return cols
