"""MeasurementSet: the columnar table of observations that flows from simulation or files
into estimators and filters.

One row per observed value.  Columns follow the measurement-file contract (README,
``docs/file-format.md``): ``time`` (s), ``sensor`` (id), ``kind``, ``value`` and ``sigma`` in the
file unit of the kind (degrees, deg/s, m, m/s, Hz, dBm), the sensor's ENU state at ``time``,
and, for range differences, ``time_ref`` and the sensor state at ``time_ref``.

Values are stored in file units so that files round-trip exactly; :attr:`value_si` and
:attr:`sigma_si` give SI (radians, dBW, ...) for computation.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .measurements import KINDS

SENSOR_STATE_COLUMNS = ("sensor_x", "sensor_y", "sensor_z", "sensor_vx", "sensor_vy",
                        "sensor_vz")
REF_STATE_COLUMNS = tuple(f"ref_{c}" for c in SENSOR_STATE_COLUMNS)


@dataclass(eq=False)
class MeasurementSet:
    """Observations in time order per sensor, with everything needed to predict them.

    Attributes are 1-D arrays of equal length ``n`` (``sensor_state`` and ``ref_sensor_state``
    are ``(n, 6)``).  ``metadata`` holds free text: scenario name, seed, ENU origin, truth.
    """

    time: NDArray[np.float64]
    sensor: NDArray[np.str_]
    kind: NDArray[np.str_]
    value: NDArray[np.float64]
    sigma: NDArray[np.float64]
    sensor_state: NDArray[np.float64]
    time_ref: NDArray[np.float64] = field(default=None)  # type: ignore[assignment]
    ref_sensor_state: NDArray[np.float64] = field(default=None)  # type: ignore[assignment]
    metadata: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float)
        n = self.time.shape[0]
        self.sensor = np.asarray(self.sensor, dtype=str)
        self.kind = np.asarray(self.kind, dtype=str)
        self.value = np.asarray(self.value, dtype=float)
        self.sigma = np.asarray(self.sigma, dtype=float)
        self.sensor_state = np.asarray(self.sensor_state, dtype=float).reshape(n, 6)
        if self.time_ref is None:
            self.time_ref = np.full(n, np.nan)
        self.time_ref = np.asarray(self.time_ref, dtype=float)
        if self.ref_sensor_state is None:
            self.ref_sensor_state = np.full((n, 6), np.nan)
        self.ref_sensor_state = np.asarray(self.ref_sensor_state, dtype=float).reshape(n, 6)
        for name in ("sensor", "kind", "value", "sigma", "time_ref"):
            if getattr(self, name).shape != (n,):
                raise ValueError(f"column {name!r} has {getattr(self, name).shape[0]} rows, "
                                 f"time has {n}")
        unknown = sorted(set(self.kind.tolist()) - set(KINDS))
        if unknown:
            raise ValueError(f"unknown measurement kind(s) {', '.join(unknown)}; expected "
                             f"{', '.join(KINDS)}")
        self.metadata = {str(k): str(v) for k, v in dict(self.metadata).items()}

    # -- size and parts ------------------------------------------------------------------
    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def kinds(self) -> list[str]:
        """Kinds present, in the order of :data:`tmakit.measurements.KINDS`."""
        present = set(self.kind.tolist())  # Python strings: far faster than numpy's
        return [k for k in KINDS if k in present]

    @property
    def sensors(self) -> list[str]:
        """Sensor ids in order of first appearance."""
        _, first = np.unique(self.sensor, return_index=True)
        return [str(s) for s in self.sensor[np.sort(first)]]

    @property
    def dim(self) -> int:
        """3 if any sensor leaves the plane z = 0 or measures elevation, else 2."""
        if "elevation" in set(self.kind):
            return 3
        return 3 if np.any(self.sensor_state[:, 2] != 0) or np.any(
            self.sensor_state[:, 5] != 0) else 2

    def take(self, index: ArrayLike) -> MeasurementSet:
        """The rows at ``index`` (integer indices or a boolean mask), metadata kept."""
        idx = np.asarray(index)
        if idx.ndim != 1:
            raise ValueError(f"index must be 1-D (row indices or a boolean mask); got shape "
                             f"{idx.shape}")
        # Rows of a checked set need no conversion or check: built without __post_init__
        # (solvers take subsets on every call).
        out = object.__new__(MeasurementSet)
        out.time, out.sensor, out.kind = self.time[idx], self.sensor[idx], self.kind[idx]
        out.value, out.sigma = self.value[idx], self.sigma[idx]
        out.sensor_state, out.time_ref = self.sensor_state[idx], self.time_ref[idx]
        out.ref_sensor_state, out.metadata = self.ref_sensor_state[idx], dict(self.metadata)
        return out

    def select(self, kind: str | None = None, sensor: str | None = None) -> MeasurementSet:
        """Rows of one kind and/or one sensor."""
        mask = np.ones(len(self), dtype=bool)
        if kind is not None:
            mask &= self.kind == kind
        if sensor is not None:
            mask &= self.sensor == sensor
        return self.take(mask)

    @staticmethod
    def concatenate(parts: list[MeasurementSet],
                    metadata: Mapping[str, str] | None = None) -> MeasurementSet:
        """Rows of several sets, sorted by sensor (first appearance) then time (stable)."""
        if not parts:
            raise ValueError("nothing to concatenate")
        cat = MeasurementSet(
            np.concatenate([p.time for p in parts]),
            np.concatenate([p.sensor for p in parts]),
            np.concatenate([p.kind for p in parts]),
            np.concatenate([p.value for p in parts]),
            np.concatenate([p.sigma for p in parts]),
            np.concatenate([p.sensor_state for p in parts]),
            np.concatenate([p.time_ref for p in parts]),
            np.concatenate([p.ref_sensor_state for p in parts]),
            dict(metadata if metadata is not None else parts[0].metadata),
        )
        return cat.sorted()

    def sorted(self) -> MeasurementSet:
        """Rows grouped by sensor (in order of first appearance), in time order within each
        sensor, keeping the existing order of simultaneous rows."""
        order_of = {s: i for i, s in enumerate(self.sensors)}
        rank = np.array([order_of[s] for s in self.sensor], dtype=int)
        return self.take(np.lexsort((self.time, rank)))

    # -- SI views ------------------------------------------------------------------------
    def _per_kind(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Per row, the scale and offset from the file unit of its kind to SI."""
        scale = np.ones(len(self))
        offset = np.zeros(len(self))
        for k in self.kinds:
            model = KINDS[k]
            if model.file_scale == 1.0 and model.file_offset == 0.0:
                continue  # already SI (the arrays' initial values)
            sel = self.kind == k
            scale[sel] = model.file_scale
            offset[sel] = model.file_offset
        return scale, offset

    def si(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(value_si, sigma_si)`` in one pass over the kinds."""
        scale, offset = self._per_kind()
        return self.value * scale + offset, self.sigma * scale

    @property
    def value_si(self) -> NDArray[np.float64]:
        """Values in SI (radians, rad/s, m, m/s, Hz, dBW)."""
        scale, offset = self._per_kind()
        return self.value * scale + offset

    @property
    def sigma_si(self) -> NDArray[np.float64]:
        """Noise standard deviations in SI (dB for power)."""
        scale, _ = self._per_kind()
        return self.sigma * scale

    def equals(self, other: MeasurementSet) -> bool:
        """Exact equality of every column and the metadata (NaN equals NaN)."""
        if len(self) != len(other):
            return False
        same = (np.array_equal(self.sensor, other.sensor)
                and np.array_equal(self.kind, other.kind)
                and self.metadata == other.metadata)
        for name in ("time", "value", "sigma", "sensor_state", "time_ref",
                     "ref_sensor_state"):
            same = same and np.array_equal(getattr(self, name), getattr(other, name),
                                           equal_nan=True)
        return bool(same)

    def summary_rows(self) -> list[dict[str, object]]:
        """One row per (sensor, kind): count, time span, value range and median sigma."""
        rows = []
        for s in self.sensors:
            for k in self.kinds:
                sel = (self.sensor == s) & (self.kind == k)
                if not np.any(sel):
                    continue
                rows.append({
                    "sensor": s, "kind": k, "unit": KINDS[k].file_unit,
                    "count": int(sel.sum()),
                    "t_first": float(self.time[sel].min()),
                    "t_last": float(self.time[sel].max()),
                    "value_min": float(self.value[sel].min()),
                    "value_max": float(self.value[sel].max()),
                    "sigma_median": float(np.median(self.sigma[sel])),
                })
        return rows

    def __repr__(self) -> str:
        parts = ", ".join(f"{r['count']} {r['kind']} from {r['sensor']}"
                          for r in self.summary_rows())
        return f"MeasurementSet({len(self)} rows: {parts})"
