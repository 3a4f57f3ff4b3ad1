"""Sample times of a scenario file: ``start, start + step, ...`` up to ``stop``, bounded.

A ``times`` table asks for ``(stop - start) / step + 1`` rows; more than :func:`max_samples`
(``TMA_MAX_SAMPLES``, default 2,000,000) is refused before anything is simulated.
"""

from __future__ import annotations

import math
import os

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["TimeRange", "max_samples"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)  # NaN/inf: refused


class TimeRange(_Strict):
    """Sample times ``start, start + step, ...`` up to and including ``stop`` (s).

    ``start``, ``stop`` (s; ``stop`` included to 1e-9 of a step), ``step`` (s, > 0).
    """

    start: float
    stop: float
    step: float = Field(gt=0)

    def values(self) -> np.ndarray:
        """Give the sample times (s)."""
        n = math.floor((self.stop - self.start) / self.step + 1e-9) + 1
        if n < 1:
            raise ValueError("stop is before start")
        if n > max_samples():
            raise ValueError(f"{n:,} sample times (start {self.start:g}, stop {self.stop:g}, "
                             f"step {self.step:g} s): more than the limit of "
                             f"{max_samples():,}; raise it with TMA_MAX_SAMPLES=N")
        return self.start + self.step * np.arange(n)


def max_samples() -> int:
    """Give the most sample times one ``times`` range may ask for (``TMA_MAX_SAMPLES``)."""
    try:
        return max(1, int(os.environ.get("TMA_MAX_SAMPLES", "2000000")))
    except ValueError:
        return 2_000_000
