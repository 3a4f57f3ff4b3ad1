"""Per-step speed of tmakit's general filter path beside FilterPy and a minimal NumPy loop.

Two problems (``bench_problems.filter_problem``), 600 updates each, four rows per update:

* ``bf2``: bearing + frequency from two moving sensors, 2-D (carrier known, 1 GHz);
* ``be3``: bearing + elevation from two moving sensors, 3-D.

tmakit runs its general path (any kinds, any sensors).  The peers get the same data, prior and
nearly-constant-velocity ``Phi``/``Q`` (Chen & Sun, §2.1):

* FilterPy's ``ExtendedKalmanFilter`` (``predict``; ``update`` with the analytic Jacobian and
  a wrapping residual) and ``UnscentedKalmanFilter`` (``MerweScaledSigmaPoints`` with tmakit's
  alpha = 1, beta = 2, kappa = 0; circular mean of the bearing sigma points);
* a minimal NumPy EKF loop written here for each problem: the fixed ``Phi``/``Q`` built once,
  predictions and Jacobian by hand for the four rows, ``S``, ``K`` by ``numpy.linalg.solve``,
  Joseph-form covariance.

Timing: ``filter.run(meas)`` whole for tmakit (the track's arrays included); each peer's loop
over updates with arrays prepared beforehand.  A set is prepared for the filters on its first
run and the compiled plan kept with it; the rows ``first run`` time tmakit on a new copy of the
set each time (compilation and plan included).  Per step = total / updates; interleaved
repeats, median [interquartile range]; ``--clock cpu`` (default) is the process CPU time, less
disturbed by other work on a shared machine than ``--clock wall``.  The final estimates are
printed with their largest difference to tmakit's (they solve the same equations, so they
agree to rounding).

    PYTHONPATH=src python benchmarks/filters_general_speed.py [--repeat 7] [--steps 600]
        [--clock cpu]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_problems import CARRIER, C, filter_problem, fmt

from tmakit.filters import ExtendedKalmanFilter, UnscentedKalmanFilter
from tmakit.motion.dynamics import process_noise, transition_matrix


def arrays(p):
    """Per-update arrays for the peers: times (K,), values (K, 4), sensors (K, 4, 6), R."""
    m = p.meas
    order = np.argsort(m.time, kind="stable")
    t = m.time[order].reshape(-1, 4)[:, 0]
    z = m.value_si[order].reshape(-1, 4)
    s = m.sensor_state[order].reshape(-1, 4, 6)
    r = np.diag(m.sigma_si[order][:4] ** 2)
    return t, z, s, r


def h_and_jac(case, x, sens):
    """Predictions (4,) and Jacobian (4, n) of [bearing, second kind] x 2 sensors, by hand."""
    dim = 2 if case == "bf2" else 3
    n = 2 * dim
    pos = sens[::2, :dim]  # the two sensors (rows 0 and 2)
    d = x[None, :dim] - pos
    dx, dy = d[:, 0], d[:, 1]
    rho2 = dx * dx + dy * dy
    h = np.empty(4)
    jac = np.zeros((4, n))
    h[0::2] = np.arctan2(dx, dy)
    jac[0::2, 0] = dy / rho2
    jac[0::2, 1] = -dx / rho2
    if case == "bf2":
        v = x[None, 2:] - sens[::2, 3:5]
        r = np.sqrt(rho2)
        u = d / r[:, None]
        rdot = np.sum(u * v, axis=1)
        h[1::2] = CARRIER * (1 - rdot / C)
        jac[1::2, :2] = -CARRIER / C * (v - rdot[:, None] * u) / r[:, None]
        jac[1::2, 2:] = -CARRIER / C * u
    else:
        dz = d[:, 2]
        rho = np.sqrt(rho2)
        r2 = rho2 + dz * dz
        h[1::2] = np.arctan2(dz, rho)
        jac[1::2, 0] = -dz * dx / (rho * r2)
        jac[1::2, 1] = -dz * dy / (rho * r2)
        jac[1::2, 2] = rho / r2
    return h, jac


def wrap(a):
    """Wrap angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def angle_rows(case):
    """Which of the four rows are angles."""
    return np.array([True, False, True, False]) if case == "bf2" else np.ones(4, bool)


