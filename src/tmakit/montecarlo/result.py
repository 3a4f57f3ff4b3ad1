"""The result of a Monte Carlo study: the per-run table and its comparison with the CRLB.

The summary compares the root-mean-square error over the converged runs with the CRLB of the same
nuisance convention.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..results.bound import Bound
from ..results.nuisance import KnownNuisance
from ..results.status import CONVERGED
from .execution import LOCAL_CHUNK

__all__ = ["MonteCarloResult", "ratio_interval"]


def ratio_interval(ratio: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """Return the ``level`` interval of the true RMSE/CRLB from ``ratio`` measured in ``n`` runs.

    ``ratio·sqrt(n/χ²_{n,(1+level)/2}) .. ratio·sqrt(n/χ²_{n,(1-level)/2})`` (NaN for ``n < 1``
    or a non-finite ratio), for independent, unbiased, Gaussian errors (``n RMSE²/σ²`` is
    ``χ²_n``).
    """
    if n < 1 or not np.isfinite(ratio):
        return float("nan"), float("nan")
    from ..core import chi2

    hi_q = chi2.ppf(0.5 + level / 2.0, n)
    lo_q = chi2.ppf(0.5 - level / 2.0, n)
    return float(ratio * np.sqrt(n / hi_q)), float(ratio * np.sqrt(n / lo_q))


def _num(x: float) -> float | None:
    return float(x) if x is not None and np.isfinite(x) else None


@dataclass
class MonteCarloResult:
    """The runs of :func:`~tmakit.montecarlo.monte_carlo` and their comparison with the CRLB.

    Parameters
    ----------
    scenario, estimator : str
        Names of the scenario and the estimator.
    parameters : tuple of str
        The motion parameters, in the order of ``truth`` and ``crlb``.
    truth : ndarray, shape (p,)
        True parameter values (SI).
    crlb : ndarray, shape (p,)
        The bound's standard deviation per parameter (SI).
    table : pandas.DataFrame
        One row per run: ``run``, ``status`` (``converged``, ``did not converge``,
        ``unobservable``, ``diverged`` or ``failed``), ``iterations``, ``chi2``, ``starts``
        (starting points solved from) and ``est_<param>`` per motion parameter.
    wall_time : float
        Seconds the runs took.
    seed : int
        The entropy that reproduces the runs.
    known_nuisance : KnownNuisance or None
        The nuisance values the estimator (and the bound) knew; None: estimated.
    executor : str
        ``local``, ``<n> processes`` or ``dask <address>``.
    chunk : int
        Runs per task.
    failures : dict of int to str
        The error message of each failed run.
    bound : Bound, optional
        The CRLB itself.

    References
    ----------
    Gu et al. (2007), §5: Monte Carlo RMS errors set beside the CRLB of eqs. 17–18.
    """

    scenario: str
    estimator: str
    parameters: tuple[str, ...]
    truth: NDArray[np.float64]
    crlb: NDArray[np.float64]
    table: pd.DataFrame
    wall_time: float
    seed: int
    known_nuisance: KnownNuisance | None
    executor: str = "local"
    chunk: int = LOCAL_CHUNK
    failures: dict[int, str] = field(default_factory=dict)
    bound: Bound | None = None

    # -- counts ----------------------------------------------------------------------------
    @property
    def runs(self) -> int:
        """Number of runs."""
        return len(self.table)

    @property
    def runs_per_second(self) -> float:
        """Runs per second of wall time."""
        return self.runs / self.wall_time if self.wall_time > 0 else float("inf")

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Mask of the converged runs."""
        return cast(NDArray[np.bool_], (self.table["status"] == CONVERGED).to_numpy())

    @property
    def convergence_rate(self) -> float:
        """Fraction of the runs whose status is ``converged``."""
        return float(np.mean(self.converged)) if self.runs else float("nan")

    @property
    def status_counts(self) -> dict[str, int]:
        """Number of runs per status, commonest first."""
        return {str(k): int(v) for k, v in self.table["status"].value_counts().items()}

    def estimates(self, converged_only: bool = True) -> NDArray[np.float64]:
        """Return the estimates (runs, p), SI, by default of the converged runs only."""
        est = self.table[[f"est_{n}" for n in self.parameters]].to_numpy(dtype=float)
        return cast(NDArray[np.float64], est[self.converged] if converged_only else est)

    def errors(self, converged_only: bool = True) -> NDArray[np.float64]:
        """Return estimate minus truth (runs, p), SI, by default of the converged runs only."""
        return self.estimates(converged_only) - self.truth

    # -- summaries -------------------------------------------------------------------------
    def summary_table(self, level: float = 0.95) -> list[dict[str, Any]]:
        """Tabulate the summary, one dict per parameter.

        Keys ``parameter``, ``truth``, ``n`` (converged runs), ``bias``, ``rmse``, ``crlb`` (SI),
        ``ratio`` (RMSE/CRLB) and its ``level`` interval ``ratio_low``, ``ratio_high``
        (:func:`ratio_interval`).
        """
        err = self.errors()
        n = err.shape[0]
        rows = []
        for k, name in enumerate(self.parameters):
            bias = float(np.mean(err[:, k])) if n else float("nan")
            rmse = float(np.sqrt(np.mean(err[:, k] ** 2))) if n else float("nan")
            bound = float(self.crlb[k])
            ratio = rmse / bound if bound > 0 and np.isfinite(bound) else float("nan")
            low, high = ratio_interval(ratio, n, level)
            rows.append({"parameter": name, "truth": float(self.truth[k]), "n": n,
                         "bias": bias, "rmse": rmse, "crlb": bound, "ratio": ratio,
                         "ratio_low": low, "ratio_high": high})
        return rows

    def summary(self) -> str:
        """Return a readable report: :meth:`summary_table`, convergence, status counts, speed."""
        counts = ", ".join(f"{k} {v}" for k, v in self.status_counts.items())
        lines = [f"Monte Carlo: {self.estimator} on {self.scenario}, {self.runs} runs "
                 f"(seed {self.seed}), nuisance {'known' if self.known_nuisance else 'unknown'}",
                 f"converged {self.convergence_rate:.1%} ({counts}); {self.wall_time:.2f} s, "
                 f"{self.runs_per_second:.1f} runs/s ({self.executor}, chunks of {self.chunk})"]
        rows = self.summary_table()
        width = max(9, *(len(r["parameter"]) for r in rows))
        lines.append(f"  {'parameter':<{width}}  {'truth':>12}  {'bias':>11}  {'RMSE':>11}  "
                     f"{'CRLB':>11}  {'RMSE/CRLB':>9}  {'95 % interval':>15}")
        for r in rows:
            lines.append(f"  {r['parameter']:<{width}}  {r['truth']:12.6g}  {r['bias']:11.4g}  "
                         f"{r['rmse']:11.4g}  {r['crlb']:11.4g}  {r['ratio']:9.3f}  "
                         f"{r['ratio_low']:7.3f}..{r['ratio_high']:<6.3f}")
        lines.append(f"  (RMSE over the {rows[0]['n'] if rows else 0} converged runs; the "
                     "interval assumes unbiased Gaussian errors)")
        if self.failures:
            first = min(self.failures)
            lines.append(f"  {len(self.failures)} runs failed; run {first}: "
                         f"{self.failures[first]}")
        return "\n".join(lines)

    def as_dict(self, runs: bool = False) -> dict[str, Any]:
        """Return the JSON form (SI, non-finite numbers None); ``runs``: the per-run ``table``."""
        summary = [{k: (_num(v) if isinstance(v, float) else v) for k, v in row.items()}
                   for row in self.summary_table()]
        out: dict[str, Any] = {
            "scenario": self.scenario,
            "estimator": self.estimator,
            "runs": self.runs,
            "seed": self.seed,
            "nuisance": "known" if self.known_nuisance else "unknown",
            "parameters": list(self.parameters),
            "truth": [float(v) for v in self.truth],
            "crlb": [_num(v) for v in self.crlb],
            "summary": summary,
            "convergence_rate": _num(self.convergence_rate),
            "status_counts": self.status_counts,
            "wall_time_s": float(self.wall_time),
            "runs_per_second": _num(self.runs_per_second),
            "executor": self.executor,
            "chunk": self.chunk,
            "failures": {str(k): v for k, v in sorted(self.failures.items())},
        }
        if runs:
            out["table"] = [{k: (_num(v) if isinstance(v, float) else v)
                             for k, v in rec.items()}
                            for rec in json.loads(self.table.to_json(orient="records"))]
        return out

    def to_json(self, indent: int | None = 2, runs: bool = False) -> str:
        """Return :meth:`as_dict` as JSON text (``indent`` as for :func:`json.dumps`)."""
        return json.dumps(self.as_dict(runs=runs), indent=indent)

