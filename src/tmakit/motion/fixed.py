"""A motion model with some of its parameters known: the others are the unknowns.

Used for bounds and estimates that assume part of the motion is known, e.g. the manoeuvres of
a piecewise curvilinear target (accelerations and change-over times known, state unknown).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .base import MotionModel


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