def numpy_loop(p, data):
    """The minimal NumPy EKF: Phi and Q once, hand predictions, solve, Joseph form."""
    t, z, sens, r = data
    n = 2 * p.dim
    phi, q = transition_matrix(1.0, p.dim), process_noise(1.0, p.q, p.dim)
    ang = angle_rows(p.name)
    eye = np.eye(n)
    x, cov = p.mean0.copy(), p.cov0.copy()
    for k in range(t.size):
        x = phi @ x
        cov = phi @ cov @ phi.T + q
        h, jac = h_and_jac(p.name, x, sens[k])
        y = z[k] - h
        y[ang] = wrap(y[ang])
        ph = cov @ jac.T
        s = jac @ ph + r
        gain = np.linalg.solve(s, ph.T).T
        x = x + gain @ y
        i_kh = eye - gain @ jac
        cov = i_kh @ cov @ i_kh.T + gain @ r @ gain.T
    return x


def filterpy_ekf(p, data):
    """FilterPy's ExtendedKalmanFilter on the same problem."""
    from filterpy.kalman import ExtendedKalmanFilter as FpEKF

    t, z, sens, r = data
    n = 2 * p.dim
    ang = angle_rows(p.name)
    f = FpEKF(dim_x=n, dim_z=4)
    f.x, f.P = p.mean0.copy(), p.cov0.copy()
    f.F, f.Q, f.R = transition_matrix(1.0, p.dim), process_noise(1.0, p.q, p.dim), r

    def residual(a, b):
        y = a - b
        y[ang] = wrap(y[ang])
        return y

    for k in range(t.size):
        f.predict()
        f.update(z[k], lambda x, s=sens[k]: h_and_jac(p.name, x, s)[1],
                 lambda x, s=sens[k]: h_and_jac(p.name, x, s)[0], residual=residual)
    return f.x


def filterpy_ukf(p, data):
    """FilterPy's UnscentedKalmanFilter (Merwe points alpha 1, beta 2, kappa 0)."""
    from filterpy.kalman import MerweScaledSigmaPoints
    from filterpy.kalman import UnscentedKalmanFilter as FpUKF

    t, z, sens, r = data
    n = 2 * p.dim
    ang = angle_rows(p.name)
    phi = transition_matrix(1.0, p.dim)
    pts = MerweScaledSigmaPoints(n, alpha=1.0, beta=2.0, kappa=0.0)

    def z_mean(sigmas, wm):
        out = wm @ sigmas
        out[ang] = np.arctan2(wm @ np.sin(sigmas[:, ang]), wm @ np.cos(sigmas[:, ang]))
        return out

    def residual(a, b):
        y = a - b
        y[ang] = wrap(y[ang])
        return y

    def hx(x, s):
        return h_and_jac(p.name, x, s)[0]

    f = FpUKF(n, 4, 1.0, hx=hx, fx=lambda x, dt: phi @ x, points=pts, z_mean_fn=z_mean,
              residual_z=residual)
    f.x, f.P = p.mean0.copy(), p.cov0.copy()
    f.Q, f.R = process_noise(1.0, p.q, p.dim), r
    for k in range(t.size):
        f.predict()
        f.update(z[k], s=sens[k])
    return f.x


def tmakit_run(cls, p):
    """tmakit's filter.run on the MeasurementSet."""
    f = cls(p.mean0, p.cov0, 0.0, q=p.q, nuisance=p.nuisance)
    return f.run(p.meas).states[-1]


def interleaved(funcs, repeats, clock="cpu"):
    """Time each callable ``repeats`` times, interleaved: ``{name: (median, q1, q3)}`` s.

    ``clock``: ``"cpu"`` (process CPU time) or ``"wall"``.
    """
    tick = time.process_time if clock == "cpu" else time.perf_counter
    times = {name: [] for name in funcs}
    for _ in range(repeats):
        for name, fn in funcs.items():
            t0 = tick()
            fn()
            times[name].append(tick() - t0)
    return {name: (float(np.median(v)), float(np.percentile(v, 25)),
                   float(np.percentile(v, 75))) for name, v in times.items()}


