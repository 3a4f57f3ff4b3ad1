"""The solution page's figures in a real headless Chromium (issue 29: the page).

* open: from navigation start to the page ready and painted (``performance.now()`` in the page
  at the first animation frame after the page's model has drawn the ML solution's dots), for a
  page of ``--cuts`` bearings (10,000 by default), over ``--repeat`` fresh loads;
* drag: a real mouse drag of the solution's position handle (selenium's pointer actions, 20
  moves); for each move the page records, with ``performance.now()``, the time from the mouse
  event (its ``timeStamp``) to the end of the repaint of every plot the update changed
  (Bokeh's ``repainted``: the dots, the track and handles; the chi-square is text)
  (``painted_ms``), and the computation alone (``compute_ms``); while the mouse drags a
  panel draws at most about :data:`~tmakit.plot.page.DRAG_DOTS` dots, every dot again once the
  drag stops (that last update is timed apart).

Both are wall-clock times in the page, and on a loaded machine the page's thread waits for a core:
the main thread's CPU time (Chromium's ``TaskDuration`` in thread ticks, from the DevTools
Performance domain) is printed beside them, for the opening and per drag update (the drag's
whole CPU time, its last update included, over its updates), as the figure the load hides least.

Needs Debian's ``chromium`` and ``chromium-driver`` (``.ci/run`` installs them) and selenium
(the test extra).  Medians and maxima; the machine's load is printed beside them.

    PYTHONPATH=src python benchmarks/solution_page.py [--cuts 10000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import tmakit as tk
from tmakit.plot.page import write_solution_page

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from browser import (
    CHROMIUM,
    chromium,
    console_errors,
    drag_handle,
    open_page,
    painted,
)


def cuts(n: int, seed: int = 1) -> tk.MeasurementSet:
    """``n`` bearings (1 deg) of a CV contact from a weaving own ship over 6 h, seeded."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 6 * 3600.0, n)
    state = np.zeros((n, 6))
    state[:, 0] = 3000.0 * np.sin(t / 900.0)
    state[:, 1] = 4.0 * t
    state[:, 3] = 3000.0 / 900.0 * np.cos(t / 900.0)
    state[:, 4] = 4.0
    truth = tk.ConstantVelocity(2).states(np.array([20000.0, 30000.0, -3.0, 1.0]), t)
    b = np.arctan2(truth[:, 0] - state[:, 0], truth[:, 1] - state[:, 1])
    sigma = np.full(n, np.radians(1.0))
    meta = {"origin_lat": "50.0", "origin_lon": "-4.0", "origin_alt": "0.0",
            "time_origin": "2026-05-04T06:00:00Z"}
    return tk.MeasurementSet.from_si(t, np.full(n, "OWNSHIP"), np.full(n, "bearing"),
                                     b + sigma * rng.normal(size=n), sigma, state,
                                     metadata=meta)


def main_thread_ms(driver: Any) -> float:
    """The page's main-thread CPU time so far (ms; Chromium's TaskDuration in thread ticks)."""
    metrics = driver.execute_cdp_cmd("Performance.getMetrics", {})["metrics"]
    return 1000.0 * next(m["value"] for m in metrics if m["name"] == "TaskDuration")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cuts", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    if CHROMIUM is None:
        raise SystemExit("no chromium binary: apt-get install -y chromium chromium-driver")
    meas = cuts(args.cuts)
    result = tk.estimate(meas, tk.ConstantVelocity(2, ref_time=3 * 3600.0))
    with tempfile.TemporaryDirectory() as folder:
        path = write_solution_page(meas, result, Path(folder) / "page.html")
        size = path.stat().st_size
        opened, drags, computes, stops, cpu_open, cpu_drag = [], [], [], [], [], []
        with chromium() as driver:
            driver.execute_cdp_cmd("Performance.enable", {"timeDomain": "threadTicks"})
            for _ in range(args.repeat):
                open_page(driver, path)
                opened.append(painted(driver))
                cpu_open.append(main_thread_ms(driver))  # a new page starts from zero
                t = drag_handle(driver)
                if t:  # (a drag that recorded no update has no CPU per update)
                    cpu_drag.append((main_thread_ms(driver) - cpu_open[-1]) / len(t))
                drags += [x["painted_ms"] for x in t if x["drag"]]
                computes += [x["compute_ms"] for x in t if x["drag"]]
                stops += [x["painted_ms"] for x in t if not x["drag"]]
            errors = console_errors(driver)
    print(f"page: {args.cuts} cuts ({result.status}, chi2/dof {result.chi2 / result.dof:.2f}), "
          f"{size / 1e6:.2f} MB, Chromium {CHROMIUM}; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"open (navigation start to ready and painted): median {np.median(opened):.0f} ms, "
          f"min {np.min(opened):.0f} ms, max {np.max(opened):.0f} ms over {len(opened)} loads "
          f"(goal <= 1000 ms); main-thread CPU median {np.median(cpu_open):.0f} ms")
    print(f"drag (mouse event to dots, track and chi2 painted): median {np.median(drags):.1f} "
          f"ms, 95th percentile {np.percentile(drags, 95):.1f} ms, max {np.max(drags):.1f} ms "
          f"over {len(drags)} updates (goal <= 50 ms); computation alone median "
          f"{np.median(computes):.2f} ms; main-thread CPU per update median "
          f"{np.median(cpu_drag):.1f} ms")
    print(f"drag stopped (every dot drawn again): median {np.median(stops):.1f} ms over "
          f"{len(stops)} drags")
    print(f"console errors: {len(errors)}")


if __name__ == "__main__":
    main()
