"""Numerically safe covariance algebra.

No ``LinAlgError`` and no non-symmetric covariance reaches a user of the filters.  Matrices
are covariances in SI units (m^2, m^2/s, m^2/s^2); the functions do not care which.
"""

from __future__ import annotations

import functools
import math
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike

from .arrays import Array


def symmetrise(p: Array) -> Array:
    """Symmetrise a matrix (or a stack of them): ``(P + P^T) / 2``."""
    return 0.5 * (p + np.swapaxes(p, -1, -2))


def check_prior(mean: ArrayLike, cov: ArrayLike, mean_name: str, cov_name: str, *,
                require_symmetric: bool = False) -> tuple[Array, Array]:
    """Check a Gaussian prior on a 2-D or 3-D position-velocity state."""
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
    """Give the symmetric matrix nearest to ``p`` with eigenvalues ``>= floor``."""
    evals, evecs = np.linalg.eigh(symmetrise(p))
    evals = np.maximum(evals, floor)
    return symmetrise((evecs * evals) @ evecs.T)


def safe_cholesky(p: Array) -> Array:
    """Give the lower Cholesky factor of a covariance, repairing it if needed."""
    p = symmetrise(p)
    try:
        return cast(Array, np.linalg.cholesky(p))
    except np.linalg.LinAlgError:
        scale = max(float(np.max(np.abs(np.diag(p)))), 1e-300)
        return cast(Array, np.linalg.cholesky(nearest_psd(p, floor=1e-12 * scale)))


def solve_spd(s: Array, b: Array) -> tuple[Array, float]:
    """Solve ``S x = b`` for a symmetric positive-definite ``S`` and give ``log det S``."""
    chol = safe_cholesky(s)
    y = np.linalg.solve(chol, b)
    x = np.linalg.solve(chol.T, y)
    return x, float(2.0 * np.sum(np.log(np.diag(chol))))


def repair_psd(p: Array) -> Array:
    """Give ``p`` symmetrised and, if need be, made positive definite."""
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


def eigh(a: Array) -> tuple[Array, Array]:
    """Give ``numpy.linalg.eigh(a)`` by its LAPACK routine called directly (10 µs less)."""
    w, v, info = _dsyevd()(a, 1, 1)  # compute_v, lower (f2py parses keywords slowly)
    if info != 0:
        raise np.linalg.LinAlgError(f"eigenvalues did not converge (LAPACK info {info})")
    return w, v


@functools.cache
def _dsyevd() -> Any:
    from scipy.linalg.lapack import dsyevd  # (scipy.linalg: imported on first use)

    return dsyevd


def normalise(info: Array) -> tuple[Array, Array]:
    """Normalise an information matrix to unit diagonal."""
    # the scale in floats (one information is small): the same bits as 1 / np.sqrt(d)
    scale = np.array([1.0 / math.sqrt(d) if d > 0 else 1.0 for d in info.diagonal().tolist()])
    return info * scale[:, None] * scale, scale


def normalised_eigh(info: Array) -> tuple[Array, Array, Array]:
    """Eigen-decompose an information matrix in the coordinates of :func:`normalise`."""
    norm, scale = normalise(info)
    evals, evecs = eigh(norm)
    return evals, evecs, scale
