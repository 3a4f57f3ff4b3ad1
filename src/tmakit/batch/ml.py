"""Maximum-likelihood batch estimation: ``tk.estimate(meas, motion)`` with no initial guess.

Gaussian noise makes the ML estimate the weighted least-squares fit.  The nuisance parameters
(carrier and drift, power constant, path-loss exponent) are eliminated exactly at every step
(:mod:`tmakit.batch.solver`); the starting points come from a coarse likelihood grid
(:mod:`tmakit.batch.init`) unless ``init`` is given.  The covariance is the inverse Fisher
information at the estimate, over the motion and nuisance parameters together.  The status is
never hidden: ``converged``, ``did not converge``, ``unobservable`` or ``diverged``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..results.estimate import EstimateResult, assemble_result
from .init import GridSettings, best_starts_many
from .solver import VarProProblem, levenberg_marquardt


def estimate(meas: MeasurementSet, motion: MotionModel | str,
             init: Mapping[str, float] | ArrayLike | None = None,
             options: Mapping[str, Mapping[str, object]] | None = None,
             known_nuisance: Mapping[str, float] | None = None,
             grid: GridSettings | None = None, max_iter: int = 100,
             **manoeuvre_options: object) -> EstimateResult:
    """Maximum-likelihood estimate of the motion parameters from a measurement set.

    ``init`` (optional) is a starting point by name or as a vector; without it the grid of
    :mod:`tmakit.batch.init` finds the starting points.  ``options`` selects the nuisance
    model per kind (``{"frequency": {"drift": True}, "power": {"exponent": None}}``).
    ``known_nuisance`` fixes the nuisance parameters at the given values instead of
    estimating them.

    A manoeuvring target — ``motion`` a :class:`~tmakit.motion.PiecewiseCurvilinear` with
    ``M`` manoeuvres, or the name ``"curvilinear:M"`` — goes to
    :func:`tmakit.batch.curvilinear.estimate_for`: ``0..M`` manoeuvres, the number chosen by
    a stated criterion (``manoeuvre_options``: ``exact``, ``criterion``, ``alpha``,
    ``ref_time``, ``settings``).
    """
    # -- manoeuvring targets: their own estimator (tmakit.batch.curvilinear) ----------------
    if isinstance(motion, str) or getattr(motion, "manoeuvres", None) is not None:
        from .curvilinear import estimate_for

        return estimate_for(meas, motion, init=init, options=options,
                            known_nuisance=known_nuisance, max_iter=max_iter,
                            **manoeuvre_options)
    if manoeuvre_options:
        raise TypeError(f"estimate() got options for manoeuvring targets "
                        f"({', '.join(manoeuvre_options)}) with motion {motion.name!r}")
    # -------------------------------------------------------------------------------------
    obs = ObservationModel(meas, motion, options)
    fixed = None if known_nuisance is None else obs.nuisance_vector(known_nuisance)
    problem = VarProProblem(obs, None, fixed)
    y = obs.values
    if init is not None:
        theta0 = (motion.theta(init) if isinstance(init, Mapping)
                  else np.asarray(init, dtype=float)).reshape(1, -1)
        if theta0.shape[1] != motion.n_params:
            raise ValueError(f"init must give {motion.n_params} values "
                             f"({', '.join(motion.param_names)})")
        sol = levenberg_marquardt(problem, y, theta0, max_iter=max_iter)
        best = Best(sol.theta[0], sol.nuisance[0], float(sol.cost[0]),
                    int(sol.iterations[0]), bool(sol.converged[0]), 1)
    else:
        (best,) = solve_without_guess(problem, y[None, :], grid, max_iter)
        if best is None:
            raise ValueError("no starting point gives finite predictions; check the data")
    return assemble_result(problem.obs, problem.noise, best.theta, best.nuisance, best.cost,
                           best.iterations, best.converged, "ml", best.starts,
                           known_nuisance is not None, best.note)


DENSE_GRID = GridSettings(n_ranges=20, n_bearings=24,
                          speeds=(0.0, 5.0, 10.0, 20.0, 40.0, 80.0, 150.0, 300.0, 450.0),
                          n_courses=16, max_rows=60, starts=12, coarse_rows=20, refine=1024)
"""The last resort of :func:`solve_without_guess`."""


@dataclass
class Best:
    """The best fit found for one data set, and how many starting points were solved."""

    theta: NDArray[np.float64]
    nuisance: NDArray[np.float64]
    cost: float
    iterations: int
    converged: bool
    starts: int
    note: str = ""


def solve_without_guess(problem: VarProProblem, ys: NDArray[np.float64],
                        grid: GridSettings | None = None, max_iter: int = 100
                        ) -> list[Best | None]:
    """The global fit of each data set ``(B, n)`` (same times, sensors, noise), no guess.

    1. The best grid starts are solved in one batch: only the best one when there are
       bearings (the grid then lies along the measured bearings), the best ``grid.starts``
       (6) otherwise — Doppler and power alone have local minima whose chi2 is plausible, so
       no test on the fit can tell them from the optimum.
    2. A data set whose best fit is not converged with a plausible chi2 is solved from its
       next distinct grid points (up to 24 in all),
    3. then from the best points of a denser grid (:data:`DENSE_GRID`).
    The starts of a data set run together and a start bound for a worse minimum than one
    already reached stops early (see :func:`~tmakit.batch.solver.levenberg_marquardt`).
    The lowest cost wins.  On 2000 random observable geometries (seeds 0 and 1) every fit
    reached the fit started at the truth (``benchmarks/blind_start.py``).
    """
    g = grid or GridSettings()
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    b = ys.shape[0]
    dof = problem.noise.rank - problem.p - (0 if problem.fixed is not None else problem.k)
    has_bearings = bool(np.any(problem.obs.meas.kind == "bearing"))
    starts = best_starts_many(problem, ys, g)
    best: list[Best | None] = [None] * b

    def solve(blocks: dict[int, NDArray[np.float64]]) -> None:
        runs = [r for r, th in blocks.items() if th.shape[0]]
        if not runs:
            return
        theta = np.concatenate([blocks[r] for r in runs])
        owner = np.concatenate([np.full(blocks[r].shape[0], r) for r in runs])
        # Starts bound for a worse minimum than one already reached stop early.
        reached = np.array([np.inf if best[r] is None else best[r].cost for r in range(b)])
        sol = levenberg_marquardt(problem, ys[owner], theta, max_iter=max_iter, groups=owner,
                                  ceiling=reached[owner])
        for r in runs:
            rows = np.flatnonzero(owner == r)
            cost = np.where(np.isfinite(sol.cost[rows]), sol.cost[rows], np.inf)
            i = rows[int(np.argmin(cost))]
            used = rows.size + (best[r].starts if best[r] is not None else 0)
            if best[r] is None or sol.cost[i] < best[r].cost:
                best[r] = Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]),
                               int(sol.iterations[i]), bool(sol.converged[i]), used)
            else:
                best[r].starts = used

    def unsettled() -> list[int]:
        return [r for r in range(b) if best[r] is None or not (
            best[r].converged and plausible_chi2(2.0 * best[r].cost, dof))]

    first = 1 if has_bearings else g.starts
    solve({r: starts[r].first(first) for r in range(b)})
    solve({r: starts[r].first(max(24, g.starts))[first:] for r in unsettled()})
    again = unsettled()
    if again:
        dense = best_starts_many(problem, ys[again], DENSE_GRID)
        solve({r: d.first(DENSE_GRID.starts) for r, d in zip(again, dense, strict=True)})
    plane = mirror_plane(problem)
    if plane is not None:
        for fit in best:
            if fit is not None:
                fit.theta, fit.note = prefer_above(problem.obs.motion, fit.theta, plane)
    return best


def mirror_plane(problem: VarProProblem) -> float | None:
    """The height of the horizontal plane through every sensor when reflecting the track
    through it leaves every measurement unchanged (all sensors at one height, none moving
    vertically, no elevation measured, a 3-D motion model), else None."""
    meas, motion = problem.obs.meas, problem.obs.motion
    if motion.dim != 3 or "z" not in motion.param_names or np.any(meas.kind == "elevation"):
        return None
    z = np.concatenate([meas.sensor_state[:, 2], meas.ref_sensor_state[:, 2]])
    z = z[np.isfinite(z)]
    vz = meas.sensor_state[:, 5]
    if z.size == 0 or np.ptp(z) > 1e-9 * max(1.0, np.abs(z).max()) or np.any(vz != 0):
        return None
    return float(z[0])


def prefer_above(motion: MotionModel, theta: NDArray[np.float64], plane: float
                 ) -> tuple[NDArray[np.float64], str]:
    """Of a track and its exact mirror image through the sensors' plane, the one above it,
    with a sentence saying so."""
    names = motion.param_names
    theta = np.array(theta, dtype=float)
    iz = names.index("z")
    note = (f"z is ambiguous: the mirror image through the sensors' plane z = {plane:g} m fits "
            "exactly as well (no elevation is measured); the solution above it is reported")
    if theta[iz] < plane:
        theta[iz] = 2.0 * plane - theta[iz]
        if "vz" in names:
            theta[names.index("vz")] *= -1.0
    return theta, note


def plausible_chi2(chi2: float, dof: int) -> bool:
    """Whether a weighted sum of squares is consistent with its degrees of freedom (within
    about five standard deviations of the chi-square distribution)."""
    dof = max(dof, 1)
    return bool(np.isfinite(chi2) and chi2 <= dof + 5.0 * np.sqrt(2.0 * dof) + 5.0)
