"""Frequency difference of arrival between two sensors at one time (FDOA).

``fdoa = -(f0 / c) (rdot - rdot_ref)``, Ho & Xu (2004); the carrier ``f0`` is known or a linear
nuisance parameter.  The noise is that of :mod:`tmakit.measurements.tdoa`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.units import SPEED_OF_LIGHT
from .base import Jacobian, as_rel
from .range_rate import range_rate_and_gradient
from .tdoa import BetweenSensors

__all__ = ["Fdoa"]


class Fdoa(BetweenSensors):
    """Frequency difference of arrival, Hz (also in files): sensor minus reference sensor.

    Parameters
    ----------
    carrier : float, optional
        The known carrier ``f0``, Hz; None (default): the nuisance parameter ``carrier``.
    noise : str, optional
        ``"shared"`` (default) or ``"independent"``, as for :class:`~.tdoa.Tdoa`.
    speed_of_light : float, optional
        Propagation speed ``c``, m/s.

    Raises
    ------
    ValueError
        If ``carrier`` is not a positive finite number, or ``noise`` is not a noise form.

    References
    ----------
    Ho & Xu (2004) (TDOA and FDOA of a moving source); Gu et al. (2007), eqs. 5-6.
    """

    kind = "fdoa"
    file_unit = "Hz"
    uses_velocity = True

    def __init__(self, carrier: float | None = None, noise: str = "shared",
                 speed_of_light: float = SPEED_OF_LIGHT) -> None:
        if carrier is not None and not (math.isfinite(float(carrier)) and float(carrier) > 0):
            raise ValueError(f"fdoa: the carrier must be a positive frequency (Hz), found "
                             f"{carrier!r}")
        super().__init__(noise, speed_of_light)
        self.carrier = None if carrier is None else float(carrier)

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give the carrier (``# fdoa_carrier: HZ``) and noise form a file's metadata states."""
        out = super().options_from_metadata(metadata)
        if metadata.get("fdoa_carrier", "").strip():
            try:
                out["carrier"] = float(metadata["fdoa_carrier"])
            except ValueError:
                raise ValueError("metadata fdoa_carrier: expected the carrier in Hz, found "
                                 f"{metadata['fdoa_carrier']!r}") from None
        return out

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """``("carrier",)`` when the carrier is unknown, else none."""
        return () if self.carrier is not None else ("carrier",)

    def _scale(self, nuisance: ArrayLike | None) -> Array:
        if self.carrier is not None:
            return np.asarray(-self.carrier / self.c)
        if nuisance is None:
            raise ValueError("fdoa: the carrier (nuisance parameter) is needed")
        nu = np.asarray(nuisance, dtype=float)
        if nu.shape[-1] != 1:
            raise ValueError(f"fdoa: expected nuisance (carrier,), got shape {nu.shape}")
        return -nu[..., 0] / self.c

    def _rate_difference(self, rel: Array, rel_ref: ArrayLike | None
                         ) -> tuple[Array, Array, Array]:
        if rel_ref is None:
            raise ValueError(self._needs())
        rdot, grad = range_rate_and_gradient(rel)
        rdot_ref, grad_ref = range_rate_and_gradient(as_rel(rel_ref))
        return rdot - rdot_ref, grad, grad_ref

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict frequency differences, Hz; see :meth:`MeasurementModel.predict`."""
        diff, _, _ = self._rate_difference(as_rel(rel), rel_ref)
        return self._scale(nuisance) * diff

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rel = as_rel(rel)
        diff, grad, grad_ref = self._rate_difference(rel, rel_ref)
        scale = self._scale(nuisance)[..., None]
        d_nu = (np.zeros((*rel.shape[:-1], 0)) if self.carrier is not None
                else (-diff / self.c)[..., None])
        return Jacobian(scale * grad, -scale * grad_ref, d_nu)

    def affine_parts(self, rel: ArrayLike, t: ArrayLike | None = None,
                     rel_ref: ArrayLike | None = None) -> tuple[Array, Array, Array]:
        """Split the design; see :meth:`MeasurementModel.affine_parts`."""
        rel = as_rel(rel)
        diff, _, _ = self._rate_difference(rel, rel_ref)
        if self.carrier is not None:
            empty = np.zeros((*rel.shape[:-1], 0))
            return self._scale(None) * diff, empty, empty
        a = (-diff / self.c)[..., None]
        return np.zeros(diff.shape), np.zeros(a.shape), a

    def __repr__(self) -> str:
        """Name the kind with its carrier and noise form."""
        return f"Fdoa(carrier={self.carrier!r}, noise={self.noise!r})"
