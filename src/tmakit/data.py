"""MeasurementSet: the columnar table of observations, from simulation or files to estimators.

One row per observed value (``docs/file-format.md``, :mod:`tmakit.rules`).  SI is stored
(:meth:`MeasurementSet.from_si`); the constructor takes file units (the readers' edge).
``kind`` and ``sensor`` are categorical codes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import rules
from .core.arrays import broadcast, take_rows
from .core.keywords import NOT_GIVEN, NotGiven, renamed_keyword
from .measurements import KINDS
from .measurements import codes as categorical
from .measurements.codes import KIND_CODES, KIND_NAMES

__all__ = ["KIND_CODES", "KIND_NAMES", "MeasurementSet"]

SENSOR_STATE_COLUMNS = rules.STATE_COLUMNS
REF_STATE_COLUMNS = tuple(f"ref_{c}" for c in SENSOR_STATE_COLUMNS)


def _frozen(values: NDArray[np.float64]) -> NDArray[np.float64]:
    values.flags.writeable = False
    return values


class MeasurementSet:
    """Observations in time order per sensor, with everything needed to predict them.

    The constructor takes file units (the readers' edge) and stores SI; library code uses
    :meth:`from_si`.  Arrays are read-only.  :attr:`ambiguous_si` holds a towed array's mirror
    bearing per row (rad, NaN where none), or None.

    Parameters
    ----------
    time : array_like, shape (n,)
        s.
    sensor, kind : array_like of str, shape (n,)
        Sensor ids; keys of :data:`tmakit.measurements.KINDS`.
    value_file, sigma_file : array_like, shape (n,)
        Value and noise std in the kind's file unit (deg, deg/s, m, m/s, Hz, dBm; dB).
    sensor_state : array_like, shape (n, 6)
        Sensor ENU position (m) and velocity (m/s) at ``time``.
    time_ref : array_like, shape (n,), optional
        Earlier sample time of a range difference, s; NaN elsewhere.
    ref_sensor_state : array_like, shape (n, 6), optional
        Sensor state at ``time_ref``; NaN where unused.
    metadata : mapping of str to str, optional
        Scenario name, seed, ENU origin, truth, ...
    check : bool, optional
        Refuse what the file reader refuses (:mod:`tmakit.rules`; default).
    value, sigma : array_like, optional
        Deprecated names of ``value_file`` and ``sigma_file``.

    Raises
    ------
    ValueError
        A column's length differs from ``time``'s, a kind is unknown, or a rule fails.
    TypeError
        A required column is missing.
    """

    #: Each row's ambiguous twin bearing (rad, NaN where none), or None: no row has one.
    ambiguous_si: NDArray[np.float64] | None = None
    #: Each frequency row's tonal label ("" elsewhere), or None: one tonal (:meth:`with_tonal`).
    tonal: NDArray[np.str_] | None = None

    def __init__(self, time: ArrayLike, sensor: ArrayLike, kind: ArrayLike,
                 value_file: ArrayLike | None = None, sigma_file: ArrayLike | None = None,
                 sensor_state: ArrayLike | None = None, time_ref: ArrayLike | None = None,
                 ref_sensor_state: ArrayLike | None = None,
                 metadata: Mapping[str, str] | None = None, check: bool = True, *,
                 value: ArrayLike | NotGiven = NOT_GIVEN,
                 sigma: ArrayLike | NotGiven = NOT_GIVEN) -> None:
        value_file = renamed_keyword("MeasurementSet", "value", value, "value_file", value_file,
                                     None)
        sigma_file = renamed_keyword("MeasurementSet", "sigma", sigma, "sigma_file", sigma_file,
                                     None)
        if value_file is None or sigma_file is None or sensor_state is None:
            raise TypeError("MeasurementSet() needs value_file, sigma_file and sensor_state")
        self.time = np.asarray(time, dtype=float)
        n = self.time.shape[0]
        sensor_text = np.asarray(sensor, dtype=str)
        kind_text = np.asarray(kind, dtype=str)
        value_array = np.array(value_file, dtype=np.float64)
        sigma_array = np.array(sigma_file, dtype=np.float64)
        self.sensor_state = np.asarray(sensor_state, dtype=float).reshape(n, 6)
        nan = np.broadcast_to(np.nan, (n, 6))  # absent references: no memory per row
        self.time_ref = nan[:, 0] if time_ref is None else np.asarray(time_ref, dtype=float)
        self.ref_sensor_state = (nan if ref_sensor_state is None
                                 else np.asarray(ref_sensor_state, dtype=float).reshape(n, 6))
        for name, col in (("sensor", sensor_text), ("kind", kind_text), ("value", value_array),
                          ("sigma", sigma_array), ("time_ref", self.time_ref)):
            if col.shape != (n,):
                raise ValueError(f"column {name!r} has {col.shape[0]} rows, time has {n}")
        self.metadata = {str(k): str(v) for k, v in dict(metadata or {}).items()}
        self._set_kinds(kind_text)
        self._set_sensors(sensor_text)
        self._set_file_values(value_array, sigma_array)
        if check:  # the rules of the file reader (tmakit.rules), with its messages
            rules.check_set(self)

    @classmethod
    def from_si(cls, time: ArrayLike, sensor: ArrayLike, kind: ArrayLike, value_si: ArrayLike,
                sigma_si: ArrayLike, sensor_state: ArrayLike, time_ref: ArrayLike | None = None,
                ref_sensor_state: ArrayLike | None = None,
                metadata: Mapping[str, str] | None = None, check: bool = True,
                tonal: ArrayLike | None = None) -> MeasurementSet:
        """Build a set from SI values (how library code builds sets).

        Parameters
        ----------
        time, sensor, kind, sensor_state, time_ref, ref_sensor_state, metadata, check
            As for :class:`MeasurementSet`.
        value_si, sigma_si : array_like, shape (n,)
            Values and noise std in SI (rad, rad/s, m, m/s, Hz, dBW; dB).
        tonal : array_like of str, shape (n,), optional
            Each frequency row's tonal label (:meth:`with_tonal`).

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            As :class:`MeasurementSet`.
        """
        n = np.shape(time)[0] if np.ndim(time) else 0
        out = cls(time, sensor, kind, np.zeros(n), np.zeros(n), sensor_state, time_ref,
                  ref_sensor_state, metadata, check=False)
        out._set_si_values(out._new_column("value", value_si),
                           out._new_column("sigma", sigma_si))
        if tonal is not None:
            out = out.with_tonal(tonal)
        if check:  # the file's rules: build out-of-order rows with check=False, then sort
            rules.check_set(out)
        return out

    @classmethod
    def _of_codes(cls, time: NDArray[np.float64], sensor_code: NDArray[np.int32],
                  sensor_names: tuple[str, ...], kind_code: NDArray[np.int8],
                  value_si: NDArray[np.float64], sigma_si: NDArray[np.float64],
                  sensor_state: NDArray[np.float64], time_ref: NDArray[np.float64] | None,
                  ref_sensor_state: NDArray[np.float64] | None, metadata: Mapping[str, str]
                  ) -> MeasurementSet:
        """Build a set of the library's own columns (codes, SI; owned arrays): nothing checked."""
        out = object.__new__(cls)
        n = time.shape[0]
        nan = np.broadcast_to(np.nan, (n, 6))  # absent references: no memory per row
        out.time, out.sensor_code, out.sensor_names = time, sensor_code, sensor_names
        out.kind_code, out.sensor_state = kind_code, sensor_state.reshape(n, 6)
        out.time_ref = nan[:, 0] if time_ref is None else time_ref
        out.ref_sensor_state = nan if ref_sensor_state is None else ref_sensor_state.reshape(n, 6)
        out.metadata = {str(k): str(v) for k, v in metadata.items()}
        out._value = out._sigma = None
        out._value_si, out._sigma_si = _frozen(value_si), _frozen(sigma_si)
        out._kind = out._sensor = out._kinds = out._sensors = None
        return out

    def _set_file_values(self, value: NDArray[np.float64] | None,
                         sigma: NDArray[np.float64] | None) -> None:
        """Store new file-unit values and/or sigmas (owned arrays) and their SI twins."""
        scale = categorical.FILE_SCALE[self.kind_code]
        self._value: NDArray[np.float64] | None
        self._sigma: NDArray[np.float64] | None
        if value is not None:
            self._value = _frozen(value)
            self._value_si = _frozen(value * scale + categorical.FILE_OFFSET[self.kind_code])
        if sigma is not None:
            self._sigma = _frozen(sigma)
            self._sigma_si = _frozen(sigma * scale)

    def _set_si_values(self, value_si: NDArray[np.float64] | None,
                       sigma_si: NDArray[np.float64] | None) -> None:
        """Store new SI values and/or sigmas (owned arrays); file units follow on first use."""
        if value_si is not None:
            self._value_si, self._value = _frozen(value_si), None
        if sigma_si is not None:
            self._sigma_si, self._sigma = _frozen(sigma_si), None

    def _set_kinds(self, text: NDArray[np.str_]) -> None:
        """Store the kind codes of a text column (the SI values are the caller's job)."""
        self.kind_code = categorical.kind_codes(text)
        self._kind: NDArray[np.str_] | None = None
        self._kinds: tuple[str, ...] | None = None

    def _set_sensors(self, text: NDArray[np.str_]) -> None:
        """Store the sensor codes and names of a text column."""
        names, codes = categorical.first_appearance(text)
        self.sensor_code = codes.astype(np.int32)
        self.sensor_names: tuple[str, ...] = tuple(names.tolist())
        self._sensor: NDArray[np.str_] | None = None
        self._sensors: tuple[str, ...] | None = self.sensor_names

    def _new_column(self, name: str, values: ArrayLike, dtype: type = float) -> NDArray[Any]:
        """Return a column of this set's length (a copy), or raise ``ValueError``."""
        out: NDArray[Any] = np.array(values, dtype=dtype)
        if out.shape != (len(self),):
            raise ValueError(f"column {name!r} has {out.shape[0] if out.ndim else 0} rows, "
                             f"time has {len(self)}")
        return out

    @property
    def value(self) -> NDArray[np.float64]:
        """Measured values in the file unit of each row's kind (read-only)."""
        if self._value is None:
            self._value = _frozen((self._value_si - categorical.FILE_OFFSET[self.kind_code])
                                  / categorical.FILE_SCALE[self.kind_code])
        return self._value

    @value.setter
    def value(self, values: ArrayLike) -> None:
        self._set_file_values(self._new_column("value", values), None)

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Noise standard deviations in the file unit of ``value`` (dB for power); read-only."""
        if self._sigma is None:
            self._sigma = _frozen(self._sigma_si / categorical.FILE_SCALE[self.kind_code])
        return self._sigma

    @sigma.setter
    def sigma(self, values: ArrayLike) -> None:
        self._set_file_values(None, self._new_column("sigma", values))

    @property
    def value_si(self) -> NDArray[np.float64]:
        """Values in SI (radians, rad/s, m, m/s, Hz, dBW); read-only, the stored form."""
        return self._value_si

    @value_si.setter
    def value_si(self, values: ArrayLike) -> None:
        self._set_si_values(self._new_column("value_si", values), None)

    @property
    def sigma_si(self) -> NDArray[np.float64]:
        """Noise standard deviations in SI (dB for power); read-only, computed once."""
        return self._sigma_si

    @property
    def kind(self) -> NDArray[np.str_]:
        """Each row's kind as text (built from :attr:`kind_code` on first use, then kept)."""
        if self._kind is None:
            # as narrow as the longest kind present (string comparisons cost by width)
            width = max((len(k) for k in self.kinds), default=1)
            self._kind = categorical.kind_table(width)[self.kind_code]
        return self._kind

    @kind.setter
    def kind(self, kinds: ArrayLike) -> None:
        value, sigma = np.array(self.value), np.array(self.sigma)
        self._set_kinds(self._new_column("kind", kinds, str))
        self._set_file_values(value, sigma)

    @property
    def sensor(self) -> NDArray[np.str_]:
        """Each row's sensor id as text (built from :attr:`sensor_code` on first use)."""
        if self._sensor is None:
            self._sensor = np.array(self.sensor_names, dtype=str)[self.sensor_code]
        return self._sensor

    @sensor.setter
    def sensor(self, sensors: ArrayLike) -> None:
        self._set_sensors(self._new_column("sensor", sensors, str))

    def kind_mask(self, kind: str) -> NDArray[np.bool_]:
        """Mark the rows of ``kind``.

        Parameters
        ----------
        kind : str

        Returns
        -------
        ndarray of bool, shape (n,)
        """
        code = KIND_CODES.get(kind)
        if code is None:
            return np.zeros(len(self), dtype=bool)
        return cast(NDArray[np.bool_], self.kind_code == code)

    def sensor_mask(self, sensor: str) -> NDArray[np.bool_]:
        """Mark the rows of the sensor ``sensor``.

        Parameters
        ----------
        sensor : str

        Returns
        -------
        ndarray of bool, shape (n,)
        """
        try:
            code = self.sensor_names.index(sensor)
        except ValueError:
            return np.zeros(len(self), dtype=bool)
        return cast(NDArray[np.bool_], self.sensor_code == code)

    def __len__(self) -> int:
        """Return the number of rows."""
        return int(self.time.shape[0])

    @property
    def kinds(self) -> list[str]:
        """Kinds present, in the order of :data:`tmakit.measurements.KINDS` (computed once)."""
        if self._kinds is None:
            present = np.bincount(self.kind_code, minlength=len(KIND_NAMES)) > 0
            self._kinds = tuple(k for k, p in zip(KIND_NAMES, present, strict=True) if p)
        return list(self._kinds)

    @property
    def sensors(self) -> list[str]:
        """Sensor ids in order of first appearance (computed once)."""
        if self._sensors is None:
            codes, _ = categorical.first_appearance(self.sensor_code)
            self._sensors = tuple(self.sensor_names[c] for c in codes.tolist())
        return list(self._sensors)

    def kind_flag(self, hook: str) -> NDArray[np.bool_]:
        """Mark the rows whose kind sets the boolean hook ``hook`` (of a ``MeasurementModel``).

        Parameters
        ----------
        hook : str

        Returns
        -------
        ndarray of bool, shape (n,)
        """
        return categorical.kind_flags(hook)[self.kind_code]

    @property
    def dim(self) -> int:
        """3 if any sensor leaves the plane z = 0 or a kind gives height (elevation), else 2."""
        return 3 if any(KINDS[k].gives_height for k in self.kinds) or np.any(
            self.sensor_state[:, 2] != 0) or np.any(self.sensor_state[:, 5] != 0) else 2

    def mirror_plane(self, tol: float = 1e-6) -> float | None:
        """Find the horizontal plane every row's prediction is mirror-symmetric about.

        Parameters
        ----------
        tol : float
            Spread of the sensors' heights allowed, relative to ``max(1 m, |z|)``, and of
            their vertical speeds (m/s).

        Returns
        -------
        float or None
            The plane's height (m); None if a kind is not mirror-symmetric or the sensors
            (reference sensors included) are not level and still in height.
        """
        if len(self) == 0 or not np.all(self.kind_flag("mirror_symmetric")):
            return None
        st = np.concatenate([self.sensor_state,
                             self.ref_sensor_state[self.kind_flag("uses_reference")]])
        z, vz = st[:, 2], st[:, 5]
        if not (np.all(np.isfinite(st[:, [2, 5]])) and np.all(np.abs(vz) <= tol)
                and np.ptp(z) <= tol * max(1.0, float(np.abs(z).max()))):
            return None
        return 0.5 * (float(z.min()) + float(z.max()))

    def take(self, index: ArrayLike) -> MeasurementSet:
        """Return the rows at ``index`` (indices or a mask), metadata kept, nothing checked again.

        Parameters
        ----------
        index : array_like

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            If ``index`` is not 1-D.
        """
        idx = np.asarray(index)
        if idx.ndim != 1:
            raise ValueError(f"index must be 1-D (row indices or a boolean mask), not {idx.shape}")
        out = object.__new__(MeasurementSet)
        out.time, out.kind_code = self.time[idx], self.kind_code[idx]
        out.sensor_code, out.sensor_names = self.sensor_code[idx], self.sensor_names
        out._value = None if self._value is None else _frozen(self._value[idx])
        out._sigma = None if self._sigma is None else _frozen(self._sigma[idx])
        out._value_si, out._sigma_si = _frozen(self._value_si[idx]), _frozen(self._sigma_si[idx])
        ix = np.flatnonzero(idx) if idx.dtype == bool else idx  # np.take: faster than [ix]
        out.time_ref, out.metadata = take_rows(self.time_ref, ix), dict(self.metadata)
        out.sensor_state = np.take(self.sensor_state, ix, 0)
        out.ref_sensor_state = take_rows(self.ref_sensor_state, ix)
        out._kind = out._sensor = out._kinds = out._sensors = None
        if self.ambiguous_si is not None:
            out.ambiguous_si = _frozen(self.ambiguous_si[idx])
        if self.tonal is not None:
            out.tonal = self.tonal[idx]
        return out

    def with_tonal(self, labels: ArrayLike | None) -> MeasurementSet:
        """Return the set with each frequency row's tonal label (one unknown carrier each).

        Parameters
        ----------
        labels : array_like of str, shape (n,), or None
            The tonal of each frequency row ("" on other rows); None removes them.

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            A wrong length, or a label missing on a frequency row or given on another row.
        """
        out = self.take(np.arange(len(self)))
        text = None if labels is None else np.array(labels, dtype=str).reshape(-1)
        if text is not None:
            if text.shape != (len(self),):
                raise ValueError(f"tonal labels: {text.size} labels for {len(self)} rows")
            if np.any((text != "") != self.kind_mask("frequency")):
                raise ValueError("tonal labels: expected a label on every frequency row and on "
                                 "no other row")
            text.flags.writeable = False
        out.tonal = text
        return out

    def stream_code(self) -> NDArray[np.int64]:
        """Give each row's sensor code, told apart by tonal (the rule of one value per time).

        Returns
        -------
        ndarray of int, shape (n,)
        """
        if self.tonal is None:
            return self.sensor_code.astype(np.int64)
        _, tonal_code = np.unique(self.tonal, return_inverse=True)
        return self.sensor_code + tonal_code.reshape(-1) * (int(self.sensor_code.max()) + 1)

    def with_ambiguous(self, ambiguous_si: ArrayLike | None) -> MeasurementSet:
        """Return the set with each bearing row's ambiguous twin bearing (a towed array's).

        Parameters
        ----------
        ambiguous_si : array_like, shape (n,), or None
            The second bearing per row, rad (NaN where none); None removes them.

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            A wrong length, a value on a row that is no bearing, or an infinite value.
        """
        out = self.take(np.arange(len(self)))
        if ambiguous_si is None:
            out.ambiguous_si = None
            return out
        values = np.array(ambiguous_si, dtype=float).reshape(-1)
        if values.shape != (len(self),):
            raise ValueError(f"ambiguous bearings: {values.size} values for {len(self)} rows")
        given = ~np.isnan(values)
        if np.any(given & ~self.kind_mask("bearing")):
            raise ValueError("ambiguous bearings are given on rows that are not bearings")
        if np.any(np.isinf(values)):
            raise ValueError("ambiguous bearings: expected finite angles (rad) or NaN")
        out.ambiguous_si = _frozen(values) if given.any() else None
        return out

    def select(self, kind: str | None = None, sensor: str | None = None) -> MeasurementSet:
        """Return the rows of one kind and/or one sensor (None keeps all).

        Parameters
        ----------
        kind, sensor : str, optional

        Returns
        -------
        MeasurementSet
        """
        mask = np.ones(len(self), dtype=bool)
        if kind is not None:
            mask &= self.kind_mask(kind)
        if sensor is not None:
            mask &= self.sensor_mask(sensor)
        return self.take(mask)

    @staticmethod
    def concatenate(parts: list[MeasurementSet],
                    metadata: Mapping[str, str] | None = None) -> MeasurementSet:
        """Join the rows of several sets, sorted by sensor (first appearance) then time.

        Parameters
        ----------
        parts : list of MeasurementSet
        metadata : mapping of str to str, optional
            Default that of ``parts[0]``.

        Returns
        -------
        MeasurementSet

        Raises
        ------
        ValueError
            If ``parts`` is empty.
        """
        if not parts:
            raise ValueError("nothing to concatenate")
        refs = not all(broadcast(p.time_ref) and broadcast(p.ref_sensor_state) for p in parts)
        names: dict[str, int] = {}  # the sensors in order of first appearance in the rows
        codes = []
        for p in parts:
            rank = np.zeros(len(p.sensor_names), dtype=np.int32)
            for name in p.sensors:
                rank[p.sensor_names.index(name)] = names.setdefault(name, len(names))
            codes.append(rank[p.sensor_code])
        cat = MeasurementSet._of_codes(  # checked parts; in order once sorted
            np.concatenate([p.time for p in parts]), np.concatenate(codes), tuple(names),
            np.concatenate([p.kind_code for p in parts]),
            np.concatenate([p.value_si for p in parts]),
            np.concatenate([p.sigma_si for p in parts]),
            np.concatenate([p.sensor_state for p in parts]),
            np.concatenate([p.time_ref for p in parts]) if refs else None,
            np.concatenate([p.ref_sensor_state for p in parts]) if refs else None,
            metadata if metadata is not None else parts[0].metadata)
        if all(p._value is not None for p in parts):  # keep a file's numbers exactly
            cat._value = _frozen(np.concatenate([p.value for p in parts]))
        if all(p._sigma is not None for p in parts):
            cat._sigma = _frozen(np.concatenate([p.sigma for p in parts]))
        if any(p.ambiguous_si is not None for p in parts):
            cat.ambiguous_si = _frozen(np.concatenate([
                np.full(len(p), np.nan) if p.ambiguous_si is None else p.ambiguous_si
                for p in parts]))
        if any(p.tonal is not None for p in parts):
            cat = cat.with_tonal(np.concatenate([
                np.where(p.kind_mask("frequency"), "frequency", "") if p.tonal is None
                else p.tonal for p in parts]))
        return cat.sorted()

    def sorted(self) -> MeasurementSet:
        """Rows grouped by sensor (first appearance), in stable time order within each.

        Returns
        -------
        MeasurementSet
        """
        rank_of_code = np.zeros(len(self.sensor_names), dtype=np.intp)
        for rank, name in enumerate(self.sensors):
            rank_of_code[self.sensor_names.index(name)] = rank
        return self.take(np.lexsort((self.time, rank_of_code[self.sensor_code])))

    def equals(self, other: MeasurementSet) -> bool:
        """Test exact equality of every column and the metadata (NaN equals NaN).

        Parameters
        ----------
        other : MeasurementSet

        Returns
        -------
        bool
        """
        if len(self) != len(other) or self.metadata != other.metadata:
            return False
        for name in ("kind_code", "sensor", "tonal", "time", "value", "sigma", "sensor_state",
                     "time_ref", "ref_sensor_state", "ambiguous_si"):
            mine, theirs = getattr(self, name), getattr(other, name)
            if (mine is None) != (theirs is None) or (mine is not None and not np.array_equal(
                    mine, theirs, equal_nan=mine.dtype.kind == "f")):
                return False
        return True

    def summary_rows(self) -> list[dict[str, object]]:
        """Summarise the set: one row per (sensor, kind).

        Returns
        -------
        list of dict
            ``sensor``, ``kind``, ``unit``, ``count``, ``t_first``, ``t_last`` (s),
            ``value_min``, ``value_max``, ``sigma_median`` (file unit).
        """
        rows = []
        for s in self.sensors:
            of_sensor = self.sensor_mask(s)
            for k in self.kinds:
                sel = of_sensor & self.kind_mask(k)
                if not np.any(sel):
                    continue
                t, v = self.time[sel], self.value[sel]
                rows.append({"sensor": s, "kind": k, "unit": KINDS[k].file_unit,
                             "count": int(sel.sum()), "t_first": float(t.min()),
                             "t_last": float(t.max()), "value_min": float(v.min()),
                             "value_max": float(v.max()),
                             "sigma_median": float(np.median(self.sigma[sel]))})
        return rows

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickle, keeping the value arrays read-only."""
        self.__dict__.update(state)
        for name in ("_value", "_sigma", "_value_si", "_sigma_si"):
            if state[name] is not None:
                state[name].flags.writeable = False

    def __repr__(self) -> str:
        """Return ``MeasurementSet(n rows: count kind from sensor, ...)``."""
        parts = ", ".join(f"{r['count']} {r['kind']} from {r['sensor']}"
                          for r in self.summary_rows())
        return f"MeasurementSet({len(self)} rows: {parts})"
