"""What every batch estimator is: settings in its constructor, :meth:`~BatchEstimator.fit`."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..motion.base import WITHIN_REACH
from ..results.estimate import EstimateResult

#: A starting point: motion parameters by name, a vector in ``param_names`` order, or None.
Init = Mapping[str, float] | ArrayLike | None
#: The nuisance model per kind, e.g. ``{"frequency": {"drift": True}}``.
Options = Mapping[str, Mapping[str, object]] | None


class BatchEstimator(ABC):
    """A batch estimator: settings in the constructor, :meth:`fit` on the data."""

    name: ClassVar[str] = ""
    takes_known_nuisance: ClassVar[bool] = False

    @abstractmethod
    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Estimate the motion parameters from the measurements.

        Parameters
        ----------
        meas : MeasurementSet
        motion : MotionModel

        Returns
        -------
        EstimateResult
        """


def theta_from_init(motion: MotionModel, init: Mapping[str, float] | ArrayLike, prefix: str = "",
                    named_only: bool = False) -> NDArray[np.float64]:
    """Give a start ``(p,)`` from names (``named_only``: others ignored) or a vector, checked."""
    if not isinstance(init, np.ndarray) and isinstance(init, Mapping):  # (an ABC's test: slow)
        theta = motion.theta({k: v for k, v in init.items() if k in motion.param_names}
                             if named_only else init)
    else:
        theta = np.asarray(init, dtype=float).reshape(-1)
        if theta.shape != (motion.n_params,):
            raise ValueError(f"{prefix}init must give {motion.n_params} values "
                             f"({', '.join(motion.param_names)})")
    if far := motion.beyond_reach(theta):
        raise ValueError(f"{prefix}init {', '.join(far)}: {WITHIN_REACH}")
    return theta


def refuse_manoeuvre_options(given: Mapping[str, object], motion: object) -> None:
    """Refuse settings of the manoeuvre search for a motion without manoeuvres."""
    if given:
        raise TypeError(f"estimate() got options for manoeuvring targets "
                        f"({', '.join(given)}) with motion {getattr(motion, 'name', motion)!r}")
