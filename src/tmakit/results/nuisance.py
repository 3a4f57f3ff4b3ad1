"""Which nuisance parameters are known: one type, :class:`KnownNuisance` (None: all unknown)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["KnownNuisance"]


@dataclass(frozen=True)
class KnownNuisance:
    """The nuisance parameters are known (held, not estimated), at ``values``; always true.

    Parameters
    ----------
    values : Mapping[str, float], optional
        ``carrier`` (Hz), ``carrier_drift`` (Hz/s), ``power_constant_db`` (dB),
        ``path_loss_exponent``; names left out come from the context.
    """

    values: Mapping[str, float] = field(default_factory=dict, hash=False)

    def __post_init__(self) -> None:
        """Copy the values into a ``dict`` of floats."""
        object.__setattr__(self, "values",
                           {str(k): float(v) for k, v in dict(self.values).items()})

    def __bool__(self) -> bool:
        """Return True: the nuisance is known."""
        return True

    def over(self, context: Mapping[str, float]) -> dict[str, float]:
        """Return ``{**context, **self.values}``.

        Parameters
        ----------
        context : Mapping[str, float]

        Returns
        -------
        dict[str, float]
        """
        return {**dict(context), **self.values}


KnownNuisanceLike = KnownNuisance | Mapping[str, float] | bool | None
"""What public functions accept as ``known_nuisance``; :func:`as_known_nuisance` converts it."""


def as_known_nuisance(value: KnownNuisanceLike) -> KnownNuisance | None:
    """Convert ``known_nuisance`` (None/False: unknown; True: known; a mapping: these values)."""
    if value is None:
        return None
    if isinstance(value, bool | np.bool_):
        return KnownNuisance() if value else None
    if isinstance(value, KnownNuisance):
        return value
    if isinstance(value, Mapping):
        return KnownNuisance(value)
    raise TypeError("known_nuisance must be a KnownNuisance, a mapping of nuisance values, "
                    f"True, False or None; got {type(value).__name__}")
