"""Monte Carlo evaluation of an estimator on a scenario, against the Cramér–Rao bound.

>>> from tmakit.montecarlo import monte_carlo
>>> res = monte_carlo(tk.load_scenario("gu2007"), "ml", runs=200, seed=1)
>>> print(res.summary())            # bias, RMSE, CRLB, RMSE/CRLB with 95 % interval
>>> res.save("gu2007-mc.parquet")   # the per-run table

Run ``r`` simulates the scenario with its own generator,
``np.random.default_rng(np.random.SeedSequence(seed).spawn(runs)[r])``, so that one seed gives
one table whatever the chunking and wherever the chunks run (in this process or on a Dask
cluster): run ``r``'s data do not depend on the number of runs either.

The maximum-likelihood estimator without an initial guess is vectorised across runs: the runs
of a chunk share times, sensors and noise (their noise-free rows are simulated once,
:meth:`~tmakit.scenario.Scenario.simulate_many`), so the grid's predictions are computed once
for all of them (:func:`~tmakit.batch.init.best_starts_many`), one batched
Levenberg–Marquardt call solves every run from its first starting points, and further batched
calls re-solve only the runs whose best fit did not converge or has an implausible chi2 —
exactly what :func:`~tmakit.batch.ml.estimate` does run by run
(:func:`~tmakit.batch.ml.solve_without_guess` serves both).  Other estimators (the registry
:data:`tmakit.batch.methods.METHODS`) are called run by run.

The summary compares the root-mean-square error over the converged runs with the CRLB of the
same nuisance convention (nuisance parameters unknown unless ``known_nuisance``).  The 95 %
interval of RMSE/CRLB assumes independent, unbiased, Gaussian errors of one parameter over
``n`` runs: then ``n RMSE² / σ²`` is chi-square with ``n`` degrees of freedom, ``σ`` the true
RMS error, so ``σ / CRLB`` lies in ``ratio·sqrt(n/χ²_{n,0.975}) .. ratio·sqrt(n/χ²_{n,0.025})``
with 95 % probability.  An interval above 1 says the estimator is not efficient there (or is
biased, or its errors are heavy-tailed); an interval that contains 1 says the runs cannot tell
it from an efficient one.

Dask, distributed and tqdm are imported only when used.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .batch.methods import METHODS, estimate_with
from .batch.ml import Best, solve_without_guess
from .batch.solver import VarProProblem, levenberg_marquardt
from .bounds.fim import crlb
from .data import MeasurementSet
from .observation import ObservationModel
from .results.bound import Bound
from .results.estimate import CONVERGED, assemble_result
from .scenario import Scenario

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = ["FAILED", "MonteCarloResult", "available_estimators", "monte_carlo",
           "ratio_interval"]

#: Status of a run whose estimator raised an error (the message is in ``result.failures``).
FAILED = "failed"
#: Runs per chunk when running in this process.
LOCAL_CHUNK = 50
#: Runs per chunk for estimators solved run by run (the progress bar moves per chunk).
LOOP_CHUNK = 10
#: Errors an estimator may raise on one unlucky data set; they mark the run as failed.
RUN_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)

Options = Mapping[str, Mapping[str, object]]


# -- estimators ------------------------------------------------------------------------------
def available_estimators() -> tuple[str, ...]:
    """Names accepted as ``estimator``: the keys of :data:`tmakit.batch.methods.METHODS`."""
    return tuple(METHODS)


def _check_estimator(estimator: str, known_nuisance: bool) -> None:
    names = available_estimators()
    if not isinstance(estimator, str) or estimator not in names:
        raise ValueError(f"unknown estimator {estimator!r}; expected one of {', '.join(names)}")
    if known_nuisance and not METHODS[estimator].takes_known_nuisance:
        raise ValueError(f"estimator {estimator!r} cannot be given known nuisance "
                         "parameters; use known_nuisance=False or estimator 'ml'")


# -- one chunk of runs (runs in this process or on a Dask worker) ----------------------------
@dataclass(frozen=True)
class _Task:
    """What a worker needs to compute runs ``first_run .. first_run + len(seeds) - 1``."""

    scenario: Scenario
    estimator: str
    options: dict[str, dict[str, object]]
    known_nuisance: bool
    init: Any
    init_vector: NDArray[np.float64] | None
    first_run: int
    seeds: tuple[np.random.SeedSequence, ...]


@dataclass
class _ChunkOutput:
    """Per-run results of one chunk, in run order."""

    first_run: int
    status: list[str]
    iterations: NDArray[np.int64]
    chi2: NDArray[np.float64]
    starts: NDArray[np.int64]
    estimates: NDArray[np.float64]
    failures: dict[int, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.status)


def _empty_output(first_run: int, m: int, p: int) -> _ChunkOutput:
    return _ChunkOutput(first_run, [FAILED] * m, np.zeros(m, dtype=np.int64),
                        np.full(m, np.nan), np.zeros(m, dtype=np.int64), np.full((m, p), np.nan))


def _record(out: _ChunkOutput, i: int, res: Any) -> None:
    out.status[i] = str(res.status)
    out.iterations[i] = int(res.iterations)
    out.chi2[i] = float(res.chi2)
    out.starts[i] = int(getattr(res, "starts", 1))
    out.estimates[i] = np.asarray(res.estimate, dtype=float)


def _run_chunk(task: _Task) -> _ChunkOutput:
    """Simulate and estimate the runs of one chunk."""
    scn = task.scenario
    meas = scn.simulate_many([np.random.default_rng(s) for s in task.seeds])
    if task.estimator == "ml" and _shared_layout(meas):
        return _ml_batched(task, meas)
    return _per_run(task, meas)


def _shared_layout(meas: Sequence[MeasurementSet]) -> bool:
    """Whether every set has the rows of the first (times, sensors, kinds, sigmas, sensor
    states): then they differ only in their values and one problem serves them all."""
    a = meas[0]
    for b in meas[1:]:
        if len(b) != len(a) or not (
                np.array_equal(a.time, b.time) and np.array_equal(a.sensor, b.sensor)
                and np.array_equal(a.kind, b.kind) and np.array_equal(a.sigma, b.sigma)
                and np.array_equal(a.sensor_state, b.sensor_state)
                and np.array_equal(a.time_ref, b.time_ref, equal_nan=True)
                and np.array_equal(a.ref_sensor_state, b.ref_sensor_state, equal_nan=True)):
            return False
    return True


def _per_run(task: _Task, meas: Sequence[MeasurementSet]) -> _ChunkOutput:
    """Each run through the estimator's public function."""
    scn = task.scenario
    out = _empty_output(task.first_run, len(meas), scn.motion.n_params)
    known = {"known_nuisance": dict(scn.nuisance)} if task.known_nuisance else {}
    for i, m in enumerate(meas):
        try:
            res = estimate_with(task.estimator, m, scn.motion, init=task.init,
                                options=task.options, **known)
        except RUN_ERRORS as e:
            out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
            continue
        _record(out, i, res)
    return out


