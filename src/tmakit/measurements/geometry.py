"""Relative-state helpers shared by the measurement kinds (shapes checked, ranges, unit vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array


def as_rel(rel: ArrayLike) -> Array:
    """Check and return a relative-state array."""
    rel = np.asarray(rel, dtype=float)
    if rel.ndim == 0 or rel.shape[-1] != 6:
        raise ValueError(f"relative states must have 6 components (position, velocity); "
                         f"got shape {rel.shape}")
    return rel


def dot3(a: Array, b: Array) -> Array:
    """Give the row-wise dot product of two arrays (fast for any memory layout)."""
    return np.einsum("...i,...i->...", a, b)


def inverse_range_and_unit(rel: Array) -> tuple[Array, Array]:
    """Give ``(1 / r, p / r)`` for the relative position ``p = rel[..., :3]``, ``r = |p|``."""
    p = rel[..., :3]
    inv_r = 1.0 / np.sqrt(dot3(p, p))
    return inv_r, p * inv_r[..., None]


def zeros_nuisance(rel: Array) -> Array:
    """Give a nuisance Jacobian of no columns, for kinds without nuisance parameters."""
    return np.zeros((*rel.shape[:-1], 0))
