"""What a steered sensor will measure at each decision step.

A :class:`SensorPlan` names the kinds, their noise (independent sigmas or a full covariance, e.g.
the radar's correlated range and range rate) and when in a decision step they are made.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..measurements import KINDS
from ..observation import MeasurementGroup


@dataclass(frozen=True, eq=False)
class SensorPlan:
    """The measurements made in each decision step, for planning.

    Parameters
    ----------
    kinds : sequence of str
        One kind per row made at each measurement time (``"bearing"``, ``"range"``,
        ``"range_rate"``, ``"elevation"``, ``"frequency"``, ``"power"``, ...).
    sigmas : array_like
        Noise standard deviations, SI (rad, m, m/s, Hz, dB), one per row.
    dim : int, optional
        Target state dimension, 2 or 3.
    times : sequence of float, optional
        When the rows are made, s after the start of a step, in ``(0, interval]``; default once, at
        the end of the step (one pulse per decision, as in Hurtado & Nehorai (2008), section 5).
    covariance : array_like, optional
        A full noise covariance (m, m) SI, overriding ``sigmas`` (correlated rows).
    options : mapping, optional
        Per-kind model options (as for :meth:`MeasurementGroup.planned`).
    nuisance : mapping, optional
        Values of the kinds' nuisance parameters (e.g. ``{"carrier": ...}``) at which the
        information is evaluated.

    Raises
    ------
    ValueError
        On empty or unknown kinds, sigmas that are not one or one per kind, positive and finite, or
        times that are not increasing and positive.
    """

    kinds: tuple[str, ...]
    sigmas: Array
    dim: int = 2
    times: tuple[float, ...] | None = None
    covariance: Array | None = None
    options: Mapping[str, Mapping[str, object]] | None = None
    nuisance: Mapping[str, float] | None = None
    _group: list[MeasurementGroup] = field(default_factory=list, repr=False, compare=False)

    def __init__(self, kinds: str | Sequence[str], sigmas: ArrayLike, dim: int = 2,
                 times: Sequence[float] | None = None, covariance: ArrayLike | None = None,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 nuisance: Mapping[str, float] | None = None) -> None:
        names = (kinds,) if isinstance(kinds, str) else tuple(kinds)
        if not names:
            raise ValueError("a sensor plan needs at least one measurement kind")
        unknown = [k for k in names if k not in KINDS]
        if unknown:
            raise ValueError(f"sensor plan kinds: unknown {', '.join(map(repr, unknown))}; "
                             f"expected some of {', '.join(KINDS)}")
        given = np.asarray(sigmas, dtype=float)
        if given.ndim > 1 or (given.ndim == 1 and given.shape[0] != len(names)):
            raise ValueError(f"sensor plan sigmas: give one value, or one per kind "
                             f"({len(names)}); got shape {given.shape}")
        sig = np.broadcast_to(given, (len(names),)).copy()
        if not np.all(np.isfinite(sig) & (sig > 0)):
            raise ValueError(f"sensor plan sigmas must be positive and finite (SI); got {sig}")
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3; got {dim}")
        if times is not None:
            t = np.asarray(times, dtype=float)
            if t.ndim != 1 or not t.size or np.any(t <= 0) or np.any(np.diff(t) <= 0):
                raise ValueError("sensor plan times must be increasing and > 0 (s after the "
                                 "start of a step)")
            times = tuple(float(v) for v in t)
        cov = None
        if covariance is not None:
            cov = np.asarray(covariance, dtype=float)
            m = len(names)
            if cov.shape != (m, m) or not np.allclose(cov, cov.T) \
                    or np.linalg.eigvalsh(cov).min() <= 0:
                raise ValueError(f"sensor plan covariance must be a ({m}, {m}) symmetric "
                                 "positive-definite matrix (SI)")
        for name, value in (("kinds", names), ("sigmas", sig), ("dim", int(dim)),
                            ("times", times), ("covariance", cov), ("options", options),
                            ("nuisance", nuisance), ("_group", [])):
            object.__setattr__(self, name, value)

    def measurement_times(self, interval: float) -> Array:
        """Return the measurement times of a step of ``interval`` s.

        Parameters
        ----------
        interval : float
            The step, s.

        Returns
        -------
        ndarray
            s after the step's start (the plan's ``times``, or the step's end).

        Raises
        ------
        ValueError
            If a time lies beyond the interval.
        """
        if self.times is None:
            return np.array([float(interval)])
        t = np.asarray(self.times)
        if t[-1] > interval * (1 + 1e-12):
            raise ValueError(f"sensor plan times reach {t[-1]:g} s, beyond the decision "
                             f"interval of {interval:g} s")
        return t

    @property
    def group(self) -> MeasurementGroup:
        """One planned group (built once); its information is evaluated at given states."""
        if not self._group:
            extra = {} if self.covariance is None else {"covariance": self.covariance}
            self._group.append(MeasurementGroup.planned(
                list(self.kinds), self.sigmas, 0.0, self.dim, options=self.options,
                nuisance=self.nuisance, **extra))
        return self._group[0]

    def information(self, states: Array, sensor_states: Array) -> Array:
        """Fisher information ``Xi`` of one measurement time, for states and sensor poses.

        Parameters
        ----------
        states : ndarray, shape (N, n)
            Target states at the measurement time.
        sensor_states : ndarray, shape (*B, 6)
            Sensor states ``[x, y, z, vx, vy, vz]`` at the same time.

        Returns
        -------
        ndarray, shape (*B, N, n, n)
            SI.

        References
        ----------
        Hurtado & Nehorai (2008), eq. 13.
        """
        sensor = np.asarray(sensor_states, dtype=float)[..., None, None, :]
        return self.group.information(states, sensor)
