"""What a measurement kind returns and declares: its Jacobian and the values a file may hold."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array


@dataclass(frozen=True)
class Jacobian:
    """Derivatives of predicted values ``(..., n)``, SI value units per m, m/s or nuisance unit.

    Parameters
    ----------
    rel : ndarray
        d value / d relative state, ``(..., n, 6)``.
    rel_ref : ndarray or None
        d value / d relative state at the reference (earlier) sample, or None.
    nuisance : ndarray
        d value / d nuisance parameters, ``(..., n, k)`` (k may be 0).
    """

    rel: Array
    rel_ref: Array | None
    nuisance: Array


@dataclass(frozen=True)
class ValueRange:
    """The values a file may hold for a kind, in the file unit (deg, Hz, m, ...).

    Parameters
    ----------
    noun : str
        The kind's value with its article, as the file checker names it ("a bearing").
    low, high : float or None
        The limits (None: unbounded on that side).
    low_inclusive, high_inclusive : bool
        Whether a value equal to the limit is valid.
    """

    noun: str
    low: float | None = None
    high: float | None = None
    low_inclusive: bool = True
    high_inclusive: bool = True

    def contains(self, values: ArrayLike) -> NDArray[np.bool_]:
        """Tell where values lie in the range.

        Parameters
        ----------
        values : array_like
            Values in the kind's file unit.

        Returns
        -------
        ndarray of bool
            Same shape as ``values``; True where the value lies in the range.
        """
        v = np.asarray(values, dtype=float)
        ok = np.ones(v.shape, dtype=bool)
        if self.low is not None:
            ok &= (v >= self.low) if self.low_inclusive else (v > self.low)
        if self.high is not None:
            ok &= (v <= self.high) if self.high_inclusive else (v < self.high)
        return ok

    def describe(self, unit: str) -> str:
        """Say what a valid value is, as the file checker words it.

        Parameters
        ----------
        unit : str
            The kind's file unit ("deg", "Hz").

        Returns
        -------
        str
            E.g. "a bearing within [-360, 360] deg", "a frequency > 0 Hz".
        """
        if self.low is not None and self.high is not None:
            left = "[" if self.low_inclusive else "("
            right = "]" if self.high_inclusive else ")"
            return f"{self.noun} within {left}{self.low:.10g}, {self.high:.10g}{right} {unit}"
        if self.low is not None:
            return f"{self.noun} {'>=' if self.low_inclusive else '>'} {self.low:g} {unit}"
        if self.high is not None:
            return f"{self.noun} {'<=' if self.high_inclusive else '<'} {self.high:g} {unit}"
        return f"{self.noun} (any value) in {unit}"
