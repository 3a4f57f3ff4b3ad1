"""Numerically safe covariance algebra.

No ``LinAlgError`` and no non-symmetric covariance reaches a user of the filters.  Matrices
are covariances in SI units (m^2, m^2/s, m^2/s^2); the functions do not care which.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from .arrays import Array


def symmetrise(p: Array) -> Array:
    """Symmetrise a matrix (or a stack of them): ``(P + P^T) / 2``.

    Parameters
    ----------
    p : numpy.ndarray
        Square matrix or stack ``(..., n, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        ``(P + P^T) / 2`` over the last two axes (same units and shape).
    """
    return 0.5 * (p + np.swapaxes(p, -1, -2))


def check_prior(mean: ArrayLike, cov: ArrayLike, mean_name: str, cov_name: str, *,
                require_symmetric: bool = False) -> tuple[Array, Array]:
    """Check a Gaussian prior on a 2-D or 3-D position-velocity state.

    Parameters
    ----------
    mean : array_like
        ``[x, y, vx, vy]`` or ``[x, y, z, vx, vy, vz]`` (m, m/s).
    cov : array_like
        Its covariance, ``(n, n)`` (m^2, m^2/s, m^2/s^2).
    mean_name, cov_name : str
        How the error messages name the two fields.
    require_symmetric : bool, optional
        Refuse a covariance that is not symmetric to 1e-9 relative (otherwise it is
        symmetrised silently).

    Returns
    -------
    mean : numpy.ndarray
        Float copy of the mean, ``(n,)``.
    cov : numpy.ndarray
        Float copy of the covariance, symmetrised, ``(n, n)``.

    Raises
    ------
    ValueError
        Naming the field, unless the mean has 4 or 6 entries, the covariance is square of
        the same size, both are finite, the covariance is positive definite and (with
        ``require_symmetric``) symmetric.
    """
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
    """Give the symmetric matrix nearest to ``p`` with eigenvalues ``>= floor``.

    Clips the (negative) eigenvalues that rounding produced.

    Parameters
    ----------
    p : numpy.ndarray
        Square matrix ``(n, n)`` (any units); symmetrised first.
    floor : float, optional
        Smallest eigenvalue allowed (units of ``p``).

    Returns
    -------
    numpy.ndarray
        Symmetric ``(n, n)`` matrix with eigenvalues ``>= floor`` (units of ``p``).
    """
    evals, evecs = np.linalg.eigh(symmetrise(p))
    evals = np.maximum(evals, floor)
    return symmetrise((evecs * evals) @ evecs.T)


def safe_cholesky(p: Array) -> Array:
    """Give the lower Cholesky factor of a covariance, repairing it if needed.

    The covariance is symmetrised; if rounding made it indefinite its eigenvalues are
    clipped to 1e-12 times its largest diagonal entry before factorising.

    Parameters
    ----------
    p : numpy.ndarray
        Covariance ``(n, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        Lower-triangular ``L`` with ``L L^T`` = the (repaired) ``p`` (square root of the
        units of ``p``).
    """
    p = symmetrise(p)
    try:
        return cast(Array, np.linalg.cholesky(p))
    except np.linalg.LinAlgError:
        scale = max(float(np.max(np.abs(np.diag(p)))), 1e-300)
        return cast(Array, np.linalg.cholesky(nearest_psd(p, floor=1e-12 * scale)))


def solve_spd(s: Array, b: Array) -> tuple[Array, float]:
    """Solve ``S x = b`` for a symmetric positive-definite ``S`` and give ``log det S``.

    By Cholesky factorisation (:func:`safe_cholesky`, repaired if needed).

    Parameters
    ----------
    s : numpy.ndarray
        Innovation covariance ``(m, m)`` (units of the measurements squared).
    b : numpy.ndarray
        Right-hand side(s), ``(m,)`` or ``(m, k)``.

    Returns
    -------
    x : numpy.ndarray
        ``S^-1 b``, shape of ``b``.
    log_det : float
        ``log det S`` (natural logarithm).
    """
    chol = safe_cholesky(s)
    y = np.linalg.solve(chol, b)
    x = np.linalg.solve(chol.T, y)
    return x, float(2.0 * np.sum(np.log(np.diag(chol))))


def joseph_update(p: Array, gain: Array, h: Array, r: Array) -> Array:
    """Give the Joseph-form covariance update ``(I - K H) P (I - K H)^T + K R K^T``.

    Symmetric and positive semi-definite for any gain, unlike ``(I - K H) P``.

    Parameters
    ----------
    p : numpy.ndarray
        Prior covariance ``(n, n)`` (state units squared).
    gain : numpy.ndarray
        Gain ``K`` ``(n, m)`` (state units per measurement unit).
    h : numpy.ndarray
        Measurement matrix ``H`` ``(m, n)`` (measurement units per state unit).
    r : numpy.ndarray
        Measurement noise covariance ``R`` ``(m, m)`` (measurement units squared).

    Returns
    -------
    numpy.ndarray
        Updated covariance ``(n, n)``, symmetrised (state units squared).
    """
    i_kh = np.eye(p.shape[0]) - gain @ h
    return symmetrise(i_kh @ p @ i_kh.T + gain @ r @ gain.T)


def repair_psd(p: Array) -> Array:
    """Give ``p`` symmetrised and, if need be, made positive definite.

    If the Cholesky factorisation fails (e.g. after an update with a huge prior and a tiny
    noise) the matrix is replaced by the nearest symmetric one with eigenvalues at least
    ``n eps`` times the largest: what a filter hands to the next step and to the user is
    always a valid covariance.  A non-finite ``p`` is returned symmetrised only.

    Parameters
    ----------
    p : numpy.ndarray
        Covariance ``(n, n)`` (any units).

    Returns
    -------
    numpy.ndarray
        Symmetric, numerically positive-definite ``(n, n)`` matrix (units of ``p``).
    """
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


def normalise(info: Array) -> tuple[Array, Array]:
    """Normalise an information matrix to unit diagonal.

    Parameters
    ----------
    info : ndarray, shape (q, q)
        Fisher information ``F`` (SI units of the parameters, inverse squared).

    Returns
    -------
    norm : ndarray, shape (q, q)
        ``D F D`` (dimensionless).
    scale : ndarray, shape (q,)
        ``D = diag(F)^-1/2`` (parameters with no information get 1).
    """
    d = np.diag(info).copy()
    scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    return info * scale[:, None] * scale[None, :], scale


def normalised_eigh(info: Array) -> tuple[Array, Array, Array]:
    """Eigen-decompose an information matrix in the coordinates of :func:`normalise`.

    Parameters
    ----------
    info : ndarray, shape (q, q)
        Fisher information (SI units of the parameters, inverse squared).

    Returns
    -------
    evals : ndarray, shape (q,)
        Eigenvalues of ``D F D``, ascending (dimensionless).
    evecs : ndarray, shape (q, q)
        Its eigenvectors, in columns.
    scale : ndarray, shape (q,)
        ``D`` (SI units of the parameters).
    """
    norm, scale = normalise(info)
    evals, evecs = np.linalg.eigh(norm)
    return evals, evecs, scale
