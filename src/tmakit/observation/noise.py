"""The measurement noise covariance of a measurement set, and whitening by it.

Correlated blocks (range differences sharing pulse intervals, Chen & Sun, eq. 1) are whitened
by their eigen-decomposition.  Sensor positions known to a covariance add ``H_b Q_b H_b'`` to
``R`` (:func:`effective_noise`; Ho, Lu & Kovavisaruch (2007)).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..data import MeasurementSet
from ..measurements import KINDS, MeasurementModel, model_for, options_with_metadata
from .model import ObservationModel
from .rows import RowModel, correlated_blocks


class NoiseModel:
    """Whitening ``x -> W x`` with ``W^T W = R^+`` for the noise covariance ``R`` (SI).

    Dense blocks (correlated range differences) are whitened by eigen-decomposition; repeated
    information gets zero weight and :attr:`rank` counts the independent rows.

    Parameters
    ----------
    meas : MeasurementSet
    models : mapping, optional
        The kinds' models (default options otherwise).

    Attributes
    ----------
    n, rank : int
        Rows, and independent rows (degrees of freedom).
    correlated : bool
        Some block is dense.

    References
    ----------
    Chen & Sun, eq. 1 (shared pulse intervals).
    """

    def __init__(self, meas: MeasurementSet,
                 models: Mapping[str, MeasurementModel] | None = None) -> None:
        chosen: dict[str, MeasurementModel] = {}
        index: dict[str, NDArray[np.intp]] = {}
        present = set(meas.kinds)
        for kind, cls in KINDS.items():
            rows = (np.flatnonzero(meas.kind_mask(kind))
                    if cls.correlated_noise and kind in present else np.zeros(0, np.int64))
            if len(rows):
                chosen[kind] = (models[kind] if models is not None and kind in models
                                else model_for(kind, options_with_metadata(
                                    [kind], None, meas.metadata).get(kind)))
                index[kind] = rows
        self._setup(meas.sigma_si, correlated_blocks(chosen, index, meas.time, meas.time_ref,
                                                     meas.sigma_si, meas.sensor_code, False,
                                                     meas.ref_sensor_state))

    @classmethod
    def from_rows(cls, rows: RowModel) -> NoiseModel:
        """Build the noise model of a :class:`~tmakit.observation.rows.RowModel`'s rows.

        Parameters
        ----------
        rows : RowModel

        Returns
        -------
        NoiseModel
        """
        out = object.__new__(cls)
        out._setup(rows.sigma, rows.correlated_blocks(singletons=False))
        return out

    def _setup(self, sigma: NDArray[np.float64],
               blocks: list[tuple[NDArray[np.intp], NDArray[np.float64]]]) -> None:
        self.n = sigma.shape[0]
        self.inv_sigma = 1.0 / sigma
        self.rank = self.n
        by_size: dict[int, list[tuple[NDArray[np.intp], NDArray[np.float64]]]] = {}
        for rows, cov in blocks:
            by_size.setdefault(rows.size, []).append((rows, cov))
        # blocks of one size stacked: decomposed in one call, whitened with one product
        self._stacks: list[tuple[NDArray[np.intp], NDArray[np.float64]]] = []
        for size in sorted(by_size):
            stack = self._whiteners(sigma, size, by_size.pop(size))
            if stack is not None:
                self._stacks.append(stack)
        self.correlated = bool(self._stacks)

    def _whiteners(self, sigma: NDArray[np.float64], size: int,
                   blocks: list[tuple[NDArray[np.intp], NDArray[np.float64]]]
                   ) -> tuple[NDArray[np.intp], NDArray[np.float64]] | None:
        """Whiten the dense blocks of one size: ``(k, size)`` rows and ``(k, size, size)``."""
        rows = np.stack([r for r, _ in blocks])
        cov = np.stack([c for _, c in blocks])
        off = cov.copy()
        off[:, np.arange(size), np.arange(size)] = 0.0
        dense = np.any(off != 0.0, axis=(1, 2))  # no shared intervals: the diagonal is exact
        if not dense.any():
            return None
        rows, cov = rows[dense], cov[dense]
        # decomposed over the rows' sigmas: rows of different units (s, Hz) in one block
        inv = 1.0 / sigma[rows]
        evals, evecs = np.linalg.eigh(cov * inv[:, :, None] * inv[:, None, :])  # ascending
        keep = evals > 1e-10 * evals[:, -1:]
        kept = keep.sum(axis=1)
        scaled = np.where(keep[:, None, :], evecs / np.sqrt(np.where(keep, evals, 1.0))[:, None, :],
                          0.0)
        # row i of a block's whitener: its i-th kept eigenvector / sqrt(eigenvalue), then zeros
        order = (np.arange(size)[None, :] + (size - kept)[:, None]) % size
        whitener = np.take_along_axis(np.swapaxes(scaled, 1, 2), order[:, :, None], axis=1)
        whitener *= inv[:, None, :]
        self.rank -= int(np.sum(size - kept))
        return rows, np.ascontiguousarray(whitener)

    @property
    def blocks(self) -> list[tuple[NDArray[np.intp], NDArray[np.float64]]]:
        """The dense blocks: each one's rows (ascending) and whitener (for small sets, tests)."""
        return [(r, w) for rows, whiteners in self._stacks for r, w in zip(rows, whiteners,
                                                                           strict=True)]

    @classmethod
    def from_covariance(cls, covariance: NDArray[np.float64]) -> NoiseModel:
        """Build the model of rows with a full noise covariance ``R`` (m, m), SI squared.

        Parameters
        ----------
        covariance : ndarray

        Returns
        -------
        NoiseModel

        Raises
        ------
        ValueError
            If ``R`` is not a finite, symmetric, positive definite square matrix.
        """
        r = checked_covariance(covariance)
        out = object.__new__(cls)
        out._setup(np.sqrt(np.diagonal(r)).copy(), [(np.arange(r.shape[0]), r)])
        return out

    @classmethod
    def independent(cls, sigma: NDArray[np.float64]) -> NoiseModel:
        """Build the model of independent rows with std ``sigma`` (m,), SI.

        Parameters
        ----------
        sigma : ndarray

        Returns
        -------
        NoiseModel
        """
        out = object.__new__(cls)
        out._setup(np.asarray(sigma, dtype=float), [])
        return out

    def whiten(self, x: NDArray[np.float64], axis: int = -1, overwrite: bool = False
               ) -> NDArray[np.float64]:
        """Return ``W x`` along ``axis`` (the measurement axis) of ``x``.

        Parameters
        ----------
        x : ndarray
            SI, ``m`` long along ``axis``.
        axis : int
        overwrite : bool
            ``x`` may be scaled in place when the rows are independent.

        Returns
        -------
        ndarray
        """
        if not self._stacks:  # independent rows: a scaling (the common, hot case)
            x = np.asarray(x, dtype=float)
            if axis in (-1, -2):
                scale = self.inv_sigma if axis == -1 else self.inv_sigma[:, None]
                if overwrite and x.flags.writeable:
                    x *= scale
                    return x
                return x * scale
        x = np.moveaxis(np.asarray(x, dtype=float), axis, -1)
        out = x * self.inv_sigma
        for rows, whitener in self._stacks:  # (k, b) rows, (k, b, b) whiteners
            out[..., rows] = np.einsum("kij,...kj->...ki", whitener, x[..., rows])
        return np.moveaxis(out, -1, axis)

    def chunk_bounds(self, size: int) -> list[tuple[int, int]]:
        """Cut the rows into ranges of about ``size`` that never split a correlated block.

        Parameters
        ----------
        size : int

        Returns
        -------
        list of (int, int)
            ``(lo, hi)`` ranges covering ``0 .. n`` in order.
        """
        n = self.n
        inside = np.zeros(n + 1, dtype=np.int64)  # blocks straddling a cut before row c
        for rows, _ in self._stacks:
            np.add.at(inside, rows[:, 0] + 1, 1)
            np.add.at(inside, rows[:, -1] + 1, -1)
        safe = np.flatnonzero(np.cumsum(inside) == 0)  # cuts that split no block
        bounds, lo = [], 0
        while lo < n:
            hi = int(safe[np.searchsorted(safe, min(n, lo + max(1, size)))])
            bounds.append((lo, hi))
            lo = hi
        return bounds

    def covariance(self) -> NDArray[np.float64]:
        """Return ``R`` (m, m), SI squared, the pseudo-inverse of ``W^T W``.

        Returns
        -------
        ndarray
        """
        w = self.whiten(np.eye(self.n), axis=0)
        return cast(Array, np.linalg.pinv(w.T @ w, rcond=1e-10, hermitian=True))


