"""The CRLB with sensor position errors (Ho, Lu & Kovavisaruch (2007)).

:func:`tmakit.bounds.crlb` with the rows' noise ``R + H_b Q_b H_b'``
(:func:`tmakit.observation.sensor_errors.effective_noise`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.sensor_errors import effective_noise
from ..results.bound import Bound, bound_from_information
from .fim import crlb, truth_vector

__all__ = ["crlb_with_sensor_errors"]


def crlb_with_sensor_errors(meas: MeasurementSet, motion: MotionModel,
                            truth: Mapping[str, float] | ArrayLike, position_sigma: float,
                            velocity_sigma: float = 0.0,
                            nuisance: Mapping[str, float] | None = None,
                            options: Mapping[str, Mapping[str, object]] | None = None
                            ) -> tuple[Bound, Bound]:
    """Give the CRLB with sensor position errors, and the one with positions known.

    References
    ----------
    Ho, Lu & Kovavisaruch (2007) (the CRLB with receiver position errors).
    """
    known = crlb(meas, motion, truth, nuisance, None, options)
    theta = truth_vector(motion, truth)
    obs = ObservationModel(meas, motion, options)
    nu = np.asarray(known.values[motion.n_params:], dtype=float)
    noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)  # grouped order
    w = noise.whiten(np.concatenate(obs.jacobian_grouped(theta, nu), axis=-1), axis=-2)
    info = w.T @ w
    names = motion.param_names + obs.nuisance_names
    with_errors = bound_from_information(info, names, np.asarray(known.values, dtype=float),
                                         meas, motion, None, known.nuisance_values)
    return with_errors, known
