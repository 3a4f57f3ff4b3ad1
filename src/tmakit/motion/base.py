"""The motion-model interface: parameters theta -> target states at given times.

``theta`` ``(..., p)`` (leading axes independent problems) and times ``t`` ``(n,)``, s, map to
ENU states ``(..., n, 6)``, m and m/s; :meth:`MotionModel.jacobian` gives ``(..., n, 6, p)``.
:class:`FixedParameters` holds some parameters of a model known (e.g. a piecewise curvilinear
target's manoeuvres, for bounds and estimates that assume them), the others unknown.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.units import REACH_M, SPEED_OF_LIGHT

#: The largest value of a position or a speed parameter (m, m/s): the rules' reach.
_REACH = {**dict.fromkeys(("x", "y", "z"), REACH_M),
          **dict.fromkeys(("vx", "vy", "vz", "speed"), SPEED_OF_LIGHT)}
#: What a position or a speed parameter must be.
WITHIN_REACH = (f"expected positions within {REACH_M:g} m of the origin and speeds below "
                "light's (m, m/s)")


class MotionModel(ABC):
    """Target motion model: named parameters, states at times, and their derivatives."""

    #: Parameter names in the order of ``theta``.
    param_names: tuple[str, ...]
    #: 2 for motion in the plane z = 0, 3 for motion in space.
    dim: int
    #: Short name used on the command line and in files (``cv2d``, ``static3d``, ...).
    name: str

    @property
    def n_params(self) -> int:
        """Number of parameters ``p`` (the length of ``theta``)."""
        return len(self.param_names)

    @abstractmethod
    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Compute the target states ``(..., n, 6)``, m and m/s, at times ``t``.

        Parameters
        ----------
        theta : array_like
            ``(..., p)``, SI, in :attr:`param_names` order.
        t : array_like
            ``(n,)``, s.

        Returns
        -------
        ndarray
        """

    def states_minus(self, theta: ArrayLike, t: ArrayLike, sensor: NDArray[np.float64]
                     ) -> NDArray[np.float64]:
        """Compute :meth:`states` minus ``sensor``'s states.

        Parameters
        ----------
        theta, t : array_like
            As for :meth:`states`.
        sensor : ndarray
            ``(n, 6)`` ENU sensor states, m and m/s.

        Returns
        -------
        ndarray
            ``(..., n, 6)``.
        """
        return self.states(theta, t) - sensor

    @abstractmethod
    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Compute ``d state / d theta`` ``(..., n, 6, p)`` at times ``t``.

        Parameters
        ----------
        theta, t : array_like
            As for :meth:`states`.

        Returns
        -------
        ndarray
        """

    #: Whether the states are affine in ``theta`` (then :meth:`component_terms` is exact).
    affine: bool = False
    #: Whether the velocity's derivatives by ``theta`` are the same at every time.
    velocity_fixed: bool = False

    def component_terms(self, t: ArrayLike
                        ) -> tuple[list[tuple[int, int, NDArray[np.float64] | None]],
                                   NDArray[np.float64]] | None:
        """Give ``states(theta, t)`` as an offset plus the non-zero terms of ``theta``.

        Parameters
        ----------
        t : array_like
            ``(n,)``, s.

        Returns
        -------
        tuple or None
            ``(terms, offset (6, n))``, each term ``(parameter, component, coefficients or None)``
            (None: all ones); None when the model is not :attr:`affine`.
        """
        if not self.affine:
            return None
        t = np.asarray(t, dtype=float)
        zero = np.zeros(self.n_params)
        matrix = self.jacobian(zero, t)  # (n, 6, p)
        terms = []
        for i in range(self.n_params):
            for c in range(6):
                row = matrix[:, c, i]
                if np.any(row != 0.0):
                    terms.append((i, c, None if np.all(row == 1.0) else row.copy()))
        return terms, np.ascontiguousarray(self.states(zero, t).T)

    def chain(self, d_state: NDArray[np.float64], theta: ArrayLike, t: ArrayLike
              ) -> NDArray[np.float64]:
        """Apply the chain rule: ``d value / d theta`` ``(..., n, p)`` from ``d value / d state``.

        Parameters
        ----------
        d_state : ndarray
            ``(..., n, 6)``, per m and per m/s.
        theta, t : array_like
            As for :meth:`states`.

        Returns
        -------
        ndarray
        """
        jac = self.jacobian(theta, t)  # (*batch, n, 6, p)
        extra = d_state.ndim - (jac.ndim - 1)
        if extra > 0:
            lead = jac.ndim - 3
            jac = jac.reshape(jac.shape[:lead] + (1,) * extra + jac.shape[lead:])
        return cast(NDArray[np.float64], np.einsum("...ni,...nip->...np", d_state, jac))

    def from_state(self, state: ArrayLike, t: float) -> NDArray[np.float64]:
        """Give the parameters ``(..., p)`` of the simplest trajectory through given states.

        Parameters
        ----------
        state : array_like
            ``(..., 6)`` ENU, m and m/s.
        t : float
            Time of ``state``, s.

        Returns
        -------
        ndarray

        Raises
        ------
        NotImplementedError
            For a model that cannot be started from a state.
        """
        raise NotImplementedError(f"{self.name} cannot be started from a state")

    def theta(self, values: Mapping[str, float]) -> NDArray[np.float64]:
        """Build a parameter vector ``(p,)`` from a mapping of names to SI values.

        Parameters
        ----------
        values : Mapping[str, float]

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            For a missing or an unknown name.
        """
        missing = [name for name in self.param_names if name not in values]
        unknown = [name for name in values if name not in self.param_names]
        if missing or unknown:
            parts = [f"{word} {', '.join(names)}" for word, names in
                     (("missing", missing), ("unknown", unknown)) if names]
            raise ValueError(
                f"parameters for motion model {self.name!r}: {'; '.join(parts)} "
                f"(expected {', '.join(self.param_names)})"
            )
        return np.array([float(values[name]) for name in self.param_names])

    def beyond_reach(self, theta: ArrayLike) -> list[str]:
        """Name the position and speed parameters of ``theta`` beyond the rules' reach.

        Parameters
        ----------
        theta : array_like
            ``(p,)``, SI.

        Returns
        -------
        list of str
            ``["x=1e+300", ...]``: positions beyond 1e9 m, speeds beyond light's, NaN.
        """
        return [f"{n}={v:g}" for n, v in zip(self.param_names, np.ravel(theta).tolist(),
                                              strict=True)
                if n in _REACH and not abs(v) <= _REACH[n]]

    def as_dict(self, theta: ArrayLike) -> dict[str, float]:
        """Name every entry of a single parameter vector.

        Parameters
        ----------
        theta : array_like
            ``(p,)``, SI.

        Returns
        -------
        dict of str to float

        Raises
        ------
        ValueError
            For a vector of the wrong shape.
        """
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (self.n_params,):
            raise ValueError(
                f"expected {self.n_params} parameters ({', '.join(self.param_names)}), "
                f"got shape {theta.shape}"
            )
        return {name: float(v) for name, v in zip(self.param_names, theta, strict=True)}

    def check_theta(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Return ``theta`` as float64, refusing a wrong number of parameters.

        Parameters
        ----------
        theta : array_like
            ``(..., n_params)``, SI.

        Returns
        -------
        numpy.ndarray

        Raises
        ------
        ValueError
            If the last axis does not have :attr:`n_params` entries.
        """
        theta = np.asarray(theta, dtype=float)
        if theta.ndim == 0 or theta.shape[-1] != self.n_params:
            raise ValueError(
                f"motion model {self.name!r} takes {self.n_params} parameters "
                f"({', '.join(self.param_names)}); got an array of shape {theta.shape}"
            )
        return theta

    def __repr__(self) -> str:
        """Name the class and its parameters."""
        return f"{type(self).__name__}({', '.join(self.param_names)})"


