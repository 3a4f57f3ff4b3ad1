"""The pairs and the noise of the ratio method (Gu et al. (2007) §4).

Consecutive pairs of one kind per sensor, the tri-diagonal covariances of the power and
Doppler ratio terms (the derived ones and the paper's printed ones,
:mod:`tmakit.batch.ratios` says where they differ), and whitening by a banded Cholesky
factor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cho_solve_banded, cholesky_banded, solve_banded

from ..core.arrays import Array
from ..core.units import SPEED_OF_LIGHT
from ..data import MeasurementSet

__all__ = ["COVARIANCES", "Banded", "RatioPairs", "chain", "doppler_bands",
           "doppler_ratio_covariance", "power_bands", "power_ratio_covariance", "ratio_pairs",
           "tridiagonal"]

COVARIANCES = ("derived", "paper")


@dataclass(frozen=True)
class RatioPairs:
    """Consecutive pairs of samples of one kind, and which neighbouring pairs are linked.

    Parameters
    ----------
    prev, cur : ndarray of int, shape (m,)
        Row indices of each pair's earlier and later sample.
    linked : ndarray of bool, shape (m,)
        True when pair ``j`` and pair ``j + 1`` share a sample (same sensor), i.e. are
        correlated.
    """

    prev: NDArray[np.int64]
    cur: NDArray[np.int64]
    linked: NDArray[np.bool_]


def ratio_pairs(meas: MeasurementSet, kind: str) -> RatioPairs:
    """Form the pairs of consecutive samples of ``kind`` per sensor, in time order.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    kind : str
        The measurement kind (``"power"`` or ``"frequency"``).

    Returns
    -------
    RatioPairs
        The pairs (empty when no sensor has two samples).

    Raises
    ------
    ValueError
        When two samples of one sensor share a time.
    """
    prev, cur, linked = [], [], []
    for s in meas.sensors:
        rows = np.flatnonzero((meas.kind == kind) & (meas.sensor == s))
        if rows.size < 2:
            continue
        rows = rows[np.argsort(meas.time[rows], kind="stable")]
        if np.any(np.diff(meas.time[rows]) <= 0):
            raise ValueError(f"ratio method: {kind} samples of sensor {s!r} must have "
                             "distinct times (pairs are formed from consecutive samples)")
        prev.append(rows[:-1])
        cur.append(rows[1:])
        link = np.ones(rows.size - 1, dtype=bool)
        link[-1] = False
        linked.append(link)
    if not prev:
        empty = np.zeros(0, dtype=np.int64)
        return RatioPairs(empty, empty, np.zeros(0, dtype=bool))
    return RatioPairs(np.concatenate(prev), np.concatenate(cur), np.concatenate(linked))


def tridiagonal(diag: Array, off: Array) -> Array:
    """Build the dense symmetric tri-diagonal matrix of two bands.

    Parameters
    ----------
    diag : ndarray, shape (m,)
        The diagonal.
    off : ndarray, shape (m,)
        ``off[j]`` goes to (j, j+1) and (j+1, j); the last entry is unused.

    Returns
    -------
    ndarray, shape (m, m)
        The matrix (units of ``diag``).
    """
    out = np.diag(diag)
    idx = np.arange(diag.size - 1)
    out[idx, idx + 1] = off[:-1]
    out[idx + 1, idx] = off[:-1]
    return out


def power_bands(mu: Array, r2_prev: Array, r2_cur: Array, s_prev: Array, s_cur: Array,
                linked: NDArray[np.bool_], covariance: str) -> tuple[Array, Array]:
    """Return the diagonal and off-diagonal of the power-ratio covariance.

    Parameters
    ----------
    mu, r2_prev, r2_cur, s_prev, s_cur, linked, covariance
        As for :func:`power_ratio_covariance`.

    Returns
    -------
    diag, off : ndarray, shape (m,)
        The bands (m⁴); ``off`` is 0 where pairs are not linked.

    References
    ----------
    Gu et al. (2007), §4, eq. 21 and the text after eq. 25.
    """
    diag = mu ** 2 * r2_cur ** 2 * s_prev + r2_prev ** 2 * s_cur
    off = np.zeros(mu.size)
    if mu.size > 1:
        # (k, k+1): mu_{k+1} R_{k-1}^2 R_{k+1}^2 s_k, negative when derived.
        off[:-1] = mu[1:] * r2_prev[:-1] * r2_cur[1:] * s_cur[:-1]
    sign = -1.0 if covariance == "derived" else 1.0
    return diag, np.where(linked, sign * off, 0.0)


def doppler_bands(nu: Array, sigma_prev: Array, sigma_cur: Array, linked: NDArray[np.bool_],
                  carrier: float, v_prev: Array | None, v_cur: Array | None,
                  covariance: str) -> tuple[Array, Array]:
    """Return the diagonal and off-diagonal of the Doppler-ratio covariance.

    Parameters
    ----------
    nu, sigma_prev, sigma_cur, linked, carrier, v_prev, v_cur, covariance
        As for :func:`doppler_ratio_covariance`.

    Returns
    -------
    diag, off : ndarray, shape (m,)
        The bands (m²/s²); ``off`` is 0 where pairs are not linked.

    Raises
    ------
    ValueError
        For the paper's covariance without the radial velocities.

    References
    ----------
    Gu et al. (2007), §4, eq. 27 and the text after eq. 32.
    """
    c = SPEED_OF_LIGHT
    scale = (c / carrier) ** 2
    off = np.zeros(nu.size)
    if covariance == "derived":
        diag = sigma_cur ** 2 + nu ** 2 * sigma_prev ** 2
        if nu.size > 1:
            off[:-1] = -nu[1:] * sigma_cur[:-1] ** 2
    else:
        if v_prev is None or v_cur is None:
            raise ValueError("the paper's Doppler covariance needs the radial velocities")
        a_cur, a_prev = (1.0 - v_cur / c) ** 2, (1.0 - v_prev / c) ** 2
        diag = a_cur * sigma_cur ** 2 + nu ** 2 * a_prev * sigma_prev ** 2
        if nu.size > 1:
            off[:-1] = -nu[1:] * a_cur[1:] * sigma_cur[:-1] ** 2  # (1 - v_{k+1}/c)^2
    return scale * diag, np.where(linked, scale * off, 0.0)


def power_ratio_covariance(mu: Array, r2_prev: Array, r2_cur: Array, s_prev: Array,
                           s_cur: Array, linked: NDArray[np.bool_] | None = None,
                           covariance: str = "derived") -> Array:
    """Return the dense covariance of the power-ratio noise terms of consecutive pairs.

    Diagonal ``mu_k^2 R_k^4 s_{k-1} + R_{k-1}^4 s_k``; off-diagonal
    ``-mu_{k+1} R_{k-1}^2 R_{k+1}^2 s_k`` (derived) or the paper's ``+mu_{k+1} ...``.

    Parameters
    ----------
    mu : ndarray, shape (m,)
        The measured power ratios (dimensionless).
    r2_prev, r2_cur : ndarray, shape (m,)
        Squared ranges ``R^2`` of each pair's earlier and later sample (m²).
    s_prev, s_cur : ndarray, shape (m,)
        Their relative noise variances ``1/SNR_p`` (dimensionless).
    linked : ndarray of bool, shape (m,), optional
        Pair j+1's earlier sample is pair j's later one where ``linked[j]``; default one chain.
    covariance : str, optional
        ``"derived"`` (default) or ``"paper"``.

    Returns
    -------
    ndarray, shape (m, m)
        The covariance (m⁴).

    References
    ----------
    Gu et al. (2007), §4, eq. 21 and the text after eq. 25.
    """
    linked = chain(mu.size) if linked is None else linked
    return tridiagonal(*power_bands(mu, r2_prev, r2_cur, s_prev, s_cur, linked, covariance))


def doppler_ratio_covariance(nu: Array, sigma_prev: Array, sigma_cur: Array,
                             linked: NDArray[np.bool_] | None = None,
                             carrier: float = 1.0, v_prev: Array | None = None,
                             v_cur: Array | None = None, covariance: str = "derived") -> Array:
    """Return the dense covariance of the noise terms of ``c h_k`` (eq. 27 times c).

    Derived: ``(c/f_s)^2`` times diagonal ``sigma_k^2 + nu_k^2 sigma_{k-1}^2``, off-diagonal
    ``-nu_{k+1} sigma_k^2``.  Paper: diagonal ``(1 - v_k/c)^2 sigma_k^2 + nu_k^2
    (1 - v_{k-1}/c)^2 sigma_{k-1}^2``, off-diagonal ``-nu_{k+1} (1 - v_{k+1}/c)^2 sigma_k^2``.

    Parameters
    ----------
    nu : ndarray, shape (m,)
        The measured frequency ratios (dimensionless).
    sigma_prev, sigma_cur : ndarray, shape (m,)
        Frequency noise std of each pair's earlier and later sample (Hz).
    linked : ndarray of bool, shape (m,), optional
        Which neighbouring pairs share a sample; default one chain.
    carrier : float, optional
        The carrier f_s (Hz); default 1.
    v_prev, v_cur : ndarray, shape (m,), optional
        Radial velocities (m/s); needed by the paper's covariance.
    covariance : str, optional
        ``"derived"`` (default) or ``"paper"``.

    Returns
    -------
    ndarray, shape (m, m)
        The covariance (m²/s² for ``carrier`` in Hz).

    Raises
    ------
    ValueError
        For the paper's covariance without the radial velocities.

    References
    ----------
    Gu et al. (2007), §4, eq. 27 and the text after eq. 32.
    """
    linked = chain(nu.size) if linked is None else linked
    return tridiagonal(*doppler_bands(nu, sigma_prev, sigma_cur, linked, carrier, v_prev,
                                        v_cur, covariance))


def chain(n: int) -> NDArray[np.bool_]:
    """Return ``linked`` of one chain of ``n`` pairs: each linked to the next, the last not.

    Parameters
    ----------
    n : int
        Number of pairs.

    Returns
    -------
    ndarray of bool, shape (n,)
        True except the last entry.
    """
    linked = np.ones(n, dtype=bool)
    if n:
        linked[-1] = False
    return linked


class Banded:
    """Whitening by a symmetric positive-definite tri-diagonal matrix (banded Cholesky).

    Parameters
    ----------
    diag : ndarray, shape (m,)
        Diagonal of ``Sigma``.
    off : ndarray, shape (m,)
        Its off-diagonal (``off[j]`` at (j, j+1); the last entry unused).

    Raises
    ------
    numpy.linalg.LinAlgError
        When ``Sigma`` is not positive definite.
    """

    def __init__(self, diag: Array, off: Array) -> None:
        ab = np.zeros((2, diag.size))
        ab[0] = diag
        ab[1, :-1] = off[:-1]
        self.diag, self.off = diag, off
        self.factor = cholesky_banded(ab, lower=True)   # raises LinAlgError if not PD

    def whiten(self, x: Array) -> Array:
        """Return ``C^-1 x`` with ``Sigma = C C^T``.

        Parameters
        ----------
        x : ndarray, shape (m,) or (m, k)
            What to whiten.

        Returns
        -------
        ndarray
            ``C^-1 x``, same shape.
        """
        return solve_banded((1, 0), self.factor, x)

    def solve(self, x: Array) -> Array:
        """Return ``Sigma^-1 x``.

        Parameters
        ----------
        x : ndarray, shape (m,) or (m, k)
            The right-hand side.

        Returns
        -------
        ndarray
            ``Sigma^-1 x``, same shape.
        """
        return cho_solve_banded((self.factor, True), x)

    def dense(self) -> Array:
        """Return ``Sigma`` as a dense matrix.

        Returns
        -------
        ndarray, shape (m, m)
            ``Sigma``.
        """
        return tridiagonal(self.diag, self.off)
