"""Rules that need several rows: time order within each sensor, no far time, no duplicate rows."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..rules import far_times
from .cells import number_text
from .problems import Problems

__all__ = ["check_order"]


def check_order(num: dict[str, NDArray[np.float64]], sensor: NDArray[np.object_],
                kind: NDArray[np.object_], problems: Problems,
                tonal: NDArray[np.str_] | None = None) -> None:
    """Time order within each sensor, no far time, no (sensor, kind, time, time_ref) twice."""
    import pandas as pd

    if "time" not in num or "sensor" not in problems.raw.frame.columns:
        return
    t = num["time"]
    tr = num.get("time_ref", np.full(t.shape[0], np.nan))
    rows = np.flatnonzero(~problems.bad_rows("time", "sensor"))
    far, expected = far_times(np.where(problems.bad_rows("time"), np.nan, t))
    for far_row in np.flatnonzero(far).tolist():
        problems.cell(far_row, "time", expected)
    # codes, not text: equal ids give equal codes, and groupby on integers is light
    table = pd.DataFrame({"sensor": pd.factorize(sensor[rows])[0],
                          "kind": pd.factorize(kind[rows])[0],
                          "time": t[rows], "time_ref": tr[rows], "row": rows,
                          "tonal": 0 if tonal is None else pd.factorize(tonal[rows])[0]})
    by_sensor = table.groupby("sensor", sort=False)
    prev_row = by_sensor["row"].shift().to_numpy()
    prev_time = by_sensor["time"].shift().to_numpy()
    for i in np.flatnonzero(prev_time > table["time"].to_numpy()).tolist():
        row, prev, s = int(rows[i]), int(prev_row[i]), sensor[rows[i]]
        problems.cell(row, "time",
                      f"a time >= {number_text(t[prev])} s, the time of the previous row of "
                      f"sensor '{s}' ({problems.where(prev)})",
                      f"{number_text(t[row])} (time decreases for sensor '{s}')")

    table = table[~problems.bad_rows("kind", "time_ref")[rows]]
    key = ["sensor", "kind", "time", "time_ref", "tonal"]
    first = table.groupby(key, sort=False, dropna=False)["row"].transform("first")
    for row, prev in zip(table["row"].to_numpy(), first.to_numpy(), strict=True):
        if row == prev:
            continue
        ref = "" if math.isnan(tr[row]) else f", time_ref {number_text(tr[row])}"
        problems.cell(int(row), "time", "one row per (sensor, kind, time, time_ref)",
                      f"a duplicate of {problems.where(int(prev))} (sensor '{sensor[row]}', "
                      f"kind '{kind[row]}', time {number_text(t[row])}{ref})")
