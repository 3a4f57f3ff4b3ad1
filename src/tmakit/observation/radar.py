"""Radar measurement groups: the radar's rows with its full (range, range-rate) covariance.

:class:`~tmakit.sensors.RadarModel` lives in the sensors layer, below the observation layer,
so it cannot build a :class:`~tmakit.observation.MeasurementGroup` itself; this module does
(what ``RadarModel.group`` would be).  A group made here is used by every filter
(``TrackingFilter.update(group)``), the posterior CRB (``PosteriorInformation.state_information``)
and a planner, with the correlated noise of the LFM pulse kept.
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
    """Return one pulse's measurements as rows of a MeasurementSet.

    The rows carry the marginal sigmas of :meth:`RadarModel.measurement_covariance`; a
    MeasurementSet holds no cross-row covariance (the batch estimators and the CRLB of a set
    see the rows as independent): use :func:`radar_group` for the full covariance.

    Parameters
    ----------
    radar : RadarModel
        The radar.
    t : float
        Time of the pulse, s.
    values : array_like
        :meth:`RadarModel.kinds` ``(dim)`` values in SI (rad, m, m/s), e.g. from
        :meth:`RadarModel.simulate`.
    sensor_state : array_like
        The radar's state ``[x, y, z, vx, vy, vz]`` (6,), m and m/s.
    dim : {2, 3}
        The dimension (3 adds elevation).
    sensor : str
        The sensor id.
    elevation : float
        The target's elevation, rad (the covariance's; 3-D only).

    Returns
    -------
    MeasurementSet
        ``m`` rows at time ``t`` (values and sigmas in file units: deg, m, m/s).
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

    Without ``values`` the group is *planned* (NaN values, zero sensor states to be given to
    ``information``/``jacobian``: a planner's candidates); with ``values`` and
    ``sensor_state`` it holds one pulse's measurements for a filter update.

    Parameters
    ----------
    radar : RadarModel
        The radar.
    t : float
        The filter time (and the pulse's), s.
    dim : {2, 3}
        The filter state's dimension; the kinds are :meth:`RadarModel.kinds` ``(dim)``.
    elevation : float
        The target's elevation for the covariance, rad (3-D: away from 0 for a horizontal
        array, which has no elevation information there).
    values : array_like, optional
        Measured values (m,), SI (rad, m, m/s).
    sensor_state : array_like, optional
        The radar's state (6,), m and m/s; needed with ``values``.
    sensor : str
        The sensor id of the rows.

    Returns
    -------
    MeasurementGroup
        Its ``covariance`` is :meth:`RadarModel.measurement_covariance` (range and range rate
        correlated), its ``noise`` whitens by it and ``information`` is ``H^T R^{-1} H``.

    Raises
    ------
    ValueError
        With ``values`` but no ``sensor_state``, or where the covariance does not exist (see
        :meth:`RadarModel.measurement_covariance`).
    """
    kinds = radar.kinds(dim)
    cov = radar.measurement_covariance(kinds, elevation)
    if values is None:
        return MeasurementGroup.planned(kinds, None, t, dim, covariance=cov)
    if sensor_state is None:
        raise ValueError("radar_group: values need the sensor_state they were measured from")
    rows = radar_rows(radar, t, values, sensor_state, dim, sensor, elevation)
    return MeasurementGroup(rows, t, dim, covariance=cov)
