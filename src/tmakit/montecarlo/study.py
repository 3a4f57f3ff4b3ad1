"""The entry point of a Monte Carlo study: :func:`monte_carlo`."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from ..bounds.fim import crlb
from ..core.keywords import NOT_GIVEN, NotGiven, RngLike, renamed_keyword, study_seed
from ..results.nuisance import KnownNuisance, KnownNuisanceLike, as_known_nuisance
from ..scenario.model import Scenario
from .execution import dask_client, default_chunk, execute, whole_number
from .result import MonteCarloResult
from .runs import ChunkOutput, ChunkTask, check_estimator

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

__all__ = ["finished_runs_table", "monte_carlo"]

Options = Mapping[str, Mapping[str, object]]


COMPILED_WORK = 200_000
"""Runs times rows from which a study's batched fits evaluate by the compiled kernel
(:mod:`tmakit.observation.varpro_compiled`): loading it (about 0.2 s per process) then costs
less than it saves (about 5 us per run and row, measured on gu2007).  Below, the NumPy path."""


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


def _check_init(scenario: Scenario, init: Mapping[str, float] | ArrayLike | None) -> None:
    """Refuse a bad ``init`` before any run."""
    motion = scenario.motion
    if init is None:
        return
    if isinstance(init, Mapping):
        motion.theta(init)
    elif np.asarray(init, dtype=float).size != motion.n_params:
        raise ValueError(f"init must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)})")


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
    _check_init(scenario, init)
    opts = _options(scenario, options)

    seq, compiled = np.random.SeedSequence(seed_used), _compiled(scenario, runs)
    entropy, children = int(seq.entropy), seq.spawn(runs)  # type: ignore[arg-type]
    client, own_client = (None, False) if dask is None else dask_client(dask)
    try:
        size = chunk or default_chunk(runs, estimator, client, compiled)
        tasks = [ChunkTask(scenario, estimator, opts, known, init, lo,
                           tuple(children[lo:lo + size]), compiled)
                 for lo in range(0, runs, size)]
        outputs, wall, executor = execute(tasks, client, f"{scenario.name} {estimator}",
                                          runs, progress, on_chunk, workers=workers)
    finally:
        if own_client and client is not None:
            close: Callable[[], object] = client.close  # (distributed is not typed)
            close()
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
