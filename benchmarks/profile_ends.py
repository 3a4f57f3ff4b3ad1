"""Profile-likelihood end points of track starts against a brute-force profile.

For seeded runs of the built-in scenarios, ``tk.track(meas, filter)`` starts from a batch fit
whose covariance is widened to its profile likelihood (``likelihood_covariance``, its ends by
``_profile_ends``).  This records each call's inputs and ends, and recomputes the ends by a slow,
sure reference: the profile at a fixed axis value ``t`` is the fit with that coordinate held
(``scipy.optimize.least_squares`` over the rest), and its end is the root of
``profile(t) - limit`` by ``brentq``.  It prints the solver's steps, ends stopped short (cost
more than 1 % of a quantile from the limit), and the widening factors of ``likelihood_covariance``
with the solver's ends against those with the reference's, and the ends flagged (not converged,
or beyond another valley of the profile).

    python benchmarks/profile_ends.py --seeds 10
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from scipy.linalg import null_space
from scipy.optimize import brentq, least_squares

import tmakit as tk
from tmakit.tracking import initiators
from tmakit.tracking.errors import TrackingError

FILTERS = {"bearings-only-2d": "ekf", "hoerst2010": "ekf", "gu2007": "ukf"}


def reference_ends(point: Callable[[np.ndarray], np.ndarray], scale: np.ndarray,
                   dirs: np.ndarray, obs: Any, noise: Any, nu: Any, quantile: float
                   ) -> np.ndarray:
    """The ends of ``_profile_ends(point, ...)`` by re-fitting at fixed ``t`` and brentq."""
    k, p = dirs.shape

    def residuals(z: np.ndarray) -> np.ndarray:
        return np.asarray(noise.whiten(obs.residuals(point(z), nu)))

    def jacobian(z: np.ndarray) -> np.ndarray:
        return -np.asarray(noise.whiten(obs.jacobian(point(z), nu)[0] @ scale, axis=-2))

    r0 = residuals(np.zeros(p))
    limit = float(r0 @ r0) + quantile
    cap = (1 - 1e-9) * initiators.MAX_PROFILE_WIDTH * math.sqrt(quantile)
    ends = np.zeros((k, p))
    for i, v in enumerate(dirs):
        basis = null_space(v[None])
        warm = {"w": np.zeros(p - 1)}
        best: dict[float, np.ndarray] = {}

        def fit(t: float, v: np.ndarray = v, basis: np.ndarray = basis,
                warm: dict[str, np.ndarray] = warm,
                best: dict[float, np.ndarray] = best) -> np.ndarray:
            # the lower of the fits from the last one and from z = 0 (the profile may have
            # more than one valley at t), once per t (brentq sees one function)
            if t in best:
                return best[t]
            sols = [least_squares(lambda w: residuals(t * v + basis @ w), w0,
                                  jac=lambda w: jacobian(t * v + basis @ w) @ basis,
                                  method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12)
                    for w0 in (warm["w"], np.zeros(p - 1))]
            sol = min(sols, key=lambda s: s.cost)
            warm["w"] = sol.x
            best[t] = t * v + basis @ sol.x
            return best[t]

        def excess(t: float, fit: Callable[[float], np.ndarray] = fit) -> float:
            r = residuals(fit(t))
            return float(r @ r) - limit

        lo, hi = 0.0, math.sqrt(quantile)
        while excess(hi) < 0 and hi < cap:
            lo, hi = hi, min(2 * hi, cap)
        if excess(hi) < 0:
            ends[i] = best[hi]
            continue
        try:
            t = brentq(excess, lo, hi, xtol=1e-6 * hi, rtol=1e-10)
        except ValueError:  # (the re-fits jumped valleys: no reference for this end)
            ends[i] = np.nan
            continue
        ends[i] = best[t] if t in best else fit(t)
    return ends


@contextmanager
def recording() -> Iterator[list[dict[str, Any]]]:
    """Record each ``_profile_ends`` call (inputs, ends) and the steps of ``_end_steps``."""
    calls: list[dict[str, Any]] = []
    ends, steps = initiators._profile_ends, initiators._end_steps
    state: dict[str, Any] = {}

    def counting_steps(*a: Any, **kw: Any) -> Any:
        state["steps"] += 1
        return steps(*a, **kw)

    def recorded(*a: Any, **kw: Any) -> Any:
        state["steps"] = 0
        out = ends(*a, **kw)
        ends_, sure, *more = out
        valleys = more[0] if more else np.zeros(len(ends_), dtype=bool)
        calls.append({"args": a, "ends": np.array(ends_, copy=True),
                      "converged": np.array(sure), "multimodal": np.array(valleys),
                      "steps": state["steps"]})
        return out

    initiators._profile_ends, initiators._end_steps = recorded, counting_steps
    try:
        yield calls
    finally:
        initiators._profile_ends, initiators._end_steps = ends, steps


def gaps(call: dict[str, Any]) -> np.ndarray:
    """Each end's (cost - limit) / quantile (0 at an end that reached the width cap)."""
    point, _, dirs, obs, noise, nu, quantile = call["args"]
    r0 = np.asarray(noise.whiten(obs.residuals(point(np.zeros(dirs.shape[1])), nu)))
    limit = float(r0 @ r0) + quantile
    out = []
    for z in call["ends"]:
        r = np.asarray(noise.whiten(obs.residuals(point(z), nu)))
        out.append((float(r @ r) - limit) / quantile)
    return np.array(out)


