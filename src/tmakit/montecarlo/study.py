"""A Monte Carlo study: :func:`monte_carlo` and its :class:`MonteCarloResult`.

The result compares the root-mean-square error over the converged runs with the CRLB of the same
nuisance convention.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from ..batch.estimator import theta_from_init
from ..bounds.fim import crlb
from ..core.keywords import NOT_GIVEN, NotGiven, RngLike, renamed_keyword, study_seed
from ..results.answers import finite
from ..results.bound import Bound
from ..results.nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from ..results.status import CONVERGED
from ..scenario.model import Scenario
from .execution import LOCAL_CHUNK, cluster, default_chunk, execute, whole_number
from .runs import ChunkOutput, ChunkTask, check_estimator

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = ["MonteCarloResult", "finished_runs_table", "monte_carlo", "ratio_interval"]

Options = Mapping[str, Mapping[str, object]]


def ratio_interval(ratio: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """Confidence interval of the true RMS error over the CRLB from the measured ratio.

    Parameters
    ----------
    ratio : float
        Measured RMSE/CRLB over ``n`` runs.
    n : int
        Runs.
    level : float
        Confidence level.

    Returns
    -------
    tuple of float
        ``ratio·sqrt(n/χ²_{n,(1+level)/2}) .. ratio·sqrt(n/χ²_{n,(1-level)/2})``; NaN for ``n < 1``
        or a non-finite ratio.

    Notes
    -----
    Assumes independent, unbiased, Gaussian errors (then ``n RMSE²/σ²`` is ``χ²_n``).
    """
    if n < 1 or not np.isfinite(ratio):
        return float("nan"), float("nan")
    from ..core import chi2

    hi_q = chi2.ppf(0.5 + level / 2.0, n)
    lo_q = chi2.ppf(0.5 - level / 2.0, n)
    return float(ratio * np.sqrt(n / hi_q)), float(ratio * np.sqrt(n / lo_q))


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
        """Return the estimates, by default of the converged runs only.

        Parameters
        ----------
        converged_only : bool
            Keep the converged runs only.

        Returns
        -------
        ndarray, shape (runs, p)
            One row per run, in the order of ``parameters`` (SI: m, m/s, Hz, ...).
        """
        est = self.table[[f"est_{n}" for n in self.parameters]].to_numpy(dtype=float)
        return cast(NDArray[np.float64], est[self.converged] if converged_only else est)

    def errors(self, converged_only: bool = True) -> NDArray[np.float64]:
        """Return estimate minus truth, by default of the converged runs only.

        Parameters
        ----------
        converged_only : bool
            As for :meth:`estimates`.

        Returns
        -------
        ndarray, shape (runs, p)
        """
        return self.estimates(converged_only) - self.truth

    def summary_table(self, level: float = 0.95) -> list[dict[str, Any]]:
        """Tabulate the summary, one row per parameter.

        Parameters
        ----------
        level : float
            Confidence level of the ratio's interval (0 .. 1, :func:`ratio_interval`).

        Returns
        -------
        list of dict
            ``parameter``, ``truth``, ``n`` (converged runs), ``bias``, ``rmse``, ``crlb`` (SI),
            ``ratio`` (RMSE/CRLB) and its interval ``ratio_low``, ``ratio_high``.
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
        """Return a readable report.

        Returns
        -------
        str
            Per parameter bias, RMSE, CRLB and RMSE/CRLB with its 95 % interval; convergence,
            status counts and speed.
        """
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
        """Return the JSON form: context, per-parameter summary, convergence and speed.

        Parameters
        ----------
        runs : bool
            Add the per-run table under ``table`` (a list of records).

        Returns
        -------
        dict
            JSON-ready; SI values, ``wall_time_s`` in s, non-finite numbers as None.
        """
        summary = [{k: (finite(v) if isinstance(v, float) else v) for k, v in row.items()}
                   for row in self.summary_table()]
        out: dict[str, Any] = {
            "scenario": self.scenario,
            "estimator": self.estimator,
            "runs": self.runs,
            "seed": self.seed,
            "nuisance": "known" if self.known_nuisance else "unknown",
            "parameters": list(self.parameters),
            "truth": [float(v) for v in self.truth],
            "crlb": [finite(v) for v in self.crlb],
            "summary": summary,
            "convergence_rate": finite(self.convergence_rate),
            "status_counts": self.status_counts,
            "wall_time_s": float(self.wall_time),
            "runs_per_second": finite(self.runs_per_second),
            "executor": self.executor,
            "chunk": self.chunk,
            "failures": {str(k): v for k, v in sorted(self.failures.items())},
        }
        if runs:
            out["table"] = [{k: (finite(v) if isinstance(v, float) else v)
                             for k, v in rec.items()}
                            for rec in json.loads(self.table.to_json(orient="records"))]
        return out

    def to_json(self, indent: int | None = 2, runs: bool = False) -> str:
        """Return :meth:`as_dict` as JSON text.

        Parameters
        ----------
        indent : int or None
            As for :func:`json.dumps`.
        runs : bool
            Add the per-run table.

        Returns
        -------
        str
        """
        return json.dumps(self.as_dict(runs=runs), indent=indent)