def _ml_batched(task: _Task, meas: Sequence[MeasurementSet]) -> _ChunkOutput:
    """:func:`tmakit.batch.ml.estimate` for every run of the chunk, the solves batched.

    Step for step what ``estimate`` does per run: best grid starts (or ``init``), a solve from
    the first start, a solve from the other starts if that fit did not converge or has an
    implausible chi2, the lowest cost wins, and ``_result`` gives the status.  Each row of a
    batched Levenberg–Marquardt solve is independent of the others, so the results are those
    of ``estimate``.
    """
    scn = task.scenario
    motion = scn.motion
    m, p = len(meas), motion.n_params
    out = _empty_output(task.first_run, m, p)
    obs0 = ObservationModel(meas[0], motion, task.options)
    fixed = obs0.nuisance_vector(scn.nuisance) if task.known_nuisance else None
    # As estimate() builds it (the problem makes its own noise model, in its row order); the
    # noise model is then shared by every run of the chunk: they have the same rows.
    problem = VarProProblem(obs0, None, fixed)
    ys = np.stack([x.value_si for x in meas])

    if task.init_vector is not None:
        sol = levenberg_marquardt(problem, ys, np.repeat(task.init_vector.reshape(1, p), m, 0))
        bests: list[Best | None] = [
            Best(sol.theta[i], sol.nuisance[i], float(sol.cost[i]), int(sol.iterations[i]),
                 bool(sol.converged[i]), 1) for i in range(m)]
    else:
        try:  # the very code estimate() runs, for the whole chunk at once
            bests = solve_without_guess(problem, ys)
        except RUN_ERRORS:  # find the run at fault one by one
            bests = []
            for i in range(m):
                try:
                    bests.extend(solve_without_guess(problem, ys[i:i + 1]))
                except RUN_ERRORS as e:
                    out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
                    bests.append(None)
    for i, best in enumerate(bests):
        if best is None:
            out.failures.setdefault(task.first_run + i, "ValueError: no starting point gives "
                                    "finite predictions; check the data")
            continue
        try:
            res = assemble_result(problem.obs, problem.noise, best.theta, best.nuisance,
                                  best.cost, best.iterations, best.converged, "ml",
                                  best.starts, fixed is not None, best.note)
        except RUN_ERRORS as e:  # pragma: no cover - the bound of a finite fit
            out.failures[task.first_run + i] = f"{type(e).__name__}: {e}"
            continue
        _record(out, i, res)
    return out


