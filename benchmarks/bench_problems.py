"""Problems shared by the speed benchmarks (``run_all.py`` and the per-topic scripts).

Each builder returns a :class:`tmakit.data.MeasurementSet` drawn with a seeded generator, the
truth and a prior, so that tmakit and its peers (FilterPy, a minimal NumPy loop, scipy) are
given exactly the same data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tmakit.data import MeasurementSet

#: Carrier frequency of the emitter in the Doppler problem (Hz), known to the filters.
CARRIER = 1.0e9
#: Speed of light used by tmakit's frequency model (m/s).
C = 299_792_458.0


@dataclass
class FilterProblem:
    """Measurements, truth and a prior for a filter benchmark."""

    name: str
    meas: MeasurementSet
    mean0: np.ndarray
    cov0: np.ndarray
    q: float
    nuisance: dict
    truth0: np.ndarray
    dim: int


def _sensor_paths(times, dim):
    """Two sensors: one on a zig-zag at 10 m/s, one circling at 15 m/s (ENU m, m/s)."""
    a = np.zeros((times.size, 6))
    leg = (times // 120).astype(int)
    heading = np.where(leg % 2 == 0, np.pi / 4, 3 * np.pi / 4)
    a[:, 3] = 10 * np.sin(heading)
    a[:, 4] = 10 * np.cos(heading)
    a[:, 0] = np.concatenate([[0.0], np.cumsum(a[:-1, 3] * np.diff(times))])
    a[:, 1] = np.concatenate([[0.0], np.cumsum(a[:-1, 4] * np.diff(times))])
    b = np.zeros((times.size, 6))
    w = 2 * np.pi / 600.0
    b[:, 0] = 3000 + 1400 * np.cos(w * times)
    b[:, 1] = -2000 + 1400 * np.sin(w * times)
    b[:, 3] = -1400 * w * np.sin(w * times)
    b[:, 4] = 1400 * w * np.cos(w * times)
    if dim == 3:
        a[:, 2] = 300.0
        b[:, 2] = 500.0
    return a, b


def _target(times, dim):
    x0 = np.array([8000.0, 9000.0, 0.0, -6.0, -3.0, 0.0])
    if dim == 3:
        x0[2] = 20.0
    tgt = np.zeros((times.size, 6))
    tgt[:, :3] = x0[:3] + times[:, None] * x0[3:]
    tgt[:, 3:] = x0[3:]
    return x0, tgt


def _rows(kinds_per_sensor, times, paths, tgt, rng):
    """Noisy rows: at each time, each sensor gives its kinds (SI values)."""
    from tmakit.measurements import model_for

    sig = {"bearing": np.radians(1.0), "elevation": np.radians(1.0), "frequency": 1.0}
    cols = {"time": [], "sensor": [], "kind": [], "value": [], "sigma": [], "state": []}
    for k, t in enumerate(times):
        for s, (name, kinds) in enumerate(kinds_per_sensor):
            for kind in kinds:
                model = model_for(kind)
                rel = (tgt[k] - paths[s][k])[None, :]
                nu = np.array([CARRIER]) if kind == "frequency" else None
                z = float(model.predict(rel, np.array([t]), nu)[0])
                z += sig[kind] * rng.standard_normal()
                cols["time"].append(t)
                cols["sensor"].append(name)
                cols["kind"].append(kind)
                cols["value"].append(z)
                cols["sigma"].append(sig[kind])
                cols["state"].append(paths[s][k])
    return MeasurementSet.from_si(np.array(cols["time"]), np.array(cols["sensor"]),
                                  np.array(cols["kind"]), np.array(cols["value"]),
                                  np.array(cols["sigma"]), np.array(cols["state"]))


def filter_problem(case: str, steps: int = 600, seed: int = 0) -> FilterProblem:
    """Build a filter problem.

    ``case``: ``"bf2"`` bearing + frequency from two sensors (2-D, 4 rows per update) or
    ``"be3"`` bearing + elevation from two sensors (3-D, 4 rows per update).
    """
    rng = np.random.default_rng(seed)
    times = np.arange(1.0, steps + 1.0)
    dim = 2 if case == "bf2" else 3
    a, b = _sensor_paths(times, dim)
    x0, tgt = _target(times, dim)
    kinds = ("bearing", "frequency") if case == "bf2" else ("bearing", "elevation")
    meas = _rows((("a", kinds), ("b", kinds)), times, (a, b), tgt, rng)
    keep = [0, 1, 3, 4] if dim == 2 else [0, 1, 2, 3, 4, 5]
    truth0 = x0[keep]
    sd = np.array([300.0] * dim + [3.0] * dim)
    cov0 = np.diag(sd**2)
    mean0 = truth0 + sd * rng.standard_normal(2 * dim)
    nuisance = {"carrier": CARRIER} if case == "bf2" else {}
    return FilterProblem(case, meas, mean0, cov0, 0.01, nuisance, truth0, dim)


def interleaved(funcs, repeats):
    """Time each callable ``repeats`` times, interleaved (one of each per round).

    Returns ``{name: (median, q1, q3)}`` in seconds: the machine is shared, so every figure is
    a median with its interquartile range, measured side by side with its peer.
    """
    import time

    times = {name: [] for name in funcs}
    for _ in range(repeats):
        for name, fn in funcs.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(v)), float(np.percentile(v, 25)),
                   float(np.percentile(v, 75))) for name, v in times.items()}


def fmt(stat, scale=1.0, unit="ms"):
    """Format ``(median, q1, q3)`` (s) times ``scale`` as ``median [q1-q3] unit``."""
    m, lo, hi = (scale * s for s in stat)
    f = ".3g" if m < 100 else ".0f"
    return f"{m:{f}} [{lo:{f}}-{hi:{f}}] {unit}"
