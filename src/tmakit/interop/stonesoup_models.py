"""tmakit's measurement kinds as one Stone Soup measurement model.

Part of :mod:`tmakit.interop.stonesoup` (its docstring states the conventions): Stone Soup's
Cartesian state ``[x, vx, y, vy(, z, vz)]``, tmakit's rows predicted by the observation layer.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike
from stonesoup.base import Property
from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
from stonesoup.types.angle import Bearing
from stonesoup.types.array import StateVector, StateVectors

from ..core.arrays import Array
from ..data import MeasurementSet
from ..observation import MeasurementGroup

__all__ = ["EPOCH", "TmakitMeasurementModel", "cartesian_mapping"]

#: The default timestamp of time 0 s of a measurement set (UTC).
EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)


def cartesian_mapping(dim: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Return Stone Soup's position and velocity indices of a constant-velocity state."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    return tuple(range(0, 2 * dim, 2)), tuple(range(1, 2 * dim, 2))


class TmakitMeasurementModel(NonLinearGaussianMeasurement):
    """tmakit measurement rows at one time as a Stone Soup measurement model.

    Build it with :meth:`from_rows`.  ``function`` and ``jacobian`` evaluate tmakit's models at the
    state's position and velocity (``mapping``, ``velocity_mapping``) in SI; angle rows are Stone
    Soup ``Bearing`` values, so innovations wrap to (-pi, pi].
    """

    group: MeasurementGroup = Property(doc="The rows, their models, sensor states and noise.")
    velocity_mapping: tuple[int, ...] = Property(doc="State indices of vx, vy(, vz).")

    @classmethod
    def from_rows(cls, rows: MeasurementSet, dim: int = 2, ndim_state: int | None = None,
                  mapping: Sequence[int] | None = None,
                  velocity_mapping: Sequence[int] | None = None,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None) -> TmakitMeasurementModel:
        """Build the model of measurement rows taken at one time."""
        if len(rows) and np.ptp(rows.time) > 1e-9:
            raise ValueError("a measurement model holds rows of one time; got times "
                             f"{rows.time.min():g} to {rows.time.max():g} s")
        pos, vel = cartesian_mapping(dim)
        pos = tuple(int(i) for i in (pos if mapping is None else mapping))
        vel = tuple(int(i) for i in (vel if velocity_mapping is None else velocity_mapping))
        n_state = 2 * dim if ndim_state is None else int(ndim_state)
        if len(pos) != dim or len(vel) != dim or max(pos + vel) >= n_state:
            raise ValueError(f"mapping {pos} and velocity_mapping {vel} do not fit a "
                             f"{dim}-D target in a state of {n_state}")
        group = MeasurementGroup(rows, float(rows.time[0]), dim, options, nuisance)
        return cls(ndim_state=n_state, mapping=pos, velocity_mapping=vel,
                   noise_covar=np.array(group.covariance), group=group)

    @classmethod
    def for_kinds(cls, kinds: str | Sequence[str], sigmas: ArrayLike,
                  sensor_state: ArrayLike, dim: int = 2, *, sensor: str = "sensor",
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  nuisance: Mapping[str, float] | None = None,
                  **mappings: object) -> TmakitMeasurementModel:
        """Build a model of tmakit kinds made from one sensor state, for Stone Soup's own loops."""
        names = [kinds] if isinstance(kinds, str) else list(kinds)
        n = len(names)
        rows = MeasurementSet.from_si(np.zeros(n), [sensor] * n, names, np.zeros(n),
                                      np.broadcast_to(np.asarray(sigmas, dtype=float), (n,)),
                                      np.tile(np.asarray(sensor_state, dtype=float), (n, 1)))
        return cls.from_rows(rows, dim, options=options, nuisance=nuisance,
                             **mappings)  # type: ignore[arg-type]

    @property
    def ndim_meas(self) -> int:
        """The number of rows ``m``."""
        return len(self.group)

    def typed_vector(self) -> Array:
        """Return a column with Bearing(0) on the angle rows, 0.0 elsewhere."""
        return np.array([[Bearing(0.0)] if a else [0.0] for a in self.group.angle],
                        dtype=object)

    def _tmakit_states(self, state: object) -> Array:
        """Return the tmakit states ``(N, 2 dim)`` of a Stone Soup state (N columns)."""
        sv = np.asarray(state.state_vector, dtype=np.float64)  # type: ignore[attr-defined]
        return sv[list(self.mapping) + list(self.velocity_mapping), :].T

    def function(self, state: object, noise: bool | ArrayLike = False,
                 **kwargs: object) -> StateVector | StateVectors:
        """Return the predicted rows (m, N), SI, angle rows as Bearing values."""
        x = self._tmakit_states(state)
        values = self.group.predict(x).T  # (m, N)
        if noise is True:
            values = values + np.asarray(self.rvs(num_samples=x.shape[0], **kwargs), float)
        elif noise is not False and noise is not None:
            values = values + np.asarray(noise, dtype=float)
        typed = self.typed_vector() + values
        return StateVector(typed) if typed.shape[1] == 1 else StateVectors(typed)

    def jacobian(self, state: object, **kwargs: object) -> Array:
        """Return the analytic Jacobian ``d function / d state`` (m, ndim_state), SI."""
        h = self.group.jacobian(self._tmakit_states(state)[0])
        out = np.zeros((len(self.group), self.ndim_state))
        out[:, list(self.mapping) + list(self.velocity_mapping)] = h
        return out

    def rvs(self, num_samples: int = 1, random_state: object = None,
            **kwargs: object) -> StateVector | StateVectors:
        """Draw noise samples (m, num_samples) from the rows' covariance, angle rows typed."""
        rng = np.random.default_rng(random_state)  # type: ignore[arg-type]
        draws = rng.multivariate_normal(np.zeros(len(self.group)), self.covar(), num_samples).T
        typed = self.typed_vector() + draws
        return StateVector(typed) if num_samples == 1 else StateVectors(typed)

    def logpdf(self, state1: object, state2: object, **kwargs: object) -> float | Array:
        """Return the log likelihood of measurement ``state1`` given state ``state2``."""
        z = np.asarray(state1.state_vector, dtype=np.float64)[:, 0]  # type: ignore[attr-defined]
        r = self.group.residual(self.group.predict(self._tmakit_states(state2)), z)
        w = self.group.noise.whiten(r, axis=-1)
        _, logdet = np.linalg.slogdet(np.asarray(self.covar(), dtype=float))
        ll = -0.5 * (np.sum(w**2, axis=-1) + logdet + len(self.group) * np.log(2 * np.pi))
        return float(ll[0]) if ll.shape[0] == 1 else ll

    def pdf(self, state1: object, state2: object, **kwargs: object) -> float | Array:
        """Return the likelihood, ``exp(logpdf)``."""
        return np.exp(self.logpdf(state1, state2, **kwargs))