# -- execution -------------------------------------------------------------------------------
class _NoBar:
    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, enabled: bool, desc: str) -> Any:
    if not enabled:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:
        warnings.warn("progress bar needs tqdm (pip install tqdm); running without one",
                      stacklevel=3)
        return _NoBar()
    return tqdm(total=total, desc=desc, unit="run", smoothing=0.1)


def _run_local(tasks: Sequence[_Task], bar: Any) -> list[_ChunkOutput]:
    outputs = []
    for task in tasks:
        res = _run_chunk(task)
        outputs.append(res)
        bar.update(len(res))
    return outputs


def _client(dask: Any) -> tuple[Client, bool]:
    """A Dask client for ``dask`` (an address or a client) and whether we opened it."""
    try:
        from distributed import Client
    except ImportError:
        raise ImportError("dask= needs Dask's distributed scheduler: "
                          "pip install 'dask[distributed]'") from None
    if isinstance(dask, Client):
        return dask, False
    if isinstance(dask, str):
        return Client(dask), True
    raise ValueError(f"dask must be a scheduler address (such as 'tcp://host:8786') or a "
                     f"distributed.Client, not {type(dask).__name__}")


def _run_dask(tasks: Sequence[_Task], client: Client, bar: Any) -> list[_ChunkOutput]:
    from distributed import as_completed

    futures = client.map(_run_chunk, list(tasks), pure=False)
    outputs = []
    try:
        for fut in as_completed(futures):
            res = fut.result()
            outputs.append(res)
            bar.update(len(res))
            fut.release()
    except BaseException:
        client.cancel(futures)  # an error or an interrupt: leave nothing running
        raise
    return outputs


def _default_chunk(runs: int, estimator: str, client: Client | None) -> int:
    if client is None:
        return LOCAL_CHUNK if estimator == "ml" else LOOP_CHUNK
    threads = sum(client.nthreads().values()) or 1
    # About four chunks per worker thread balance the load; large enough chunks keep the
    # batched solves efficient.
    return int(min(LOCAL_CHUNK, max(1, math.ceil(runs / (4 * threads)))))


