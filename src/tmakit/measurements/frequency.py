"""Doppler-shifted frequency with an unknown carrier, ``f = f_c(t) (1 - rdot / c)``.

The carrier (optionally drifting linearly, Hz and Hz/s) is a linear nuisance parameter; ``c``
is light's speed for a radio emitter, sound's for a sonar tonal (about 1500 m/s in sea water).
Gu et al. (2007), eqs. 5-6 and §5; the Doppler-tracking lecture notes use the opposite sign,
tmakit the physical one (an approaching emitter is heard higher).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array
from ..core.keywords import NOT_GIVEN, NotGiven, renamed_keyword
from ..core.units import SPEED_OF_LIGHT
from .base import Jacobian, MeasurementModel, ValueRange, as_rel, dot3
from .range_rate import range_rate, range_rate_and_gradient, range_rate_row

#: What a propagation speed must be (no wave outruns light).
PROPAGATION_SPEED = f"expected a speed within (0, {SPEED_OF_LIGHT:.0f}] m/s (light's)"


class Frequency(MeasurementModel):
    """Received carrier frequency ``f_c(t) (1 - rdot / c)``, Hz (also in files).

    Parameters
    ----------
    drift : bool, optional
        Add the nuisance ``carrier_drift`` (Hz/s) to ``carrier`` (Hz).
    propagation_speed : float, optional
        Propagation speed ``c``, m/s: light (default) for radio, about 1500 for sonar.
    speed_of_light : float, optional
        Deprecated name of ``propagation_speed``.

    References
    ----------
    Gu et al. (2007), eqs. 5-6 and §5 (the carrier drift); the Doppler-tracking lecture notes.
    """

    kind = "frequency"
    file_unit = "Hz"
    mirror_symmetric = True
    uses_velocity = True
    value_range = ValueRange("a frequency", 0.0, 1e15, low_inclusive=False)
    nuisance_by_tonal = True

    def __init__(self, drift: bool = False, propagation_speed: float = SPEED_OF_LIGHT, *,
                 speed_of_light: float | NotGiven = NOT_GIVEN) -> None:
        c = renamed_keyword("Frequency", "speed_of_light", speed_of_light, "propagation_speed",
                            propagation_speed, SPEED_OF_LIGHT)
        if not 0 < c <= SPEED_OF_LIGHT:
            raise ValueError(f"frequency: propagation speed {c!r}: {PROPAGATION_SPEED}")
        self.drift = bool(drift)
        self.c = float(c)

    @classmethod
    def options_from_metadata(cls, metadata: Mapping[str, str]) -> dict[str, object]:
        """Give ``propagation_speed`` (m/s) where metadata ``frequency_propagation_speed`` says."""
        text = metadata.get("frequency_propagation_speed", "").strip()
        if not text:
            return {}
        try:
            c = float(text)
        except ValueError:
            c = float("nan")
        if not 0 < c <= SPEED_OF_LIGHT:
            raise ValueError(f"metadata frequency_propagation_speed: {PROPAGATION_SPEED}, found "
                             f"{text!r}")
        return {"propagation_speed": c}

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """``("carrier",)``, or ``("carrier", "carrier_drift")`` with drift (Hz, Hz/s)."""
        return ("carrier", "carrier_drift") if self.drift else ("carrier",)

    def default_nuisance(self) -> dict[str, float]:
        """Give the default nuisance: a drift of 0 Hz/s; the carrier has none."""
        return {"carrier_drift": 0.0}

    def _carrier(self, t: ArrayLike | None, nuisance: ArrayLike,
                 shape: tuple[int, ...]) -> Array:
        nu = np.asarray(nuisance, dtype=float)
        if nu.shape[-1] != len(self.nuisance_names):
            raise ValueError(f"frequency: expected nuisance ({', '.join(self.nuisance_names)}),"
                             f" got shape {nu.shape}")
        if nu.ndim == 1 and not self.drift:  # one carrier for every row
            return nu[0]
        carrier = nu[..., 0]
        if self.drift:
            if t is None:
                raise ValueError("frequency with carrier drift needs the sample times")
            carrier = carrier + nu[..., 1] * np.asarray(t, dtype=float)
        return np.broadcast_to(carrier, shape)

    def predict(self, rel: ArrayLike, t: ArrayLike | None = None,
                nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None) -> Array:
        """Predict received frequencies, Hz; see :meth:`MeasurementModel.predict`."""
        rel = as_rel(rel)
        if nuisance is None:
            raise ValueError("frequency: the carrier (nuisance parameter) is needed")
        rdot = range_rate(rel)
        return self._carrier(t, nuisance, rdot.shape) * (1.0 - rdot / self.c)

    def _design(self, small: Array, t: ArrayLike | None) -> tuple[Array, Array, Array]:
        """Give ``(h0, A_const, A_var)`` from ``small = -rdot / c``."""
        ones = np.ones((*small.shape, 1))
        if not self.drift:
            return np.zeros(small.shape), ones, small[..., None]
        tt = np.broadcast_to(np.asarray(t, dtype=float), small.shape)
        return (np.zeros(small.shape), np.stack([ones[..., 0], tt], axis=-1),
                np.stack([small, small * tt], axis=-1))

    def affine_parts(self, rel: ArrayLike, t: ArrayLike | None = None,
                     rel_ref: ArrayLike | None = None) -> tuple[Array, Array, Array]:
        """Split the design; see :meth:`MeasurementModel.affine_parts`."""
        # f = carrier (1 - rdot/c) [+ drift t (1 - rdot/c)]
        rel = as_rel(rel)
        p = rel[..., :3]
        small = dot3(p, rel[..., 3:]) / np.sqrt(dot3(p, p)) * (-1.0 / self.c)
        return self._design(small, t)

    def affine_derivatives(self, rel: ArrayLike, t: ArrayLike | None = None,
                           rel_ref: ArrayLike | None = None
                           ) -> tuple[Array, Array, Array, Array | None, Array | None,
                                      Array | None, Array | None]:
        """Give the affine parts and their derivatives in one pass."""
        # h0 = 0 (no derivative); A_var = (small, small t) with small = -rdot / c.
        rel = as_rel(rel)
        small, d_small = range_rate_and_gradient(rel, -1.0 / self.c)
        h0, const, var = self._design(small, t)
        if not self.drift:
            return h0, const, var, None, None, d_small[..., None, :], None
        tt = np.asarray(t, dtype=float)[:, None]
        return h0, const, var, None, None, np.stack([d_small, d_small * tt], axis=-2), None

    def jacobian(self, rel: ArrayLike, t: ArrayLike | None = None,
                 nuisance: ArrayLike | None = None, rel_ref: ArrayLike | None = None
                 ) -> Jacobian:
        """Give the derivatives of :meth:`predict`; see :meth:`MeasurementModel.jacobian`."""
        rdot, _, d_rel = self._rate_carrier_gradient(as_rel(rel), t, nuisance)
        scale = 1.0 - rdot / self.c
        cols = [scale]
        if self.drift:
            cols.append(scale * np.asarray(t, dtype=float))
        return Jacobian(d_rel, None, np.stack(cols, axis=-1))

    def values_and_derivatives_into(self, rel: Array, t: Array | None, values: Array,
                                    d_rel: Array, nuisance: Array | None = None) -> None:
        """Write frequencies and their derivatives (the operations of :meth:`jacobian`)."""
        rdot, carrier, d_rel[...] = self._rate_carrier_gradient(rel, t, nuisance)
        np.multiply(carrier, 1.0 - rdot / self.c, out=values)

    def _rate_carrier_gradient(self, rel: Array, t: ArrayLike | None,
                               nuisance: ArrayLike | None) -> tuple[Array, Array, Array]:
        """Give the range rate, the carrier and d frequency / d ``rel``."""
        if nuisance is None:
            raise ValueError("frequency: the carrier (nuisance parameter) is needed")
        rdot, grad = range_rate_and_gradient(rel)
        carrier = self._carrier(t, nuisance, rdot.shape)
        grad *= (carrier / -self.c)[..., None]
        return rdot, carrier, grad

    has_row_gradient = True

    def row_gradient(self, rel: tuple[float, ...], t: float, nuisance: tuple[float, ...]
                     ) -> tuple[float, ...]:
        """Give :meth:`predict` and :meth:`jacobian`'s ``rel`` for one row in plain floats."""
        rdot, g0, g1, g2, g3, g4, g5 = range_rate_row(rel)
        carrier = nuisance[0] + nuisance[1] * t if self.drift else nuisance[0]
        k = carrier / -self.c
        return (carrier * (1.0 - rdot / self.c), g0 * k, g1 * k, g2 * k, g3 * k, g4 * k,
                g5 * k)

    def __repr__(self) -> str:
        """Name the kind with its options: ``Frequency(drift=False, propagation_speed=1500)``."""
        return f"Frequency(drift={self.drift}, propagation_speed={self.c:g})"
