"""The measured values of a Debrief replay's cuts: bearings, ranges and frequencies as rows.

Each cut gives a ``bearing`` row (degrees true, wrapped), a ``range`` row (yards to m) and a
``frequency`` row (Hz) where its field is not ``NULL``.  A ``;SENSOR3:`` line's accuracy is the
sigma of its bearing or frequency unless the user gave that kind's sigma.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
from numpy.typing import NDArray

from .debrief_fixes import at_line
from .debrief_lines import SensorLine
from .logs import YARD

__all__ = ["RANGES_CHOICES", "cut_rows", "placeholder_ranges"]

#: The values of ``ranges=``: None (placeholders left out), ``use`` or ``ignore``.
RANGES_CHOICES = ("use", "ignore")


def placeholder_ranges(rows: list[SensorLine], ranges: str | None,
                       notes: list[str]) -> NDArray[np.bool_]:
    """Mark the cuts whose range is left out (a placeholder, or ``ranges="ignore"``)."""
    value = np.array([np.nan if s.range_yd is None else s.range_yd for s in rows], float)
    stated = np.isfinite(value)
    if ranges == "use" or not stated.any():
        return np.zeros(len(rows), bool)
    if ranges == "ignore":
        notes.append(f"note: {int(stated.sum())} range(s) left out (--ranges ignore)")
        return stated
    drop = stated & (value == 0)
    if drop.any():
        notes.append(f"note: {int(drop.sum())} range(s) of 0 yd left out: a placeholder, not a "
                     "measurement (--ranges use to fit them anyway)")
    rest = value[stated & ~drop]
    if rest.size >= 2 and np.all(rest == rest[0]):
        notes.append(f"note: the {rest.size} ranges left out: every cut states {rest[0]:g} yd, "
                     "a plotting default rather than a measurement (--ranges use to fit them "
                     "anyway)")
        drop = stated
    return drop


def cut_rows(rows: list[SensorLine], states: NDArray[np.float64], t: NDArray[np.float64],
             sigmas: dict[str, float], asked: set[str], kinds: Collection[str],
             no_range: NDArray[np.bool_]
             ) -> tuple[list, list, list, list, list, list, list, list]:
    """Return the (time, kind, SI value, SI sigma, state, line, twin, tonal) of each value used."""
    out: tuple[list, ...] = ([], [], [], [], [], [], [], [])
    for k, s in enumerate(rows):
        stated = {"bearing": None if s.bearing_accuracy is None
                  else float(np.deg2rad(s.bearing_accuracy)),
                  "frequency": s.frequency_accuracy}
        for kind, value in (("bearing", s.bearing), ("range", s.range_yd),
                            ("frequency", s.frequency)):
            if value is None or kind not in kinds or (kind == "range" and no_range[k]):
                continue
            si = (float(np.deg2rad(value)) if kind == "bearing"
                  else value * YARD if kind == "range" else value)
            line_sigma = stated.get(kind)
            sigma = sigmas[kind] if line_sigma is None or kind in asked else line_sigma
            twin = (float(np.deg2rad(s.ambiguous)) if kind == "bearing"
                    and s.ambiguous is not None else np.nan)
            tonal = s.sensor if kind == "frequency" else ""  # a sensor's tonal line
            for col, item in zip(out, (t[k], kind, si, sigma, states[k], at_line(s), twin,
                                       tonal), strict=True):
                col.append(item)
    return out  # type: ignore[return-value]
