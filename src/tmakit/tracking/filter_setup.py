"""What the filter of a track is made of: its class, dimension, process noise and settings.

Values are typed (the command line parses its text); errors name the library parameter.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..data import MeasurementSet
from ..filters import FILTERS, NearlyConstantVelocity, TrackingFilter, state_names
from ..filters.base import KindOptions
from ..motion import motion_from_name
from ..motion.dynamics import MAX_ACCELERATION
from .errors import TrackingError

if TYPE_CHECKING:  # pragma: no cover
    from ..filters import BearingPrior, FirstBearing
    from ..results.estimate import EstimateResult

__all__ = ["FilterSetup", "filter_class", "filter_dim", "noise_density", "process_noise",
           "random_filters", "state_vector"]


def filter_dim(meas: MeasurementSet, dim: int | None = None) -> int:
    """Return the filter's spatial dimension.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements to track.
    dim : int, optional
        2 or 3.

    Returns
    -------
    int
        ``dim`` if given, else 3 when the data need it (:attr:`MeasurementSet.dim`) or the
        set's metadata names a 3-D motion model, else 2.

    Raises
    ------
    TrackingError
        ``dim`` is neither 2 nor 3.
    """
    if dim is not None:
        if dim not in (2, 3):
            raise TrackingError(f"{{dim}} must be 2 or 3, got {dim}", "dim", ["dim"])
        return int(dim)
    if meas.dim == 3:
        return 3
    name = meas.metadata.get("motion")
    if not name:
        return 2
    try:  # the file's motion name, read by the one parser
        return 3 if motion_from_name(name).dim == 3 else 2
    except ValueError:
        return 2


def _per_axis(value: float | ArrayLike, dim: int, name: str, unit: str, axes: str,
              limit: float, too_big: str) -> tuple[float, ...]:
    """Read one value for every axis or ``dim`` of them, finite and from 0 to ``limit``."""
    what = f"a number or {dim} numbers ({unit} per axis)"

    def error(text: str) -> TrackingError:
        return TrackingError(f"{{{name}}}: {text}", name, [name])

    if isinstance(value, str | bytes):
        raise error(f"expected {what}, not the text {value!r}")
    try:
        values = np.atleast_1d(np.asarray(value, dtype=float)).reshape(-1).tolist()
    except (TypeError, ValueError):
        raise error(f"expected {what}, got {value!r}") from None
    if len(values) == 1:
        values = values * dim
    if len(values) != dim:
        raise error(f"expected one value or {dim} per-axis values{axes} for a {dim}-D track, "
                    f"got {len(values)}")
    if not all(np.isfinite(v) and 0 <= v <= limit for v in values):
        raise error(f"{too_big}, got {values}")
    return tuple(float(v) for v in values)


def process_noise(q: float | ArrayLike, dim: int) -> tuple[float, ...]:
    """Process noise as ``dim`` per-axis acceleration standard deviations (Chen & Sun, §2.1).

    Parameters
    ----------
    q : float or array_like
        One acceleration std (m/s^2) for every axis, or ``dim`` of them (x, y[, z]); not text.
    dim : int
        The track's spatial dimension, 2 or 3.

    Returns
    -------
    tuple of float

    Raises
    ------
    TrackingError
        Text, the wrong number of values, or one negative, non-finite or above 1000 g.
    """
    return _per_axis(q, dim, "q", "m/s^2", f" ({'qx,qy' if dim == 2 else 'qx,qy,qz'})",
                     MAX_ACCELERATION, "process noise must be an acceleration std >= 0 and at "
                     f"most {MAX_ACCELERATION:g} m/s^2 (1000 g: beyond any vehicle)")


def noise_density(q_density: float | ArrayLike, dim: int) -> tuple[float, ...]:
    """Process noise as ``dim`` per-axis white-noise acceleration spectral densities.

    Parameters
    ----------
    q_density : float or array_like
        One density (m^2/s^3) for every axis, or ``dim`` of them.
    dim : int
        2 or 3.

    Returns
    -------
    tuple of float

    Raises
    ------
    TrackingError
        As :func:`process_noise`'s.
    """
    return _per_axis(q_density, dim, "q_density", "m^2/s^3", "", MAX_ACCELERATION**2,
                     "a white-noise acceleration density must be >= 0 and at most "
                     f"{MAX_ACCELERATION**2:g} m^2/s^3")


def state_vector(values: Mapping[str, float] | ArrayLike, names: tuple[str, ...],
                 what: str) -> Array:
    """Read a state-sized vector given by state name or in state order."""
    if isinstance(values, Mapping):
        unknown = sorted(set(values) - set(names))
        missing = [n for n in names if n not in values]
        if unknown or missing:
            raise TrackingError(
                f"{what}: expected the state components {', '.join(names)}"
                + (f"; missing {', '.join(missing)}" if missing else "")
                + (f"; unknown {', '.join(unknown)}" if unknown else ""), what)
        out = np.array([float(values[n]) for n in names])
    else:
        out = np.asarray(values, dtype=float).reshape(-1)
        if out.shape != (len(names),):
            raise TrackingError(f"{what}: expected {len(names)} values ({', '.join(names)}), "
                                f"got {out.size}", what)
    if not np.all(np.isfinite(out)):
        raise TrackingError(f"{what}: values must be finite, got {out.tolist()}", what)
    return out


def filter_class(name: str) -> type[TrackingFilter]:
    """Return the filter class registered as ``name`` in :data:`tmakit.filters.FILTERS`.

    Parameters
    ----------
    name : str
        ``ekf``, ``ukf``, ``mgekf``, ``pf``, ...

    Returns
    -------
    type

    Raises
    ------
    TrackingError
        No filter has that name (parameter ``tracker``).
    """
    cls = FILTERS.get(name)
    if cls is None:
        raise TrackingError(f"filter {name!r}: expected one of {', '.join(sorted(FILTERS))}",
                            "tracker")
    return cls


def random_filters() -> list[str]:
    """Names of the registered filters that draw random numbers (take ``rng``), sorted.

    Returns
    -------
    list of str
    """
    return [n for n, c in sorted(FILTERS.items()) if c.takes_rng]


def _filter_kwargs(cls: type[TrackingFilter], particles: int | None,
                   rng: np.random.Generator | int | None) -> dict[str, Any]:
    kwargs: dict[str, Any] = {}
    if particles is not None:
        if not cls.takes_particles:
            raise TrackingError(f"particles: the {cls.name} filter has no particles; the "
                                "number of particles applies only to particle filters "
                                f"({', '.join(random_filters()) or 'none registered'})",
                                "particles")
        if isinstance(particles, bool) or int(particles) != particles:
            raise TrackingError(f"particles: expected a whole number, got {particles!r}",
                                "particles")
        kwargs["particles"] = int(particles)
    if cls.takes_rng:
        kwargs["rng"] = np.random.default_rng(rng)
    return kwargs


@dataclass(frozen=True)
class FilterSetup:
    """How to build the filter a start hands over to: every setting but the start.

    Parameters
    ----------
    cls : type
        The :class:`~tmakit.filters.TrackingFilter` subclass.
    dim : int
        Spatial dimension, 2 or 3.
    q : tuple of float
        Per-axis acceleration standard deviations (m/s^2).
    options : dict
        Per-kind measurement-model options.
    kwargs : dict
        Further constructor arguments (particle count, the one random generator shared).
    q_density : tuple of float
        Per-axis white-noise acceleration densities (m^2/s^3), added to ``q``'s noise.
    """

    cls: type[TrackingFilter]
    dim: int
    q: tuple[float, ...]
    options: dict[str, dict[str, object]] = field(default_factory=dict)
    kwargs: dict[str, Any] = field(default_factory=dict)
    q_density: tuple[float, ...] = ()

    @classmethod
    def create(cls, filter: str, dim: int, q: float | ArrayLike = 0.0,
               particles: int | None = None, rng: np.random.Generator | int | None = None,
               options: KindOptions | None = None, q_density: float | ArrayLike = 0.0,
               settings: Mapping[str, object] | None = None) -> FilterSetup:
        """Check and collect the settings of a filter by name.

        Parameters
        ----------
        filter, dim, q, particles, rng, options, q_density, settings
            As for :func:`tmakit.track` (``filter`` its ``tracker``; ``dim`` 2 or 3).

        Returns
        -------
        FilterSetup

        Raises
        ------
        TrackingError
            An unknown filter or one not for ``dim``, bad ``q`` or ``q_density``, or
            ``particles`` for a filter without them.
        """
        klass = filter_class(filter)
        if dim not in klass.dims:
            raise TrackingError(f"filter {filter!r} tracks in 2-D only; the data are "
                                f"{dim}-D: use ekf, ukf, ckf, gsf or pf", "tracker")
        q_axes = process_noise(q, dim)
        density = noise_density(q_density, dim)
        kwargs = {**_filter_kwargs(klass, particles, rng), **dict(settings or {})}
        opts = {str(k): dict(v) for k, v in dict(options or {}).items()}
        return cls(klass, dim, q_axes, opts, kwargs, density)

    @property
    def dynamics(self) -> NearlyConstantVelocity:
        """The filter's dynamics: ``q`` and ``q_density`` per axis."""
        return NearlyConstantVelocity(self.dim, self.q, self.q_density or 0.0)

    @property
    def state_names(self) -> tuple[str, ...]:
        """The state components, ``x, y, (z), vx, vy, (vz)``."""
        return state_names(self.dim)

    def _extra(self) -> dict[str, Any]:
        return {**self.kwargs, "options": self.options} if self.options else dict(self.kwargs)

    def from_prior(self, mean: Array, covariance: Array, time: float,
                   nuisance: Mapping[str, float] | None) -> TrackingFilter:
        """Start a filter from a Gaussian prior.

        Parameters
        ----------
        mean, covariance, time, nuisance
            As for :class:`~tmakit.filters.TrackingFilter`.

        Returns
        -------
        TrackingFilter
        """
        return self.cls(mean, covariance, time, dynamics=self.dynamics, nuisance=nuisance,
                        **self._extra())

    def from_first_bearing(self, prior: BearingPrior, first: FirstBearing,
                           nuisance: Mapping[str, float] | None) -> TrackingFilter:
        """Start a filter at the first bearing.

        Parameters
        ----------
        prior, first, nuisance
            As for :meth:`TrackingFilter.from_first_bearing <tmakit.filters.TrackingFilter>`.

        Returns
        -------
        TrackingFilter
        """
        return self.cls.from_first_bearing(prior, first, self.dim, dynamics=self.dynamics,
                                           nuisance=nuisance, **self._extra())

    def from_estimate(self, estimate: EstimateResult, time: float) -> TrackingFilter:
        """Start a filter from a batch estimate at ``time`` (s), with its nuisance values.

        Parameters
        ----------
        estimate, time
            As ``result`` and ``time`` of :meth:`TrackingFilter.from_estimate
            <tmakit.filters.TrackingFilter>`.

        Returns
        -------
        TrackingFilter
        """
        return self.cls.from_estimate(estimate, time, dynamics=self.dynamics, **self._extra())
