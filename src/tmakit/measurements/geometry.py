"""Relative-state helpers shared by the measurement kinds (shapes checked, ranges, unit vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array


def as_rel(rel: ArrayLike) -> Array:
    """Check and return a relative-state array.

    Parameters
    ----------
    rel : array_like
        Relative states ``(..., 6)``: position in m, velocity in m/s.

    Returns
    -------
    ndarray
        ``rel`` as a float array.

    Raises
    ------
    ValueError
        If the last axis does not have 6 components.
    """
    rel = np.asarray(rel, dtype=float)
    if rel.ndim == 0 or rel.shape[-1] != 6:
        raise ValueError(f"relative states must have 6 components (position, velocity); "
                         f"got shape {rel.shape}")
    return rel


def dot3(a: Array, b: Array) -> Array:
    """Give the row-wise dot product of two arrays (fast for any memory layout).

    Parameters
    ----------
    a, b : ndarray
        ``(..., 3)`` arrays, any units.

    Returns
    -------
    ndarray
        ``(...)``, in the units of ``a`` times those of ``b``.
    """
    return np.einsum("...i,...i->...", a, b)


def inverse_range_and_unit(rel: Array) -> tuple[Array, Array]:
    """Give ``(1 / r, p / r)`` for the relative position ``p = rel[..., :3]``, ``r = |p|``.

    Parameters
    ----------
    rel : ndarray
        Relative states ``(..., 6)``, position in m.

    Returns
    -------
    inv_r : ndarray
        ``(...)``, 1/m.
    unit : ndarray
        ``(..., 3)``, the unit line-of-sight vector (dimensionless).
    """
    p = rel[..., :3]
    inv_r = 1.0 / np.sqrt(dot3(p, p))
    return inv_r, p * inv_r[..., None]


def zeros_nuisance(rel: Array) -> Array:
    """Give a nuisance Jacobian of no columns, for kinds without nuisance parameters.

    Parameters
    ----------
    rel : ndarray
        ``(..., n, 6)`` relative states (m, m/s); only the shape is used.

    Returns
    -------
    ndarray
        Zeros ``(..., n, 0)``.
    """
    return np.zeros((*rel.shape[:-1], 0))