def first_runs(p, repeat, clock):
    """Median [IQR] s of tmakit's EKF on a new copy of the set each time (compiled anew)."""
    tick = time.process_time if clock == "cpu" else time.perf_counter
    times = []
    for _ in range(repeat):
        fresh = p.meas.take(np.arange(len(p.meas)))
        t0 = tick()
        ExtendedKalmanFilter(p.mean0, p.cov0, 0.0, q=p.q, nuisance=p.nuisance).run(fresh)
        times.append(tick() - t0)
    return (float(np.median(times)), float(np.percentile(times, 25)),
            float(np.percentile(times, 75)))


def measure(case, steps, repeat, clock="cpu"):
    """Rows of (what, tmakit, peer, ratio, note) for one problem."""
    p = filter_problem(case, steps)
    data = arrays(p)
    finals = {"tmakit ekf": tmakit_run(ExtendedKalmanFilter, p),
              "tmakit ukf": tmakit_run(UnscentedKalmanFilter, p),
              "numpy ekf": numpy_loop(p, data), "filterpy ekf": filterpy_ekf(p, data),
              "filterpy ukf": filterpy_ukf(p, data)}
    stats = interleaved({
        "tmakit ekf": lambda: tmakit_run(ExtendedKalmanFilter, p),
        "numpy ekf": lambda: numpy_loop(p, data),
        "filterpy ekf": lambda: filterpy_ekf(p, data),
        "tmakit ukf": lambda: tmakit_run(UnscentedKalmanFilter, p),
        "filterpy ukf": lambda: filterpy_ukf(p, data)}, repeat, clock)
    stats["tmakit ekf first run"] = first_runs(p, repeat, clock)
    per = {k: tuple(v / steps for v in s) for k, s in stats.items()}
    agree_ekf = max(np.max(np.abs(finals["tmakit ekf"] - finals[k])[:p.dim])
                    for k in ("numpy ekf", "filterpy ekf"))
    agree_ukf = float(np.max(np.abs(finals["tmakit ukf"] - finals["filterpy ukf"])[:p.dim]))
    label = {"bf2": "bearing+frequency, 2 sensors, 2-D", "be3": "bearing+elevation, 2 sensors, 3-D"}
    rows = []
    for peer in ("numpy ekf", "filterpy ekf"):
        rows.append((f"EKF per step, {label[case]}", fmt(per["tmakit ekf"], 1e6, "us"),
                     f"{peer} {fmt(per[peer], 1e6, 'us')}",
                     per[peer][0] / per["tmakit ekf"][0], f"positions agree {agree_ekf:.1e} m"))
    first = per["tmakit ekf first run"]
    rows.append((f"EKF first run (set compiled), {label[case]}", fmt(first, 1e6, "us"),
                 f"filterpy ekf {fmt(per['filterpy ekf'], 1e6, 'us')}",
                 per["filterpy ekf"][0] / first[0], "peer/tmakit, the plan made in the run"))
    rows.append((f"UKF per step, {label[case]}", fmt(per["tmakit ukf"], 1e6, "us"),
                 f"filterpy ukf {fmt(per['filterpy ukf'], 1e6, 'us')}",
                 per["filterpy ukf"][0] / per["tmakit ukf"][0],
                 f"positions agree {agree_ukf:.1e} m"))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--clock", choices=["cpu", "wall"], default="cpu")
    args = ap.parse_args()
    print(f"clock {args.clock}; per step, median [interquartile range] of {args.repeat}")
    for case in ("bf2", "be3"):
        for what, ours, peer, ratio, note in measure(case, args.steps, args.repeat, args.clock):
            print(f"{what:45s} {ours:28s} {peer:40s} peer/tmakit {ratio:5.2f}  {note}")


if __name__ == "__main__":
    main()
