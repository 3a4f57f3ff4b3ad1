"""Received power with an unknown constant: ``P = C / R^n`` (Gu et al. (2007), eq. 3).

dBW inside (so the constant enters linearly), dBm in files, sigma in dB; the exponent ``n`` is
known (2) or a nuisance parameter.  Simulated noise follows Gu et al. (2007), §2
(:func:`tmakit.core.units.snr_to_sigma_db`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.units import DBM_MINUS_DBW
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, dot3, range_of

_TEN_OVER_LN10 = 10.0 / np.log(10.0)


def _squared_range_and_gradient(rel: Array, n: Array | float) -> tuple[Array, Array]:
    """Give ``R^2`` and d(-10 n log10 R) / d rel = -(10 n / ln 10) p / R^2 (position part)."""
    p = rel[..., :3]
    r2 = dot3(p, p)
    d = np.zeros(rel.shape)
    d[..., :3] = p * (-_TEN_OVER_LN10 * n / r2)[..., None]
    return r2, d


class Power(MeasurementModel):
    """Received power ``power_constant_db - 10 n log10 R``; dBW inside, dBm in files.

    Nuisance parameters: ``power_constant_db`` (dB re W m^n) and, with an unknown exponent,
    ``path_loss_exponent``.

    Parameters
    ----------
    exponent : float or None, optional
        The known path-loss exponent (default 2); None makes it a nuisance parameter.

    References
    ----------
    Gu et al. (2007), eq. 3 (``P = C / R^2``) and §2 (the noise ``var(eta/P) = 1/SNR_p``).
    """

    kind = "power"
    file_unit = "dBm"
    value_range = ValueRange("a power", -400.0, 400.0)
    mirror_symmetric = True
    file_offset = -DBM_MINUS_DBW

    def __init__(self, exponent: float | None = 2.0) -> None:
        self.exponent = None if exponent is None else float(exponent)

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """``("power_constant_db",)``, plus ``"path_loss_exponent"`` if it is unknown."""
        if self.exponent is None:
            return ("power_constant_db", "path_loss_exponent")
        return ("power_constant_db",)

    def default_nuisance(self) -> dict[str, float]:
        """Give the default nuisance: the exponent (2 if unknown); the constant has none."""
        return {"path_loss_exponent": 2.0 if self.exponent is None else self.exponent}

    def _split(self, nuisance: ArrayLike | None) -> tuple[Array, Array | float]:
        if nuisance is None:
            raise ValueError("power: the power constant (nuisance parameter) is needed")
        nu = np.asarray(nuisance, dtype=float)
        if nu.shape[-1] != len(self.nuisance_names):
            raise ValueError(f"power: expected nuisance ({', '.join(self.nuisance_names)}), "
                             f"got shape {nu.shape}")
        n = nu[..., 1] if self.exponent is None else self.exponent
        return nu[..., 0], n

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict received powers, dBW; see :meth:`MeasurementModel.predict`."""
        rel = as_rel(rel)
        const_db, n = self._split(nuisance)
        r = range_of(rel)
        return const_db - 10.0 * n * np.log10(r)

    def _design(self, r2: Array) -> tuple[Array, Array, Array]:
        """Give ``(h0, A_const, A_var)`` from the squared range ``r2``."""
        minus_10_log_r = np.log(r2) * (-0.5 * _TEN_OVER_LN10)
        ones = np.ones((*r2.shape, 1))
        if self.exponent is None:
            return (np.zeros(r2.shape), np.zeros((*r2.shape, 2)),
                    np.concatenate([ones, minus_10_log_r[..., None]], axis=-1))
        minus_10_log_r *= self.exponent
        return minus_10_log_r, np.zeros(ones.shape), ones

    def affine_parts(self, rel: ArrayLike, t: ArrayLike | None = None,
                     rel_ref: ArrayLike | None = None) -> tuple[Array, Array, Array]:
        """Split the design; see :meth:`MeasurementModel.affine_parts`."""
        # P_dB = C_dB + n (-10 log10 R)
        p = as_rel(rel)[..., :3]
        return self._design(dot3(p, p))

    def affine_derivatives(self, rel: ArrayLike, t: ArrayLike | None = None,
                           rel_ref: ArrayLike | None = None
                           ) -> tuple[Array, Array, Array, Array | None, Array | None,
                                      Array | None, Array | None]:
        """Give the affine parts and their derivatives in one pass."""
        rel = as_rel(rel)
        r2, d = _squared_range_and_gradient(rel, 1.0 if self.exponent is None else self.exponent)
        h0, const, var = self._design(r2)
        if self.exponent is None:
            d_a = np.zeros((*rel.shape[:-1], 2, 6))
            d_a[..., 1, :] = d
            return h0, const, var, None, None, d_a, None
        return h0, const, var, d, None, None, None

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        r2, d = _squared_range_and_gradient(as_rel(rel), self._split(nuisance)[1])
        cols = [np.ones(r2.shape)]
        if self.exponent is None:
            cols.append(-5.0 * np.log10(r2))
        return Jacobian(d, None, np.stack(cols, axis=-1))

    def __repr__(self) -> str:
        """Name the kind with its exponent, e.g. ``Power(exponent=2.0)``."""
        return f"Power(exponent={self.exponent})"