class FixedParameters(MotionModel):
    """``model`` with the parameters named in ``known`` held at the given values (SI).

    ``param_names`` are the rest, in ``model``'s order; :meth:`full` gives the wrapped vector.

    Parameters
    ----------
    model : MotionModel
    known : Mapping[str, float]
        SI.

    Raises
    ------
    ValueError
        For a name that is not a parameter of ``model``, or when none would remain unknown.
    """

    def __init__(self, model: MotionModel, known: Mapping[str, float]) -> None:
        unknown = [n for n in known if n not in model.param_names]
        if unknown:
            raise ValueError(f"known parameters {', '.join(unknown)} are not parameters of "
                             f"{model.name!r} ({', '.join(model.param_names)})")
        self.model = model
        self.known = {n: float(v) for n, v in known.items()}
        self.free = np.array([i for i, n in enumerate(model.param_names) if n not in known],
                             dtype=int)
        self.param_names = tuple(model.param_names[i] for i in self.free)
        if not self.param_names:
            raise ValueError("at least one parameter must remain unknown")
        self.dim = model.dim
        self.name = model.name
        self.ref_time = getattr(model, "ref_time", None)
        self._fixed_index = np.array([model.param_names.index(n) for n in self.known],
                                     dtype=int)
        self._fixed_values = np.array(list(self.known.values()))

    def full(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Give the wrapped model's parameters ``(..., P)`` from the unknowns ``(..., p)``.

        Parameters
        ----------
        theta : array_like

        Returns
        -------
        ndarray
        """
        theta = self.check_theta(theta)
        out = np.empty((*theta.shape[:-1], self.model.n_params))
        out[..., self.free] = theta
        out[..., self._fixed_index] = self._fixed_values
        return out

    def states(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give the wrapped model's states ``(..., n, 6)`` (m, m/s) at times ``t`` (s)."""
        return self.model.states(self.full(theta), t)

    def jacobian(self, theta: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Give ``d state / d theta`` ``(..., n, 6, p)`` over the unknowns only."""
        return self.model.jacobian(self.full(theta), t)[..., self.free]

    def __repr__(self) -> str:
        """Name the wrapped model and the known values."""
        known = ", ".join(f"{k}={v:g}" for k, v in self.known.items())
        return f"FixedParameters({self.model!r}, known: {known})"
