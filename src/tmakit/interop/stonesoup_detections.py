"""Measurement sets to and from Stone Soup detections (see :mod:`tmakit.interop.stonesoup`)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from stonesoup.models.measurement import nonlinear as ss
from stonesoup.types.array import StateVector
from stonesoup.types.detection import Detection

from ..data import MeasurementSet
from ..observation.groups import group_times
from .stonesoup_models import EPOCH, TmakitMeasurementModel

__all__ = ["NATIVE_MODELS", "detection_feed", "from_detections", "to_detections"]

#: Stone Soup's own measurement models read by :func:`from_detections`: the tmakit kind of
#: each component of their measurement vector.
NATIVE_MODELS: dict[type, tuple[str, ...]] = {
    ss.Cartesian2DToBearing: ("bearing",),
    ss.CartesianToBearingRange: ("bearing", "range"),
    ss.CartesianToElevationBearing: ("elevation", "bearing"),
    ss.CartesianToElevationBearingRange: ("elevation", "bearing", "range"),
}


def to_detections(meas: MeasurementSet, dim: int | None = None, *,
                  epoch: dt.datetime = EPOCH, per_sensor: bool = False,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None,
                  ndim_state: int | None = None, mapping: Sequence[int] | None = None,
                  velocity_mapping: Sequence[int] | None = None) -> list[Detection]:
    """Turn a measurement set into Stone Soup detections, in time order."""
    dim = int(meas.dim if dim is None else dim)
    out = []
    for index in group_times(meas):
        rows = meas.take(index)
        parts = ([rows.take(np.flatnonzero(rows.sensor == s)) for s in rows.sensors]
                 if per_sensor else [rows])
        for part in parts:
            model = TmakitMeasurementModel.from_rows(part, dim, ndim_state, mapping,
                                                     velocity_mapping, options, nuisance)
            value = model.typed_vector() + part.value_si[:, None]
            out.append(Detection(StateVector(value),
                                 timestamp=epoch + dt.timedelta(seconds=float(part.time[0])),
                                 measurement_model=model,
                                 metadata={"sensor": ",".join(part.sensors),
                                           "kinds": ",".join(part.kinds)}))
    return out


def detection_feed(detections: Iterable[Detection]) -> list[tuple[dt.datetime, set[Detection]]]:
    """Group detections by timestamp for a Stone Soup tracker's ``detector``."""
    by_time: dict[dt.datetime, set[Detection]] = {}
    for d in detections:
        by_time.setdefault(d.timestamp, set()).add(d)
    return sorted(by_time.items(), key=lambda item: item[0])


def from_detections(detections: Iterable[Detection], *, epoch: dt.datetime = EPOCH,
                    sensor: str = "stonesoup",
                    metadata: Mapping[str, str] | None = None) -> MeasurementSet:
    """Turn Stone Soup detections into a measurement set."""
    parts = []
    ordered = sorted(detections, key=lambda d: d.timestamp)
    for i, d in enumerate(ordered):
        t = (d.timestamp - epoch).total_seconds()
        z = np.asarray(d.state_vector, dtype=float)[:, 0]
        model = d.measurement_model
        if isinstance(model, TmakitMeasurementModel):
            rows = model.group.rows
            shift = t - float(rows.time[0])
            parts.append(MeasurementSet.from_si(rows.time + shift, rows.sensor, rows.kind, z,
                                                rows.sigma_si, rows.sensor_state,
                                                rows.time_ref + shift, rows.ref_sensor_state))
        else:
            parts.append(_native_rows(i, d, model, t, z, sensor))
    if not parts:
        raise ValueError("no detections to convert")
    return MeasurementSet.concatenate(parts, dict(metadata or {}))


def _native_rows(i: int, d: Detection, model: object, t: float, z: np.ndarray,
                 sensor: str) -> MeasurementSet:
    """Return the rows of a detection made with one of Stone Soup's own models."""
    kinds = NATIVE_MODELS.get(type(model))
    where = f"detection {i} (t = {t:g} s)"
    if kinds is None:
        raise ValueError(f"{where}: its measurement model {type(model).__name__} is not one "
                         "tmakit reads (TmakitMeasurementModel or "
                         f"{', '.join(c.__name__ for c in NATIVE_MODELS)})")
    if np.any(np.asarray(model.rotation_offset, dtype=np.float64) != 0.0):  # type: ignore[attr-defined]
        raise ValueError(f"{where}: a rotation_offset is not supported; rotate the sensor "
                         "frame into East-North-Up first")
    cov = np.asarray(model.covar(), dtype=np.float64)  # type: ignore[attr-defined]
    if np.any(cov != np.diag(np.diag(cov))):
        raise ValueError(f"{where}: correlated measurement noise is not supported "
                         "(tmakit's rows have independent sigmas)")
    values = z.copy()
    for k, kind in enumerate(kinds):
        if kind == "bearing":  # counter-clockwise from East -> clockwise from North
            values[k] = np.angle(np.exp(1j * (0.5 * np.pi - z[k])))
    offset = np.asarray(model.translation_offset, dtype=np.float64).ravel()  # type: ignore[attr-defined]
    state = np.zeros(6)
    state[:offset.size] = offset
    n = len(kinds)
    return MeasurementSet.from_si(np.full(n, t), [str(d.metadata.get("sensor", sensor))] * n,
                                  list(kinds), values, np.sqrt(np.diag(cov)),
                                  np.tile(state, (n, 1)))
