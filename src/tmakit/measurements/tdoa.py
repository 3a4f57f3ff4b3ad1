"""Time difference of arrival between two sensors at one time (TDOA).

``tdoa = (|p - s| - |p - s_ref|) / c`` (Chan & Ho (1994)).  Differences at one time sharing a
reference sensor share its error: covariance ``sigma^2 (I + 1 1') / 2``
(:func:`shared_reference_covariance`), unless ``noise="independent"``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.units import REACH_M, SPEED_OF_LIGHT
from .base import Jacobian, MeasurementModel, ValueRange
from .range_difference import path_difference, path_difference_jacobian

__all__ = ["NOISE_FORMS", "BetweenSensors", "Tdoa", "noise_form", "shared_reference_covariance"]

#: The noise forms of differences between sensors: ``shared`` (the reference's arrival
#: error is common to the rows that share it, the default) or ``independent``.
NOISE_FORMS = ("shared", "independent")


def noise_form(text: str, where: str) -> str:
    """Check a noise form (``shared`` or ``independent``)."""
    form = str(text).strip().lower()
    if form not in NOISE_FORMS:
        raise ValueError(f"{where}: expected one of {', '.join(NOISE_FORMS)}, found {text!r}")
    return form


def shared_reference_covariance(sigma: ArrayLike) -> NDArray[np.float64]:
    """Covariance of differences that share one reference measurement.

    ``R_ii = sigma_i^2``, ``R_ij = sigma_i sigma_j / 2``.

    Parameters
    ----------
    sigma : array_like
        Standard deviations of the differences (m,), SI.

    Returns
    -------
    ndarray
        (m, m), SI units squared.

    References
    ----------
    Chan & Ho (1994) (the TDOA covariance with equal arrival-time variances).
    """
    s = np.asarray(sigma, dtype=float)
    cov = 0.5 * s[:, None] * s[None, :]
    cov[np.diag_indices_from(cov)] = s**2
    return cov


class BetweenSensors(MeasurementModel):
    """A difference between a sensor and its reference sensor at one time (tdoa, fdoa).

    Rows at one time that share a reference sensor are correlated
    (:func:`shared_reference_covariance`) unless ``noise="independent"``.
    """

    mirror_symmetric = True
    uses_reference = True
    between_sensors = True
    correlated_noise = True

    def __init__(self, noise: str = "shared", speed_of_light: float = SPEED_OF_LIGHT) -> None:
        self.noise = noise_form(noise, f"{self.kind} noise")
        self.correlated_noise = self.noise == "shared"
        self.c = float(speed_of_light)

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the noise form a file's metadata states (``# tdoa_noise: independent``)."""
        key = f"{cls.kind}_noise"
        return {"noise": noise_form(metadata[key], f"metadata {key}")} if key in metadata else {}

    def noise_covariance(self, time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike,
                         sensor: ArrayLike | None = None) -> NDArray[np.float64]:
        """Give the covariance of rows sharing one reference at one time (SI squared)."""
        if not self.correlated_noise:
            return np.diag(np.asarray(sigma, dtype=float) ** 2)
        return shared_reference_covariance(sigma)

    def _needs(self) -> str:
        """Give the error for a row without the reference sensor's state."""
        return f"{self.kind} needs the target's state relative to the reference sensor"


class Tdoa(BetweenSensors):
    """Time difference of arrival, s (also in files): sensor minus reference sensor.

    Parameters
    ----------
    noise : str, optional
        ``"shared"`` (default) or ``"independent"`` (:data:`NOISE_FORMS`).
    speed_of_light : float, optional
        Propagation speed ``c``, m/s.

    References
    ----------
    Chan & Ho (1994) (the model and its noise); Ho & Xu (2004) (TDOA and FDOA).
    """

    kind = "tdoa"
    file_unit = "s"
    value_range = ValueRange("a time difference", -REACH_M / SPEED_OF_LIGHT,
                             REACH_M / SPEED_OF_LIGHT)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict time differences, s; see :meth:`MeasurementModel.predict`."""
        return path_difference(rel, rel_ref, self._needs()) / self.c

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        return path_difference_jacobian(rel, rel_ref, self._needs(), 1.0 / self.c)

    def __repr__(self) -> str:
        """Name the kind with its noise form."""
        return f"Tdoa(noise={self.noise!r})"
