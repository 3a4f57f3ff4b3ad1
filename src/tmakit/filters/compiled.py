"""A measurement set prepared once for a filter run.

:meth:`TrackingFilter.run <tmakit.filters.TrackingFilter.run>` updates once per distinct
measurement time.  Cutting the :class:`~tmakit.data.MeasurementSet` into one small set per
update (``take``) and building a :class:`~tmakit.observation.MeasurementGroup` from it costs
more than the arithmetic of a filter step, so the set is compiled once, vectorised: rows sorted
by time, the update boundaries, SI values and sigmas, the measurement models of the kinds
present and their (known) nuisance vectors.  A step then takes slices (views) of these arrays
(:meth:`CompiledMeasurements.group`).

When every update is a single bearing at its own time, the filters use closed-form step
kernels (:mod:`.kernels`) on the plain arrays :attr:`CompiledMeasurements.bearing_columns`:
the specialised path, tested equal to the general one.
"""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arrays import Array
from ..data import KIND_CODES, MeasurementSet
from ..measurements import MeasurementModel
from ..observation import MeasurementGroup, RowLayout, resolve_models, time_blocks


@dataclass(frozen=True)
class BearingColumns:
    """The columns a bearing-only step kernel needs, one entry per update.

    Attributes
    ----------
    time : ndarray
        Update times (K,), s.
    value : ndarray
        Bearings (K,), rad, clockwise from North.
    variance : ndarray
        Bearing variances (K,), rad^2.
    sx, sy : ndarray
        Sensor position (K,), m, ENU.
    """

    time: Array
    value: Array
    variance: Array
    sx: Array
    sy: Array


