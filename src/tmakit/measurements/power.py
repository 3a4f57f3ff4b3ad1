"""Received power with an unknown constant: ``P = C / R^n`` (Gu et al. (2007), eq. 3).

Inside, power is in dBW so that the nuisance constant enters linearly:
``P_dBW = power_constant_db - 10 n log10 R`` with ``power_constant_db = 10 log10 C``
(C in W m^n).  Files carry dBm.  The path-loss exponent ``n`` is 2 by default and known; with
``exponent=None`` it becomes the nuisance parameter ``path_loss_exponent``.

Noise: a file's ``sigma`` is the standard deviation of the power in dB.  Gu et al. (2007)'s
noise (var(eta/P) = 1/SNR_p) is simulated exactly by the scenario and written with the
first-order sigma (10 / ln 10) / sqrt(SNR_p), see :func:`tmakit.core.units.snr_to_sigma_db`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core.units import DBM_MINUS_DBW
from .base import Array, Jacobian, MeasurementModel, ValueRange, as_rel, dot3

_TEN_OVER_LN10 = 10.0 / np.log(10.0)


class Power(MeasurementModel):
    """Received power ``power_constant_db - 10 n log10 R``; dBW inside, dBm in files.

    A file's sigma is in dB.  Nuisance parameters: ``power_constant_db`` (dB re W m^n) and,
    with an unknown exponent, ``path_loss_exponent`` (dimensionless).

    Parameters
    ----------
    exponent : float or None, optional
        The known path-loss exponent ``n`` (default 2, free space); None makes it the
        nuisance parameter ``path_loss_exponent``.

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
        """Give the default nuisance: the exponent (2 if unknown); the constant has none.

        Returns
        -------
        dict of str to float
            ``{"path_loss_exponent": n}``, dimensionless.
        """
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
        """Predict received powers, dBW; see :meth:`MeasurementModel.predict`.

        Parameters
        ----------
        rel, t, nuisance, rel_ref
            As for :meth:`MeasurementModel.predict`; ``nuisance`` (dB re W m^n, and the
            exponent if unknown) is required; ``t`` and ``rel_ref`` are not used.

        Returns
        -------
        ndarray
            ``power_constant_db - 10 n log10 R``, dBW, shape ``rel.shape[:-1]``.

        Raises
        ------
        ValueError
            If ``nuisance`` is missing or of the wrong length.
        """
        rel = as_rel(rel)
        const_db, n = self._split(nuisance)
        r = np.linalg.norm(rel[..., :3], axis=-1)
        return const_db - 10.0 * n * np.log10(r)

    def affine(self, rel: ArrayLike, t: ArrayLike | None = None,
               rel_ref: ArrayLike | None = None) -> tuple[Array, Array]:
        """Give ``(h0, A_const + A_var)``; see :meth:`MeasurementModel.affine`.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`affine_parts`.

        Returns
        -------
        h0, A : ndarray
            As for :meth:`affine_parts`, with ``A = A_const + A_var``.
        """
        h0, const, var = self.affine_parts(rel, t, rel_ref)
        return h0, const + var

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
        """Split the design; see :meth:`MeasurementModel.affine_parts`.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`MeasurementModel.predict`; only ``rel`` is used.

        Returns
        -------
        h0 : ndarray
            ``(..., n)``: ``-10 n log10 R`` dB with a known exponent, else zeros.
        A_const, A_var : ndarray
            ``(..., n, k)``: ``A_const`` is zero; ``A_var`` has the columns 1 (dB per dB) and,
            with an unknown exponent, ``-10 log10 R`` (dB).
        """
        # P_dB = C_dB + n (-10 log10 R)
        p = as_rel(rel)[..., :3]
        return self._design(dot3(p, p))

    def affine_derivatives(self, rel: ArrayLike, t: ArrayLike | None = None,
                           rel_ref: ArrayLike | None = None
                           ) -> tuple[Array, Array, Array, Array | None, Array | None,
                                      Array | None, Array | None]:
        """Give the affine parts and derivatives; see :meth:`MeasurementModel.affine_derivatives`.

        Parameters
        ----------
        rel, t, rel_ref
            As for :meth:`affine_parts`.

        Returns
        -------
        tuple
            ``(h0, A_const, A_var, dh0, None, dA, None)`` with ``d(-10 n log10 R) / d p =
            -(10 n / ln 10) p / R^2`` (dB/m, position part only) as ``dh0`` when the exponent
            is known (``dA`` None), else in ``dA[..., 1, :]`` with ``n = 1`` (``dh0`` None).
        """
        rel = as_rel(rel)
        p = rel[..., :3]
        r2 = dot3(p, p)
        h0, const, var = self._design(r2)
        # d(-10 n log10 R) / d rel = -(10 n / ln 10) p / R^2 (position part only)
        n = 1.0 if self.exponent is None else self.exponent
        d = np.zeros_like(rel)
        d[..., :3] = p * (-_TEN_OVER_LN10 * n / r2)[..., None]
        if self.exponent is None:
            d_a = np.zeros((*rel.shape[:-1], 2, 6))
            d_a[..., 1, :] = d
            return h0, const, var, None, None, d_a, None
        return h0, const, var, d, None, None, None

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
            ``rel``: ``-(10 n / ln 10) p / R^2``, dB/m (position part only); ``nuisance``: 1
            (dB/dB) and, with an unknown exponent, ``-10 log10 R`` (dB); no reference.

        Raises
        ------
        ValueError
            As for :meth:`predict`.
        """
        rel = as_rel(rel)
        _, n = self._split(nuisance)
        p = rel[..., :3]
        r2 = np.einsum("...i,...i->...", p, p)
        d = np.zeros(rel.shape)
        d[..., :3] = -(_TEN_OVER_LN10 * n / r2)[..., None] * p
        cols = [np.ones(r2.shape)]
        if self.exponent is None:
            cols.append(-5.0 * np.log10(r2))
        return Jacobian(d, None, np.stack(cols, axis=-1))

    def __repr__(self) -> str:
        """Name the kind with its exponent, e.g. ``Power(exponent=2.0)``."""
        return f"Power(exponent={self.exponent})"
