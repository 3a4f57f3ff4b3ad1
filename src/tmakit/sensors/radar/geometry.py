"""Relative states and the Jacobian of the radar's measurements with respect to the state.

The relation after eq. 4 of Hurtado & Nehorai (2008) in tmakit's kinds: bearing (clockwise
from North), elevation, range and range rate of the target relative to the sensor.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["elevation_of", "measurement_jacobian", "measurements", "relative_states"]

Array = NDArray[np.float64]


def relative_states(target_states: ArrayLike, sensor_states: ArrayLike) -> tuple[Array, int]:
    """Return the relative states target minus sensor and the dimension of the targets.

    Parameters
    ----------
    target_states : array_like, shape (..., 4) or (..., 6)
        ``[x, y, vx, vy]`` (2-D) or ``[x, y, z, vx, vy, vz]`` (m, m/s).
    sensor_states : array_like, shape (..., 6)
        ``[x, y, z, vx, vy, vz]`` (m, m/s); broadcasts with the targets.

    Returns
    -------
    relative : ndarray, shape (..., 6)
        Target minus sensor (m, m/s); a 2-D target at ``z = 0``.
    dim : int
        2 or 3.

    Raises
    ------
    ValueError
        On states of the wrong length.
    """
    x = np.asarray(target_states, dtype=float)
    s = np.asarray(sensor_states, dtype=float)
    if x.ndim == 0 or x.shape[-1] not in (4, 6):
        raise ValueError("target states must have 4 (2-D: x, y, vx, vy) or 6 (3-D) "
                         f"components; got shape {x.shape}")
    if s.ndim == 0 or s.shape[-1] != 6:
        raise ValueError(f"sensor states must have 6 components (x, y, z, vx, vy, vz); got "
                         f"shape {s.shape}")
    dim = x.shape[-1] // 2
    target = np.zeros((*x.shape[:-1], 6))
    target[..., :dim] = x[..., :dim]
    target[..., 3:3 + dim] = x[..., dim:]
    return target - s, dim


def measurement_jacobian(rel: Array, dim: int) -> Array:
    """Return ``d [bearing, (elevation), range, range_rate] / d target state``.

    Parameters
    ----------
    rel : ndarray, shape (..., 6)
        Relative states (:func:`relative_states`), m and m/s.
    dim : int
        2 (no elevation row) or 3.

    Returns
    -------
    ndarray, shape (..., m, 2 dim)
        Rad/m, m/m, (m/s)/m and (m/s)/(m/s).

    References
    ----------
    Hurtado & Nehorai (2008), the chain from the radar parameters to the state (after eq. 4).
    """
    p, v = rel[..., :3], rel[..., 3:]
    r = np.linalg.norm(p, axis=-1)
    unit = p / r[..., None]
    rdot = np.einsum("...i,...i->...", unit, v)
    rho2 = p[..., 0] ** 2 + p[..., 1] ** 2
    rows = []
    d_bearing = np.zeros(rel.shape)
    d_bearing[..., 0], d_bearing[..., 1] = p[..., 1] / rho2, -p[..., 0] / rho2
    rows.append(d_bearing)
    if dim == 3:
        rho = np.sqrt(rho2)
        d_el = np.zeros(rel.shape)
        d_el[..., 0] = -p[..., 2] * p[..., 0] / (rho * r * r)
        d_el[..., 1] = -p[..., 2] * p[..., 1] / (rho * r * r)
        d_el[..., 2] = rho / (r * r)
        rows.append(d_el)
    d_range = np.zeros(rel.shape)
    d_range[..., :3] = unit
    rows.append(d_range)
    d_rdot = np.concatenate([(v - rdot[..., None] * unit) / r[..., None], unit], axis=-1)
    rows.append(d_rdot)
    d6 = np.stack(rows, axis=-2)
    return np.concatenate([d6[..., :dim], d6[..., 3:3 + dim]], axis=-1)



def elevation_of(rel: Array) -> Array:
    """Return the elevation ``atan2(dz, hypot(dx, dy))`` of relative states.

    Parameters
    ----------
    rel : ndarray, shape (..., 6)
        Relative states, m and m/s.

    Returns
    -------
    ndarray, shape (...,)
        Rad.
    """
    return np.arctan2(rel[..., 2], np.hypot(rel[..., 0], rel[..., 1]))


def measurements(rel: Array, dim: int) -> Array:
    """``[bearing, (elevation), range, range_rate]`` of relative states ``(..., 6)``.

    Parameters
    ----------
    rel : ndarray
        Target minus sensor ``(..., 6)``, m and m/s.
    dim : {2, 3}
        Without elevation when 2.

    Returns
    -------
    ndarray
        ``(..., 3)`` or ``(..., 4)``: rad (bearing clockwise from North), rad, m, m/s.
    """
    p, v = rel[..., :3], rel[..., 3:]
    r = np.linalg.norm(p, axis=-1)
    out = [np.arctan2(p[..., 0], p[..., 1])]
    if dim == 3:
        out.append(elevation_of(rel))
    out += [r, np.einsum("...i,...i->...", p, v) / r]
    return np.stack(out, axis=-1)
