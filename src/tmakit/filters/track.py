"""A filter's output, :class:`Track`: one row per update.

A track's :meth:`Track.answer` gives the emitter after any update in the user's terms (position
in E/N and lat/lon, course, speed, range and bearing, each with its std, and the ellipse), the
same answer :meth:`tmakit.results.EstimateResult.answer` gives for a batch estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.linalg import symmetrise
from ..data import MeasurementSet
from ..results.answers import ELLIPSE_LEVEL, Answer, track_answer
from .extras import TrackExtras


@dataclass
class Track:
    """A filter's output: one row per update.

    Parameters
    ----------
    filter_name : str
        Name of the filter (``"ekf"``, ``"ukf"``, ``"pf"``, ``"mgekf"``).
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
            ``states - truth``.
        """
        return cast(Array, self.states - np.asarray(truth, dtype=float))

    def nees(self, truth: ArrayLike) -> Array:
        """Give the normalised estimation error squared ``e^T P^-1 e`` per update ``(K,)``.

        Parameters
        ----------
        truth : array_like
            True states ``(K, n)`` at :attr:`times` (m, m/s).

        Returns
        -------
        numpy.ndarray
            NEES per update; ``inf`` where a singular covariance (a collapsed particle cloud) says
            the error is impossible.
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
        meas : MeasurementSet, optional
            The measurements tracked: ENU and clock-time origins, the sensor's track.
        index : int
            The update (default the last).
        sensor : str, optional
            Sensor for range and bearing; default the sensor of the last measurement.
        level : float
            Probability inside the position ellipse (default 0.95).

        Returns
        -------
        Answer
            Position (E/N, lat/lon), course (deg true), speed, range and bearing at the update's
            time, each with its std, and the position ellipse.
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
        cols: dict[str, Array] = {"time": self.times}
        n = len(self.state_names)
        for i, name in enumerate(self.state_names):
            cols[name] = self.states[:, i]
        for i, name in enumerate(self.state_names):
            cols[f"std_{name}"] = self.std[:, i]
        for i in range(n):
            for j in range(i, n):
                cols[f"cov_{self.state_names[i]}_{self.state_names[j]}"] = \
                    self.covariances[:, i, j]
        cols["nis"] = self.nis
        cols["dof"] = self.dof.astype(float)
        cols["log_likelihood"] = self.log_likelihood
        return cols
