"""Numerically safe covariance algebra for the filters: no ``LinAlgError`` and no
non-symmetric covariance reaches a user."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def symmetrise(p: Array) -> Array:
    """``(P + P^T) / 2``."""
    return 0.5 * (p + np.swapaxes(p, -1, -2))


def check_prior(mean: ArrayLike, cov: ArrayLike, mean_name: str, cov_name: str, *,
                require_symmetric: bool = False) -> tuple[Array, Array]:
    """A Gaussian prior on the state ``[x, y, vx, vy]`` or ``[x, y, z, vx, vy, vz]`` (m, m/s)
    as float arrays (copies), the covariance symmetrised.

    Raises ``ValueError``, naming the field as ``mean_name`` / ``cov_name``, unless the mean
    has 4 or 6 entries, the covariance is square of the same size, both are finite, the
    covariance is positive definite and, with ``require_symmetric``, symmetric to 1e-9
    relative (otherwise it is symmetrised silently)."""
    mean = np.array(mean, dtype=float)
    cov = np.array(cov, dtype=float)
    if mean.ndim != 1 or mean.shape[0] not in (4, 6):
        raise ValueError(f"{mean_name} must be [x, y, vx, vy] or [x, y, z, vx, vy, vz] "
                         f"(m, m/s); got shape {mean.shape}")
    n = mean.shape[0]
    if cov.shape != (n, n):
        raise ValueError(f"{cov_name} must be {n}x{n} to match {mean_name}; got shape "
                         f"{cov.shape}")
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        raise ValueError(f"{mean_name} and {cov_name} must be finite")
    if require_symmetric and not np.allclose(cov, cov.T, rtol=1e-9, atol=0.0):
        raise ValueError(f"{cov_name} must be symmetric")
    cov = symmetrise(cov)
    if np.min(np.linalg.eigvalsh(cov)) <= 0:
        raise ValueError(f"{cov_name} must be positive definite (every state component needs "
                         "a finite, non-zero prior variance; use a large one for 'unknown')")
    return mean, cov


def nearest_psd(p: Array, floor: float = 0.0) -> Array:
    """The symmetric matrix nearest to ``p`` with eigenvalues ``>= floor`` (clips negative
    eigenvalues that rounding produced)."""
    evals, evecs = np.linalg.eigh(symmetrise(p))
    evals = np.maximum(evals, floor)
    return symmetrise((evecs * evals) @ evecs.T)


def safe_cholesky(p: Array) -> Array:
    """Lower Cholesky factor of a covariance, repairing it (symmetrising, then clipping
    eigenvalues to a tiny multiple of the largest) if rounding made it indefinite."""
    p = symmetrise(p)
    try:
        return np.linalg.cholesky(p)
    except np.linalg.LinAlgError:
        scale = max(float(np.max(np.abs(np.diag(p)))), 1e-300)
        return np.linalg.cholesky(nearest_psd(p, floor=1e-12 * scale))


def solve_spd(s: Array, b: Array) -> tuple[Array, float]:
    """``S^-1 b`` and ``log det S`` for a symmetric positive-definite innovation covariance
    ``S``, by Cholesky (repaired if needed)."""
    chol = safe_cholesky(s)
    y = np.linalg.solve(chol, b)
    x = np.linalg.solve(chol.T, y)
    return x, float(2.0 * np.sum(np.log(np.diag(chol))))


def joseph_update(p: Array, gain: Array, h: Array, r: Array) -> Array:
    """Joseph form ``(I - K H) P (I - K H)^T + K R K^T``: symmetric and positive
    semi-definite for any gain, unlike ``(I - K H) P``."""
    i_kh = np.eye(p.shape[0]) - gain @ h
    return symmetrise(i_kh @ p @ i_kh.T + gain @ r @ gain.T)


def repair_psd(p: Array) -> Array:
    """``p`` symmetrised and, if it is not numerically positive definite (its Cholesky
    factorisation fails, e.g. after an update with a huge prior and a tiny noise), replaced by
    the nearest symmetric matrix with eigenvalues at least ``n eps`` times the largest: what a
    filter hands to the next step and to the user is always a valid covariance."""
    p = symmetrise(p)
    try:
        np.linalg.cholesky(p)
        return p
    except np.linalg.LinAlgError:
        if not np.all(np.isfinite(p)):
            return p  # the filters refuse non-finite updates before they get here
        evals = np.linalg.eigvalsh(p)
        scale = max(float(np.max(np.abs(evals))), 1e-300)
        return nearest_psd(p, floor=p.shape[0] * np.finfo(float).eps * scale)
