"""Per-step cost of the step-by-step API (one ``predict`` and one ``update`` per measurement time).

A live tracker, or Stone Soup calling tmakit, does not hand over a whole file: it calls
``predict(t)`` and ``update(rows)`` once per measurement time.  This times that loop for
tmakit's EKF beside FilterPy's ``ExtendedKalmanFilter`` (``predict``; ``update`` with the
analytic Jacobian and a wrapping residual) on the same data, prior and nearly-constant-velocity
``Phi``/``Q`` (Chen & Sun, §2.1):

* ``b2``: ``bearings-only-2d`` (600 bearings, 1 Hz, one sensor, 2-D);
* ``be3``: bearing + elevation from two moving sensors, 3-D (``bench_problems``, 4 rows/update).

tmakit gets each update's rows as a ``MeasurementSet`` cut beforehand (``take``), as a live
feed delivers them; FilterPy gets the arrays.  Process CPU time per step = total / updates;
interleaved repeats, median [interquartile range].  The final states are printed with their
largest difference (the same equations: they agree to rounding).

    PYTHONPATH=src python benchmarks/filters_step_api.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_problems import filter_problem
from filters_general_speed import h_and_jac, wrap

import tmakit as tk
from tmakit.filters import ExtendedKalmanFilter
from tmakit.motion.dynamics import process_noise, transition_matrix


def bearing_problem():
    """``bearings-only-2d``: measurements, prior, q, and the per-update rows and arrays."""
    meas = tk.load_scenario("bearings-only-2d").simulate(rng=3)
    order = np.argsort(meas.time, kind="stable")
    rows = [meas.take(order[k:k + 1]) for k in range(len(meas))]
    mean0 = np.array([2000.0, 9000.0, 0.0, 0.0])
    cov0 = np.diag([1e6, 1e6, 25.0, 25.0])
    arrays = (meas.time[order], meas.value_si[order], meas.sensor_state[order],
              meas.sigma_si[order])
    return rows, mean0, cov0, 0.01, {}, arrays


def two_sensor_problem():
    """``be3`` of ``bench_problems``: the same pieces."""
    p = filter_problem("be3")
    m = p.meas
    order = np.argsort(m.time, kind="stable")
    rows = [m.take(order[4 * k:4 * k + 4]) for k in range(len(m) // 4)]
    t = m.time[order].reshape(-1, 4)[:, 0]
    return rows, p.mean0, p.cov0, p.q, p.nuisance, (
        t, m.value_si[order].reshape(-1, 4), m.sensor_state[order].reshape(-1, 4, 6),
        np.diag(m.sigma_si[order][:4] ** 2))


def tmakit_steps(rows, mean0, cov0, q, nuisance):
    f = ExtendedKalmanFilter(mean0, cov0, 0.0, q=q, nuisance=nuisance)
    for r in rows:
        f.predict(float(r.time.max()))
        f.update(r)
    return f.state


def filterpy_b2(mean0, cov0, q, arrays):
    from filterpy.kalman import ExtendedKalmanFilter as FpEKF

    t, z, sens, sig = arrays
    f = FpEKF(dim_x=4, dim_z=1)
    f.x, f.P = mean0.copy(), cov0.copy()
    f.F, f.Q = transition_matrix(1.0, 2), process_noise(1.0, q, 2)

    def jac(x, s):
        dx, dy = x[0] - s[0], x[1] - s[1]
        r2 = dx * dx + dy * dy
        return np.array([[dy / r2, -dx / r2, 0.0, 0.0]])

    def hx(x, s):
        return np.array([np.arctan2(x[0] - s[0], x[1] - s[1])])

    def residual(a, b):
        return wrap(a - b)

    for k in range(t.size):
        f.predict()
        f.R = np.array([[sig[k] ** 2]])
        f.update(z[k:k + 1], jac, hx, args=(sens[k],), hx_args=(sens[k],), residual=residual)
    return f.x


def filterpy_be3(mean0, cov0, q, arrays):
    from filterpy.kalman import ExtendedKalmanFilter as FpEKF

    t, z, sens, r = arrays
    f = FpEKF(dim_x=6, dim_z=4)
    f.x, f.P = mean0.copy(), cov0.copy()
    f.F, f.Q, f.R = transition_matrix(1.0, 3), process_noise(1.0, q, 3), r

    def residual(a, b):
        return wrap(a - b)

    for k in range(t.size):
        f.predict()
        f.update(z[k], lambda x, s=sens[k]: h_and_jac("be3", x, s)[1],
                 lambda x, s=sens[k]: h_and_jac("be3", x, s)[0], residual=residual)
    return f.x


def measure(repeat: int = 7) -> list[tuple[str, float, float, float, float]]:
    """Rows ``(case, tmakit us/step, its IQR, FilterPy us/step, its IQR, largest diff)``."""
    out = []
    for case, build, peer in (("b2", bearing_problem, filterpy_b2),
                              ("be3", two_sensor_problem, filterpy_be3)):
        rows, mean0, cov0, q, nuisance, arrays = build()
        k = len(rows)
        times: dict[str, list[float]] = {"tmakit": [], "filterpy": []}
        for _ in range(repeat):
            t0 = time.process_time()
            xa = tmakit_steps(rows, mean0, cov0, q, nuisance)
            times["tmakit"].append(time.process_time() - t0)
            t0 = time.process_time()
            xb = peer(mean0, cov0, q, arrays)
            times["filterpy"].append(time.process_time() - t0)
        stats = {n: np.percentile(np.array(v) / k * 1e6, [25, 50, 75]) for n, v in times.items()}
        out.append((case, stats["tmakit"], stats["filterpy"], float(np.max(np.abs(xa - xb)))))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    print(f"{'case':5s} {'tmakit us/step':>24s} {'FilterPy us/step':>24s} {'ratio':>6s} "
          f"{'max |dx|':>9s}")
    for case, a, b, diff in measure(args.repeat):
        print(f"{case:5s} {a[1]:8.1f} [{a[0]:6.1f}, {a[2]:6.1f}] "
              f"{b[1]:8.1f} [{b[0]:6.1f}, {b[2]:6.1f}] {a[1] / b[1]:6.2f} {diff:9.2e}")
    print("process CPU time per step, median [interquartile range] of interleaved repeats")


if __name__ == "__main__":
    main()