# -- the public entry point ------------------------------------------------------------------
def _whole(value: object, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ValueError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    return int(value)


def _init_vector(scenario: Scenario, init: Mapping[str, float] | ArrayLike
                 ) -> NDArray[np.float64]:
    motion = scenario.motion
    if isinstance(init, Mapping):
        return motion.theta(init)
    vec = np.asarray(init, dtype=float).reshape(-1)
    if vec.shape[0] != motion.n_params:
        raise ValueError(f"init must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)})")
    return vec


def monte_carlo(scenario: Scenario | str | Path, estimator: str = "ml", runs: int = 100,
                seed: int | None = 0, options: Options | None = None,
                known_nuisance: bool = False,
                init: Mapping[str, float] | ArrayLike | None = None, progress: bool = True,
                dask: str | Client | None = None, chunk: int | None = None
                ) -> MonteCarloResult:
    """Simulate ``scenario`` ``runs`` times, estimate each run, and compare with the CRLB.

    ``scenario`` is a :class:`~tmakit.scenario.Scenario` or a built-in name / TOML path.
    ``estimator`` is ``"ml"`` or a key of ``tmakit.batch.methods.METHODS``
    (:func:`available_estimators`).  ``options`` selects the nuisance model per kind and
    defaults to the scenario's (:attr:`Scenario.measurement_options`); the CRLB uses the same
    options and the same nuisance convention: unknown, unless ``known_nuisance`` gives the
    estimator the scenario's true nuisance values.  ``init`` is a starting point given to
    every run (default: the estimator's own initialisation).

    ``seed`` fixes every run's data (run ``r`` uses child ``r`` of
    ``np.random.SeedSequence(seed)``); ``None`` draws fresh entropy, recorded in the result.
    ``chunk`` runs go to one task; ``dask`` (a scheduler address or a
    ``distributed.Client``) sends the tasks to a Dask cluster, whose workers must be able to
    import tmakit.  The table is the same, run for run, for any ``chunk`` and ``dask``.
    ``progress`` shows a tqdm progress bar.
    """
    if isinstance(scenario, str | Path):
        from .scenario_file import load_scenario

        scenario = load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise ValueError(f"scenario must be a Scenario or a scenario name, not "
                         f"{type(scenario).__name__}")
    runs = _whole(runs, "runs")
    if chunk is not None:
        chunk = _whole(chunk, "chunk")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int | np.integer)
                             or seed < 0):
        raise ValueError(f"seed must be a whole number >= 0 or None, got {seed!r}")
    known_nuisance = bool(known_nuisance)
    _check_estimator(estimator, known_nuisance)
    init_vector = None if init is None else _init_vector(scenario, init)
    opts = {str(k): dict(v) for k, v in (
        scenario.measurement_options if options is None else options).items()}

    seq = np.random.SeedSequence(seed)
    entropy = int(seq.entropy)  # type: ignore[arg-type]
    children = seq.spawn(runs)
    client, own_client = (None, False) if dask is None else _client(dask)
    try:
        size = chunk or _default_chunk(runs, estimator, client)
        batched_init = init_vector if estimator == "ml" else None
        tasks = [_Task(scenario, estimator, opts, known_nuisance, init, batched_init, lo,
                       tuple(children[lo:lo + size])) for lo in range(0, runs, size)]
        bar = _progress_bar(runs, progress, f"{scenario.name} {estimator}")
        start = time.perf_counter()
        try:
            outputs = (_run_local(tasks, bar) if client is None
                       else _run_dask(tasks, client, bar))
        finally:
            bar.close()
        wall = time.perf_counter() - start
        executor = "local" if client is None else f"dask {client.scheduler.address}"
    finally:
        if own_client and client is not None:
            client.close()

    outputs.sort(key=lambda o: o.first_run)
    names = scenario.motion.param_names
    table = pd.DataFrame({
        "run": np.arange(runs, dtype=np.int64),
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

    bound = crlb(scenario, known_nuisance=known_nuisance, options=opts)
    std = np.array([bound.std_of(n) for n in names])
    return MonteCarloResult(scenario.name, estimator, names, scenario.theta.copy(), std,
                            table, wall, entropy, known_nuisance, executor, size, failures,
                            bound)


# -- results ---------------------------------------------------------------------------------
def ratio_interval(ratio: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """Confidence interval of the true RMS error over the CRLB from the measured ratio of
    ``n`` runs: ``ratio·sqrt(n/χ²_{n,(1+level)/2}) .. ratio·sqrt(n/χ²_{n,(1-level)/2})``.

    Assumes independent, unbiased, Gaussian errors (then ``n RMSE²/σ²`` is ``χ²_n``)."""
    if n < 1 or not np.isfinite(ratio):
        return float("nan"), float("nan")
    from scipy.stats import chi2

    hi_q = chi2.ppf(0.5 + level / 2.0, n)
    lo_q = chi2.ppf(0.5 - level / 2.0, n)
    return float(ratio * np.sqrt(n / hi_q)), float(ratio * np.sqrt(n / lo_q))


def _num(x: float) -> float | None:
    return float(x) if x is not None and np.isfinite(x) else None


@dataclass
class MonteCarloResult:
    """The runs of :func:`monte_carlo` and their comparison with the CRLB.

    ``table`` has one row per run: ``run``, ``status`` (``converged``, ``did not converge``,
    ``unobservable``, ``diverged`` or ``failed``), ``iterations``, ``chi2``, ``starts`` (starting
    points solved from) and ``est_<param>`` per motion parameter.  ``crlb`` is the bound's
    standard deviation per parameter (same order as ``parameters`` and ``truth``); ``seed``
    the entropy that reproduces the runs; ``failures`` the error message of each failed run.
    """

    scenario: str
    estimator: str
    parameters: tuple[str, ...]
    truth: NDArray[np.float64]
    crlb: NDArray[np.float64]
    table: pd.DataFrame
    wall_time: float
    seed: int
    known_nuisance: bool
    executor: str = "local"
    chunk: int = LOCAL_CHUNK
    failures: dict[int, str] = field(default_factory=dict)
    bound: Bound | None = None

    # -- counts ----------------------------------------------------------------------------
    @property
    def runs(self) -> int:
        return len(self.table)

    @property
    def runs_per_second(self) -> float:
        return self.runs / self.wall_time if self.wall_time > 0 else float("inf")

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Mask of the converged runs."""
        return (self.table["status"] == CONVERGED).to_numpy()

    @property
    def convergence_rate(self) -> float:
        """Fraction of the runs whose status is ``converged``."""
        return float(np.mean(self.converged)) if self.runs else float("nan")

    @property
    def status_counts(self) -> dict[str, int]:
        return {str(k): int(v) for k, v in self.table["status"].value_counts().items()}

    def estimates(self, converged_only: bool = True) -> NDArray[np.float64]:
        """Estimates ``(runs, p)``, by default of the converged runs only."""
        est = self.table[[f"est_{n}" for n in self.parameters]].to_numpy(dtype=float)
        return est[self.converged] if converged_only else est

    def errors(self, converged_only: bool = True) -> NDArray[np.float64]:
        """Estimate minus truth ``(runs, p)``, by default of the converged runs only."""
        return self.estimates(converged_only) - self.truth

    # -- summaries -------------------------------------------------------------------------
    def summary_table(self, level: float = 0.95) -> list[dict[str, Any]]:
        """One row per parameter: ``parameter``, ``truth``, ``n`` (converged runs),
        ``bias``, ``rmse``, ``crlb``, ``ratio`` (RMSE/CRLB) and its interval
        ``ratio_low``, ``ratio_high`` at ``level`` (see :func:`ratio_interval`)."""
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
        """A readable report: per parameter bias, RMSE, CRLB and RMSE/CRLB with its 95 %
        interval; convergence, status counts and speed."""
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
        """The JSON form: context, per-parameter summary, convergence and speed; with
        ``runs=True`` also the per-run table as a list of records."""
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
        return json.dumps(self.as_dict(runs=runs), indent=indent)

    def save(self, path: str | Path, force: bool = False) -> Path:
        """Write the per-run table: CSV (``.csv``) or Parquet (``.parquet``, ``.pq``).

        Refuses (``FileExistsError``) to overwrite an existing file unless ``force``."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".csv", ".parquet", ".pq"):
            raise ValueError(f"{path}: the per-run table is written as .csv or .parquet, "
                             f"not {path.suffix or 'a file without suffix'}")
        if path.exists() and not force:
            raise FileExistsError(f"{path} already exists; pass force=True to overwrite it")
        if suffix == ".csv":
            self.table.to_csv(path, index=False)
        else:
            self.table.to_parquet(path, index=False)
        return path

