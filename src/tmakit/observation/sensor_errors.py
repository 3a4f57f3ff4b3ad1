"""Sensor positions known to a covariance: the rows' noise with the navigation error folded in.

Rows sharing a reported sensor position share its error, so the noise is
``R + H_b Q_b H_b'`` (Ho, Lu & Kovavisaruch (2007): their CRLB with sensor position errors).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from .model import ObservationModel
from .noise import NoiseModel

__all__ = ["MAX_ROWS", "effective_noise", "sensor_error_design"]

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