COMPILED_WORK = 200_000
"""Runs times rows from which a study's batched fits use the compiled kernel (loads in ~0.2 s)."""


def _compiled(scenario: Scenario, runs: int) -> bool:
    """Tell whether a study of ``runs`` runs asks for the compiled kernel."""
    return runs * sum(len(plan.times) for plan in scenario.plans) >= COMPILED_WORK


def _workers(workers: object, dask: object) -> int:
    """Check ``workers`` (a whole number >= 1; above 1 not with ``dask``)."""
    count = whole_number(workers, "workers")
    if count > 1 and dask is not None:
        raise ValueError(f"give either dask (a cluster) or workers (processes here), not both "
                         f"(workers={count})")
    return count


def _known(scenario: Scenario, known_nuisance: KnownNuisanceLike) -> KnownNuisance | None:
    """Convert to the one type; the scenario's true values fill the names left out."""
    known = as_known_nuisance(known_nuisance)
    return None if known is None else KnownNuisance(known.over(scenario.nuisance))


def _scenario(scenario: Scenario | str | Path) -> Scenario:
    """Return the scenario itself, or load it by built-in name or TOML path."""
    if isinstance(scenario, str | Path):
        from ..scenario.files import load_scenario

        scenario = load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise ValueError(f"scenario must be a Scenario or a scenario name, not "
                         f"{type(scenario).__name__}")
    if getattr(scenario.motion, "manoeuvres", None):
        raise ValueError(f"scenario {scenario.name}: its target manoeuvres "
                         f"({scenario.motion.name}); Monte Carlo studies fit one motion model "
                         "per run and cannot start a manoeuvring one (for hoerst2010: tma "
                         "reproduce hoerst2010)")
    return scenario


def finished_runs_table(outputs: Sequence[ChunkOutput], names: Sequence[str]
                        ) -> pd.DataFrame:
    """Build the per-run table of the chunks finished so far (a study interrupted or failed).

    Parameters
    ----------
    outputs : sequence of ChunkOutput
        Finished chunks, in any order (as given to ``on_chunk`` of :func:`monte_carlo`).
    names : sequence of str
        The motion parameters' names (``est_<name>`` columns).

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`MonteCarloResult.table`, the runs in order.
    """
    done = sorted(outputs, key=lambda o: o.first_run)
    if not done:
        return pd.DataFrame({"run": np.zeros(0, np.int64)})
    table, _ = _table(done, 0, tuple(names))
    table["run"] = np.concatenate([np.arange(o.first_run, o.first_run + len(o))
                                   for o in done])
    return table


def _table(outputs: Sequence[ChunkOutput], runs: int, names: tuple[str, ...]
           ) -> tuple[pd.DataFrame, dict[int, str]]:
    """Build the per-run table and the failures."""
    table = pd.DataFrame({
        "run": np.arange(sum(len(o) for o in outputs), dtype=np.int64),
        "status": np.concatenate([np.asarray(o.status, dtype=object) for o in outputs]),
        "iterations": np.concatenate([o.iterations for o in outputs]),
        "chi2": np.concatenate([o.chi2 for o in outputs]),
        "starts": np.concatenate([o.starts for o in outputs]),
    })
    est = np.concatenate([o.estimates for o in outputs])
    for k, name in enumerate(names):
        table[f"est_{name}"] = est[:, k]
    failures: dict[int, str] = {}
    for o in outputs:
        failures.update(o.failures)
    return table, failures


