"""Radar measurement groups: the radar's rows with its full (range, range-rate) covariance.

What ``RadarModel.group`` would be, were :class:`~tmakit.sensors.RadarModel` not below the
observation layer; used by the filters, the posterior CRB and the planners.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..data import MeasurementSet
from ..measurements import KINDS
from ..sensors.radar import RadarModel
from .groups import MeasurementGroup

__all__ = ["radar_group", "radar_rows"]


def radar_rows(radar: RadarModel, t: float, values: ArrayLike, sensor_state: ArrayLike,
               dim: int = 2, sensor: str = "radar", elevation: float = 0.0) -> MeasurementSet:
    """Return one pulse's measurements as rows of a MeasurementSet (marginal sigmas only).

    Parameters
    ----------
    radar : RadarModel
    t : float
        Pulse time, s.
    values : array_like
        :meth:`RadarModel.kinds` values, SI (rad, m, m/s).
    sensor_state : array_like
        (6,), m and m/s.
    dim : {2, 3}
        3 adds elevation.
    sensor : str
    elevation : float
        The target's elevation, rad (3-D only).

    Returns
    -------
    MeasurementSet
    """
    kinds = radar.kinds(dim)
    m = len(kinds)
    z = np.asarray(values, dtype=float).reshape(m)
    sigma = radar.measurement_sigmas(kinds, elevation)
    scale = np.array([KINDS[k].file_scale for k in kinds])
    state = np.broadcast_to(np.asarray(sensor_state, dtype=float).reshape(6), (m, 6))
    return MeasurementSet(np.full(m, float(t)), np.full(m, sensor), list(kinds), z / scale,
                          sigma / scale, state, check=False)  # noisy: a range may be < 0


def radar_group(radar: RadarModel, t: float, dim: int = 2, *, elevation: float = 0.0,
                values: ArrayLike | None = None, sensor_state: ArrayLike | None = None,
                sensor: str = "radar") -> MeasurementGroup:
    """Return the radar's measurement group at time ``t`` with its full noise covariance.

    Without ``values`` the group is planned (NaN values, for a planner's candidates).

    Parameters
    ----------
    radar : RadarModel
    t : float
        s.
    dim : {2, 3}
    elevation : float
        The target's elevation for the covariance, rad.
    values : array_like, optional
        Measured values (m,), SI.
    sensor_state : array_like, optional
        (6,), m and m/s; needed with ``values``.
    sensor : str

    Returns
    -------
    MeasurementGroup

    Raises
    ------
    ValueError
        With ``values`` but no ``sensor_state``, or where the covariance does not exist.
    """
    kinds = radar.kinds(dim)
    cov = radar.measurement_covariance(kinds, elevation)
    if values is None:
        return MeasurementGroup.planned(kinds, None, t, dim, covariance=cov)
    if sensor_state is None:
        raise ValueError("radar_group: values need the sensor_state they were measured from")
    rows = radar_rows(radar, t, values, sensor_state, dim, sensor, elevation)
    return MeasurementGroup(rows, t, dim, covariance=cov)