def checked_covariance(covariance: object, m: int | None = None) -> NDArray[np.float64]:
    """Return a noise covariance as a float array, checked."""
    r = np.array(covariance, dtype=float)
    size = r.shape[0] if r.ndim == 2 else -1
    if r.ndim != 2 or r.shape[1] != size or (m is not None and size != m):
        want = "a square matrix" if m is None else f"shape ({m}, {m}), one row per measurement"
        raise ValueError(f"covariance must be {want}; got shape {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ValueError("covariance must be finite")
    scale = float(np.max(np.abs(np.diagonal(r)))) if size else 0.0
    if np.max(np.abs(r - r.T), initial=0.0) > 1e-9 * scale:
        raise ValueError("covariance must be symmetric")
    r = 0.5 * (r + r.T)
    diag = np.diagonal(r)
    if size == 0 or not np.all(diag > 0.0):
        raise ValueError("covariance must be positive definite")
    scale_rows = 1.0 / np.sqrt(diag)  # rows of different units (s and Hz): test the correlation
    if np.min(np.linalg.eigvalsh(r * scale_rows[:, None] * scale_rows[None, :])) <= 0.0:
        raise ValueError("covariance must be positive definite")
    return r


#: Most rows whose effective covariance (dense) is formed.
MAX_ROWS = 4096


def sensor_error_design(obs: ObservationModel, theta: ArrayLike, nuisance: ArrayLike,
                        velocity: bool = False) -> Array:
    """Give ``H_b``: the rows' derivatives by the errors of the distinct sensor positions."""
    g = obs.grouped
    rows = obs.row_model
    theta = np.asarray(theta, dtype=float)
    target = obs.motion.states(theta, g.time)
    target_ref = (None if rows.reference is None
                  else obs.motion.states(theta, g.time_ref[rows.reference]))
    rel, rel_ref = rows.relative(target, target_ref)
    d_rel, d_ref, _ = rows.jacobian(rel, rel_ref, np.asarray(nuisance, dtype=float))
    width = 6 if velocity else 3
    own = g.sensor_state[:, :width]
    refs = (np.zeros((0, width)) if rows.reference is None
            else g.ref_sensor_state[rows.reference, :width])
    keys, label = np.unique(np.concatenate([own, refs]), axis=0, return_inverse=True)
    label = label.ravel()
    design = np.zeros((len(g), keys.shape[0], width))
    m = len(g)
    # the reported position is off by b: rel = target - (sensor + b), d/db = -d/d rel
    np.add.at(design, (np.arange(m), label[:m]), -d_rel[:, :width])
    if rows.reference is not None and d_ref is not None:
        np.add.at(design, (rows.reference, label[m:]), -d_ref[:, :width])
    return design.reshape(m, -1)


def effective_noise(obs: ObservationModel, theta: ArrayLike, nuisance: ArrayLike,
                    position_sigma: float, velocity_sigma: float = 0.0) -> NoiseModel:
    """Give the noise model of the rows with the sensors' navigation errors folded in.

    References
    ----------
    Ho, Lu & Kovavisaruch (2007) (the CRLB with sensor position errors).
    """
    for name, value in (("position", position_sigma), ("velocity", velocity_sigma)):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"sensor {name} sigma: expected a finite value >= 0, found "
                             f"{value!r}")
    m = len(obs.grouped)
    if m > MAX_ROWS:
        raise ValueError(f"{m:,} rows: the covariance with sensor position errors is dense; "
                         f"at most {MAX_ROWS:,} rows (a snapshot, or --from/--to)")
    r = obs.row_model.covariance()
    velocity = velocity_sigma > 0
    h = sensor_error_design(obs, theta, nuisance, velocity)
    scale: NDArray[np.float64] = np.tile(
        np.array([position_sigma] * 3 + ([velocity_sigma] * 3 if velocity else [])),
        h.shape[1] // (6 if velocity else 3))
    hs = h * scale
    return NoiseModel.from_covariance(r + hs @ hs.T)
