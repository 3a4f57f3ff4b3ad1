"""Time difference of arrival between two sensors at one time (TDOA).

``tdoa = (|p - s| - |p - s_ref|) / c``: the arrival time at the row's sensor ``s`` minus that
at its reference sensor ``s_ref``, both at the row's time (Chan & Ho (1994), the
range difference ``r_i,1`` divided by ``c``).  The reference sensor's state is the row's
``ref_sensor_state`` and its time the row's own (``time_ref = time``).

Noise (:func:`shared_reference_covariance`): with independent arrival-time errors at every
sensor, the differences at one time that share a reference sensor share its error, so their
covariance is ``sigma^2 (I + 1 1') / 2`` for the std ``sigma`` of one difference (Chan & Ho
(1994), with equal arrival-time variances); ``noise="independent"`` (the file's
``# tdoa_noise: independent``) is for differences measured independently (a correlator per
pair).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.units import REACH_M, SPEED_OF_LIGHT
from .base import Array, Jacobian, MeasurementModel, ValueRange
from .range_difference import path_difference, path_difference_jacobian

__all__ = ["NOISE_FORMS", "Tdoa", "noise_form", "shared_reference_covariance"]

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

    Each difference ``i`` is ``sigma_i / sqrt(2)`` times (its own unit error minus the
    reference's), so ``R_ii = sigma_i^2`` and ``R_ij = sigma_i sigma_j / 2``: with one
    ``sigma``, ``sigma^2 (I + 1 1') / 2``.

    Parameters
    ----------
    sigma : array_like
        Standard deviations of the differences (m,), SI.

    Returns
    -------
    ndarray
        (m, m) covariance, SI units squared.

    References
    ----------
    Chan & Ho (1994) (the TDOA covariance with equal arrival-time variances).
    """
    s = np.asarray(sigma, dtype=float)
    cov = 0.5 * s[:, None] * s[None, :]
    cov[np.diag_indices_from(cov)] = s**2
    return cov


_NEEDS = "tdoa needs the target's state relative to the reference sensor"


class Tdoa(MeasurementModel):
    """Time difference of arrival, s (also in files): sensor minus reference sensor.

    No nuisance parameters.  Rows at one time that share a reference sensor are correlated
    (:func:`shared_reference_covariance`) unless ``noise="independent"``.

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
    mirror_symmetric = True
    uses_reference = True
    between_sensors = True
    correlated_noise = True

    def __init__(self, noise: str = "shared", speed_of_light: float = SPEED_OF_LIGHT) -> None:
        self.noise = noise_form(noise, "tdoa noise")
        self.correlated_noise = self.noise == "shared"
        self.c = float(speed_of_light)

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the options a file's metadata states (``# tdoa_noise: independent``).

        Parameters
        ----------
        metadata : mapping of str to str
            The set's metadata.

        Returns
        -------
        dict
            ``{"noise": ...}`` when the file states it, else empty.

        Raises
        ------
        ValueError
            If ``tdoa_noise`` is not a noise form.
        """
        if "tdoa_noise" not in metadata:
            return {}
        return {"noise": noise_form(metadata["tdoa_noise"], "metadata tdoa_noise")}

    def noise_covariance(self, time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike,
                         sensor: ArrayLike | None = None) -> NDArray[np.float64]:
        """Give the noise covariance of rows sharing one reference at one time, s^2.

        Parameters
        ----------
        time, time_ref, sensor : array_like
            Not used (the rows given share the reference and the time).
        sigma : array_like
            Standard deviations (m,), s.

        Returns
        -------
        ndarray
            (m, m): :func:`shared_reference_covariance`, or ``diag(sigma^2)`` with
            ``noise="independent"``.
        """
        if not self.correlated_noise:
            return np.diag(np.asarray(sigma, dtype=float) ** 2)
        return shared_reference_covariance(sigma)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict time differences, s; see :meth:`MeasurementModel.predict`.

        Parameters
        ----------
        rel, t, nuisance, rel_ref
            As for :meth:`MeasurementModel.predict`; ``rel_ref`` (the target relative to
            the reference sensor) is required; ``t`` and ``nuisance`` are not used.

        Returns
        -------
        ndarray
            ``(|p| - |p_ref|) / c``, s, shape ``rel.shape[:-1]``.

        Raises
        ------
        ValueError
            If ``rel_ref`` is missing.
        """
        return path_difference(rel, rel_ref, _NEEDS) / self.c

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`.

        Parameters
        ----------
        rel, t, nuisance, rel_ref
            As for :meth:`predict`.

        Returns
        -------
        Jacobian
            ``rel``: ``p / (c |p|)``; ``rel_ref``: ``-p_ref / (c |p_ref|)`` (s/m, position
            part only); no nuisance.

        Raises
        ------
        ValueError
            If ``rel_ref`` is missing.
        """
        return path_difference_jacobian(rel, rel_ref, _NEEDS, 1.0 / self.c)

    def __repr__(self) -> str:
        """Name the kind with its noise form."""
        return f"Tdoa(noise={self.noise!r})"