def widening(call: dict[str, Any], ends: np.ndarray) -> float:
    """The largest sqrt eigenvalue of P0^-1 P_wide with the given ends (1: not widened)."""
    dirs, quantile = call["args"][2], call["args"][-1]
    wide_z = np.eye(dirs.shape[1])
    for z in ends:
        if not np.all(np.isfinite(z)):
            return math.nan
        m = float(z @ np.linalg.solve(wide_z, z))
        if m > quantile * initiators.LIKELIHOOD_TOLERANCE ** 2:
            wide_z = wide_z + (m / quantile - 1.0) / m * np.outer(z, z)
    return float(math.sqrt(np.max(np.linalg.eigvalsh(wide_z))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--scenario", action="append")
    args = ap.parse_args()
    names = args.scenario or sorted(n for n, _ in tk.builtin_scenarios())
    rows = []
    for name in names:
        scn = tk.load_scenario(name)
        for seed in range(args.seeds):
            meas = scn.simulate(rng=seed)
            with recording() as calls:
                c0 = time.process_time()
                try:
                    tk.track(meas, FILTERS.get(name, "ekf"))
                except (TrackingError, ValueError) as exc:
                    print(f"{name} {seed}: no track ({type(exc).__name__})")
                cpu = time.process_time() - c0
            for call in calls:
                ref = reference_ends(*call["args"])
                g = gaps(call)
                ours, theirs = widening(call, call["ends"]), widening(call, ref)
                flagged = int(np.sum(~call["converged"] | call["multimodal"]))
                rows.append((name, seed, call["steps"], float(np.max(np.abs(g))), ours, theirs,
                             flagged))
                print(f"{name:18s} {seed} steps {call['steps']:3d} worst gap "
                      f"{np.max(np.abs(g)):7.3f}"
                      f" widening {ours:7.3f} ref {theirs:7.3f} ratio {ours / theirs:6.3f}"
                      f" flagged {flagged} cpu {cpu:.2f}", flush=True)
    steps = [r[2] for r in rows]
    off = [r for r in rows if not abs(r[4] / r[5] - 1) <= 0.02]  # (nan: no reference)
    short = [r for r in rows if r[4] < 0.98 * r[5]]
    print(f"starts {len(rows)}, Gauss-Newton steps {sum(steps)}, at the step cap "
          f"{sum(s >= initiators._PROFILE_ITERATIONS for s in steps)}, worst gap > 0.01 quantile "
          f"{sum(r[3] > 0.01 for r in rows)}, widening off the reference by > 2 % "
          f"{len(off)} (of them flagged {sum(r[6] > 0 for r in off)}), short of it by > 2 % "
          f"{len(short)} (of them flagged {sum(r[6] > 0 for r in short)}), starts with a flagged "
          f"end (not converged or beyond another valley) {sum(r[6] > 0 for r in rows)}")


if __name__ == "__main__":
    main()