def monte_carlo(scenario: Scenario | str | Path, estimator: str = "ml", runs: int = 100,
                rng: RngLike = 0, options: Options | None = None,
                known_nuisance: KnownNuisanceLike = False,
                init: Mapping[str, float] | ArrayLike | None = None, progress: bool = True,
                dask: str | Client | None = None, chunk: int | None = None,
                on_chunk: Callable[[ChunkOutput], None] | None = None,
                workers: int = 1, *, seed: int | NotGiven | None = NOT_GIVEN
                ) -> MonteCarloResult:
    """Simulate ``scenario`` ``runs`` times, estimate each run, and compare with the CRLB.

    Parameters
    ----------
    scenario : Scenario or str or path
        A :class:`~tmakit.scenario.Scenario`, or a built-in name / TOML path.
    estimator : str
        ``"ml"`` or a key of ``tmakit.batch.methods.METHODS``
        (:func:`~.runs.available_estimators`).
    runs : int
        Number of runs (>= 1).
    rng : int, numpy.random.Generator or None
        The study's seed, which fixes every run's data (a Generator gives one,
        None fresh entropy), recorded in the result's ``seed``.
    options : mapping, optional
        The nuisance model per kind (default :attr:`Scenario.measurement_options`), CRLB too.
    known_nuisance : KnownNuisance, Mapping[str, float], bool or None
        Known to the estimator and the CRLB: the values named, the scenario's (true) for the others
        (``True``: all the scenario's); default estimated.
    init : mapping or array_like, optional
        A starting point given to every run (default: the estimator's own initialisation).
    progress : bool
        Show a tqdm progress bar.
    dask : str or distributed.Client, optional
        Send the chunks to a Dask cluster (its workers must import tmakit).
    chunk : int, optional
        Runs per task; the table is the same for any ``chunk``, ``workers`` and ``dask``.
    on_chunk : callable, optional
        Called with each finished chunk's output (:func:`finished_runs_table` saves them).
    workers : int, optional
        Worker processes here (default 1: this one), at most one per chunk and per CPU; not
        with dask.
    seed : int or None, optional
        Deprecated: ``rng``.

    Returns
    -------
    MonteCarloResult
        The per-run table, the CRLB and the summary.

    Raises
    ------
    ValueError
        A bad argument (named), unknown estimator or scenario, manoeuvring target.
    ImportError
        ``dask`` without Dask's distributed scheduler installed.
    """
    scenario, runs = _scenario(scenario), whole_number(runs, "runs")
    workers = _workers(workers, dask)
    chunk = None if chunk is None else whole_number(chunk, "chunk")
    seed_used = study_seed(renamed_keyword("monte_carlo", "seed", seed, "rng", rng, 0))
    known = _known(scenario, known_nuisance)
    check_estimator(estimator, known is not None)
    if init is not None:  # refused before any run
        theta_from_init(scenario.motion, init)
    opts = _options(scenario, options)

    seq, compiled = np.random.SeedSequence(seed_used), _compiled(scenario, runs)
    entropy, children = int(seq.entropy), seq.spawn(runs)  # type: ignore[arg-type]
    with cluster(dask) as client:
        size = chunk or default_chunk(runs, estimator, client, compiled)
        tasks = [ChunkTask(scenario, estimator, opts, known, init, lo,
                           tuple(children[lo:lo + size]), compiled)
                 for lo in range(0, runs, size)]
        outputs, wall, executor = execute(tasks, client, f"{scenario.name} {estimator}",
                                          runs, progress, on_chunk, workers=workers)
    return _result(scenario, estimator, outputs, runs, opts, known,
                   (wall, entropy, executor, size))


def _options(scenario: Scenario, options: Options | None) -> dict[str, dict[str, object]]:
    """Give the nuisance model per kind: ``options``, or the scenario's."""
    return {str(k): dict(v) for k, v in (
        scenario.measurement_options if options is None else options).items()}


def _result(scenario: Scenario, estimator: str, outputs: Sequence[ChunkOutput], runs: int,
            opts: Options, known: KnownNuisance | None, how: tuple[float, int, str, int]
            ) -> MonteCarloResult:
    """Assemble the study's result: table, CRLB; ``how``: wall, seed, executor, chunk."""
    names = scenario.motion.param_names
    table, failures = _table(outputs, runs, names)
    bound = crlb(scenario, known_nuisance=known, options=opts)
    std = np.array([bound.std_of(n) for n in names])
    wall, entropy, executor, size = how
    return MonteCarloResult(scenario.name, estimator, names, scenario.theta.copy(), std,
                            table, wall, entropy, known, executor, size, failures, bound)