class CompiledMeasurements:
    """A measurement set prepared once for a filter run.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements (SI columns are taken from it).
    dim : int
        Filter dimension, 2 or 3.
    options : mapping, optional
        Per-kind model options (``{"frequency": {"drift": True}}``).
    nuisance : mapping, optional
        Known nuisance values by name (Hz, dB, ...).

    Raises
    ------
    ValueError
        The same clear errors as :class:`~tmakit.observation.MeasurementGroup` (e.g. a
        missing nuisance value), once, up front.
    """

    def __init__(self, meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        self.meas = meas
        self.dim = int(dim)
        n = len(meas)
        # The same grouping as tmakit.observation.group_times: one update per time.
        order, self.bounds = time_blocks(meas.time)
        t = meas.time[order]
        self.order = order
        #: Update times (s): the last (latest) row time of each update, as ``run`` uses.
        self.times = t[self.bounds[1:] - 1] if n else np.zeros(0)
        self.models: dict[str, MeasurementModel]
        self.nuisance: dict[str, Array]
        self.models, self.nuisance = resolve_models(meas.kinds, options, nuisance)
        self.kind = meas.kind[order]
        self.values = meas.value_si[order]
        self.sigmas = meas.sigma_si[order]
        self.time = t
        self.time_ref = meas.time_ref[order]
        self.sensor_state = meas.sensor_state[order]
        self.ref_sensor_state = meas.ref_sensor_state[order]
        self.sensor = meas.sensor[order]
        self._kind_codes = {k: i for i, k in enumerate(self.models)}
        # The set's kind codes (data.KIND_CODES) mapped to this file's model order: no per-row
        # Python.
        lookup = np.full(len(KIND_CODES), -1, dtype=np.int64)
        for k, i in self._kind_codes.items():
            lookup[KIND_CODES[k]] = i
        self._codes = lookup[meas.kind_code[order]] if n else np.zeros(0, dtype=np.int64)
        self._lists: tuple[list[float], ...] | None = None
        #: What the filters derive from the set once per run (e.g. the general path's plan).
        self.cache: dict[str, object] = {}
        #: Per pattern of kinds in an update (its kind codes): models, index, nuisance and
        #: row layout, made once and shared by the updates with that pattern.
        self._layouts: dict[bytes, tuple[dict, dict, dict, RowLayout]] = {}
        sizes = np.diff(self.bounds)
        #: Every update is one bearing row (the closed-form kernels apply).
        self.single_bearing = bool(n > 0 and np.all(sizes == 1)
                                   and set(self.models) == {"bearing"})

    @property
    def model_index(self) -> NDArray[np.int64]:
        """Each row's kind as its position in :attr:`models` ``(rows,)``, in run order."""
        return self._codes

    def __len__(self) -> int:
        """Return the number of updates."""
        return int(self.times.shape[0])

    @property
    def bearing_columns(self) -> BearingColumns:
        """Per-update columns for the bearing kernels (only when :attr:`single_bearing`).

        Raises
        ------
        ValueError
            When the updates are not all single bearings.
        """
        if not self.single_bearing:
            raise ValueError("bearing_columns: the updates are not all single bearings")
        return BearingColumns(self.time, self.values, self.sigmas**2,
                              self.sensor_state[:, 0], self.sensor_state[:, 1])

    def bearing_lists(self) -> tuple[list[float], ...]:
        """Return :attr:`bearing_columns` as Python lists, made once.

        The plain-float kernels index them faster than arrays.

        Returns
        -------
        tuple of list of float
            ``(time s, value rad, variance rad^2, sx m, sy m)``.
        """
        if self._lists is None:
            c = self.bearing_columns
            self._lists = (c.time.tolist(), c.value.tolist(), c.variance.tolist(),
                           c.sx.tolist(), c.sy.tolist())
        return self._lists

    def rows(self, k: int) -> MeasurementSet:
        """Return the rows of update ``k`` as a MeasurementSet (the slow, general path).

        Parameters
        ----------
        k : int
            Update index.

        Returns
        -------
        MeasurementSet
        """
        return self.meas.take(self.order[self.bounds[k]:self.bounds[k + 1]])

    def group(self, k: int, t: float) -> MeasurementGroup:
        """Return update ``k`` as a :class:`MeasurementGroup`, from views of the columns.

        Parameters
        ----------
        k : int
            Update index.
        t : float
            Filter time, s.

        Returns
        -------
        MeasurementGroup
        """
        a, b = int(self.bounds[k]), int(self.bounds[k + 1])
        codes = self._codes[a:b]
        key = codes.tobytes()
        parts = self._layouts.get(key)
        if parts is None:  # the first update with this pattern of kinds
            models, index = {}, {}
            for kind, code in self._kind_codes.items():
                idx = np.flatnonzero(codes == code)
                if idx.size:
                    models[kind] = self.models[kind]
                    index[kind] = idx
            nus = {kind: self.nuisance[kind] for kind in models}
            parts = (models, index, nus, RowLayout(models, index, b - a))
            self._layouts[key] = parts
        models, index, nus, layout = parts
        return MeasurementGroup.from_arrays(
            t, self.dim, models, nus, index, self.values[a:b], self.sigmas[a:b],
            self.time[a:b], self.time_ref[a:b], self.sensor_state[a:b],
            self.ref_sensor_state[a:b], self.sensor[a:b], lambda: self.rows(k), layout)


#: The sets compiled so far, per measurement set (whose arrays are read-only) and per
#: (dimension, options, nuisance values): a set filtered again (another filter, another prior,
#: the same filter once more) is compiled once.  Kept while the set lives.
_COMPILED: weakref.WeakKeyDictionary[MeasurementSet, dict[str, CompiledMeasurements]] = \
    weakref.WeakKeyDictionary()


def compiled_for(meas: MeasurementSet, dim: int,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> CompiledMeasurements:
    """Give ``meas`` compiled for a filter, made once per set and settings.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements.
    dim : int
        Filter dimension, 2 or 3.
    options, nuisance : mapping, optional
        As for :class:`CompiledMeasurements`.

    Returns
    -------
    CompiledMeasurements
        The same object for the same set, dimension, options and nuisance values.
    """
    key = repr((int(dim), sorted((str(k), sorted(dict(v).items()))
                                 for k, v in dict(options or {}).items()),
                sorted(dict(nuisance or {}).items())))
    try:
        per_set = _COMPILED.get(meas)
        if per_set is None:
            per_set = _COMPILED[meas] = {}
    except TypeError:  # a set that cannot be weakly referenced or hashed: compiled each time
        return CompiledMeasurements(meas, dim, options, nuisance)
    out = per_set.get(key)
    if out is None:
        if len(per_set) >= 8:  # many settings on one set: keep the cache small
            per_set.clear()
        out = per_set[key] = CompiledMeasurements(meas, dim, options, nuisance)
    return out
