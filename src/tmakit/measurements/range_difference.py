"""Range difference from the difference of pulse arrival times (Chen & Sun, eq. 1).

``dr = c (dTOA - j T) = r(t) - r(t_ref)``; the noise adds one independent term per pulse
interval, so differences sharing intervals are correlated (:func:`range_difference_covariance`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..core.units import REACH_M
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, range_of, zeros_nuisance


class RangeDifference(MeasurementModel):
    """Range difference ``r(t) - r(t_ref)``, m (also in files), against an earlier sample.

    References
    ----------
    Chen & Sun, eq. 1 (``c (dTOA - j T)``) and the text after it (the noise).
    """

    kind = "range_difference"
    file_unit = "m"
    value_range = ValueRange("a range difference", -REACH_M, REACH_M)
    mirror_symmetric = True
    uses_reference = True
    correlated_noise = True

    def noise_covariance(self, time: ArrayLike, time_ref: ArrayLike, sigma: ArrayLike,
                         sensor: ArrayLike | None = None) -> NDArray[np.float64]:
        """Give the noise covariance of range differences, m^2.

        References
        ----------
        Chen & Sun, eq. 1 and the text after it.
        """
        return range_difference_covariance(time, time_ref, sigma, sensor)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict range differences, m; see :meth:`MeasurementModel.predict`."""
        return path_difference(rel, rel_ref, _NEEDS)

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        return path_difference_jacobian(rel, rel_ref, _NEEDS)


_NEEDS = "range_difference needs the relative state at the earlier sample"


def path_difference(rel: ArrayLike, rel_ref: ArrayLike | None, needs: str) -> Array:
    """Give ``|p| - |p_ref|`` (m); ``needs`` is the error without ``rel_ref``."""
    rel = as_rel(rel)
    if rel_ref is None:
        raise ValueError(needs)
    rel_ref = as_rel(rel_ref)
    return range_of(rel) - range_of(rel_ref)


def path_difference_jacobian(rel: ArrayLike, rel_ref: ArrayLike | None, needs: str,
                             scale: float = 1.0) -> Jacobian:
    """Give the derivatives of ``scale (|p| - |p_ref|)``: ``±scale p/|p|``."""
    rel = as_rel(rel)
    if rel_ref is None:
        raise ValueError(needs)
    rel_ref = as_rel(rel_ref)
    d = np.zeros(rel.shape)
    d_ref = np.zeros(rel_ref.shape)
    d[..., :3] = rel[..., :3] / range_of(rel)[..., None] * scale
    d_ref[..., :3] = -rel_ref[..., :3] / range_of(rel_ref)[..., None] * scale
    return Jacobian(d, d_ref, zeros_nuisance(rel))


def interval_count(t: ArrayLike, t_ref: ArrayLike, pri: float) -> NDArray[np.int64]:
    """Count the pulse intervals between ``t_ref`` and ``t`` (rounded to whole intervals).

    Parameters
    ----------
    t, t_ref : array_like
        Times of the later and earlier samples, s.
    pri : float
        Pulse repetition interval ``T``, s.

    Returns
    -------
    ndarray of int64
        ``j = rint((t - t_ref) / T)``, broadcast shape of ``t`` and ``t_ref``.

    References
    ----------
    Chen & Sun, eq. 1 (``t_ref = t - j T``).
    """
    return np.rint((np.asarray(t, float) - np.asarray(t_ref, float)) / pri).astype(np.int64)


def range_difference_covariance(t: ArrayLike, t_ref: ArrayLike, sigma: ArrayLike,
                                sensor: ArrayLike | None = None) -> NDArray[np.float64]:
    """Covariance of range differences that share pulse intervals.

    Two differences of one sensor covary by the overlap of their spans times the noise density
    ``sigma^2 / (t - t_ref)``.

    Parameters
    ----------
    t, t_ref : array_like
        Times of the later and earlier samples (m,), s.
    sigma : array_like
        Standard deviations (m,), m.
    sensor : array_like, optional
        Sensor ids (m,); differences of different sensors are independent.

    Returns
    -------
    ndarray
        (m, m), m^2.

    Raises
    ------
    ValueError
        If a row has ``time_ref >= time``.

    References
    ----------
    Chen & Sun, eq. 1 and the text after it (one noise term per interval).
    """
    t = np.asarray(t, dtype=float)
    t_ref = np.asarray(t_ref, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    span = t - t_ref
    if np.any(span <= 0):
        raise ValueError("every range difference needs time_ref < time")
    density = sigma**2 / span
    overlap = np.clip(np.minimum(t[:, None], t[None, :])
                      - np.maximum(t_ref[:, None], t_ref[None, :]), 0.0, None)
    # The per-interval noise is a property of the receiver; use the geometric mean density of
    # the pair (they are equal when one sigma_interval holds for the sensor).
    cov = overlap * np.sqrt(density[:, None] * density[None, :])
    if sensor is not None:
        sensor = np.asarray(sensor)
        cov = np.where(sensor[:, None] == sensor[None, :], cov, 0.0)
    return cov
