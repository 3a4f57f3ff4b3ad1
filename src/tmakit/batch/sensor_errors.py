"""Maximum likelihood with sensor position errors (Ho, Lu & Kovavisaruch (2007)'s setting).

The errors are integrated out into the noise ``R + H_b Q_b H_b'``
(:mod:`tmakit.observation.sensor_errors`); the fit starts from the ordinary ML and refits twice
with that noise linearised at the estimate.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.sensor_errors import effective_noise
from ..results.estimate import EstimateResult, assemble_result
from .ml import MaximumLikelihood
from .solver import levenberg_marquardt
from .varpro import VarProProblem

__all__ = ["estimate_with_sensor_errors"]

#: Refits with the effective noise relinearised.
REFITS = 2


def estimate_with_sensor_errors(meas: MeasurementSet, motion: MotionModel,
                                position_sigma: float, velocity_sigma: float = 0.0,
                                options: Mapping[str, Mapping[str, object]] | None = None
                                ) -> tuple[EstimateResult, EstimateResult]:
    """Fit by maximum likelihood with the sensors' positions known to ``position_sigma``.

    References
    ----------
    Ho, Lu & Kovavisaruch (2007) (source localisation with receiver position errors).
    """
    opts = {k: dict(v) for k, v in dict(options or {}).items()}
    ignoring = MaximumLikelihood(options=opts).fit(meas, motion)
    obs = ObservationModel(meas, motion, opts)
    theta = np.asarray(ignoring.estimate, dtype=float)
    nu = np.array([ignoring.nuisance[n][0] for n in obs.nuisance_names])
    converged, iterations, cost = ignoring.status == "converged", 0, np.nan
    for _ in range(REFITS):
        noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)
        sol = levenberg_marquardt(VarProProblem(obs, noise), obs.values, theta[None, :])
        theta, nu = sol.theta[0], sol.nuisance[0]
        converged, cost = bool(sol.converged[0]), float(sol.cost[0])
        iterations += int(sol.iterations[0])
    noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)
    note = (f"sensor positions known to {position_sigma:g} m per axis"
            + (f", velocities to {velocity_sigma:g} m/s" if velocity_sigma else ""))
    accounting = assemble_result(obs, noise, theta, nu, cost, iterations, converged,
                                 "ml-sensor-errors", ignoring.starts, None, note)
    loss = ", ".join(f"{n} {a / b:.3g}x" for n, a, b in zip(
        motion.param_names, accounting.std, ignoring.std, strict=True))
    accounting.message += f"; std against perfectly known positions: {loss}"
    return accounting, ignoring
