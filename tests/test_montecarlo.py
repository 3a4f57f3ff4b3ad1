"""Monte Carlo runs: reproducibility, the batched ML path against estimate(), efficiency on
gu2007, saving, Dask execution, the estimator registry and argument checks."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

import tmakit as tk
from tmakit import montecarlo as mc
from tmakit.batch.estimator import BatchEstimator
from tmakit.batch.methods import METHODS, Method
from tmakit.batch.ml import estimate
from tmakit.montecarlo import MonteCarloResult, monte_carlo, ratio_interval


@pytest.fixture(scope="module")
def gu2007() -> tk.Scenario:
    return tk.load_scenario("gu2007")


@pytest.fixture(scope="module")
def gu2007_40(gu2007) -> MonteCarloResult:
    return monte_carlo(gu2007, runs=40, rng=0, progress=False)


def _estimates(res: MonteCarloResult) -> np.ndarray:
    return res.table[[f"est_{n}" for n in res.parameters]].to_numpy(dtype=float)


# -- reproducibility ---------------------------------------------------------------------------
def _same_answers(x: pd.DataFrame, y: pd.DataFrame) -> None:
    pd.testing.assert_frame_equal(x[["run", "status", "starts"]], y[["run", "status",
                                                                     "starts"]])
    cols = [c for c in x.columns if c == "chi2" or c.startswith("est_")]
    pd.testing.assert_frame_equal(x[cols], y[cols], check_exact=False, rtol=1e-6)


def test_same_seed_same_table_whatever_the_chunking(gu2007):
    a = monte_carlo(gu2007, runs=7, rng=11, progress=False)
    b = monte_carlo(gu2007, runs=7, rng=11, progress=False, chunk=3)
    c = monte_carlo(gu2007, runs=7, rng=11, progress=False, chunk=1)
    # Chunks batch different numbers of solves together; the linear algebra may round the
    # last step differently, so iteration counts of equally good starts can differ.  The
    # answers may not.
    for other in (b, c):
        _same_answers(a.table, other.table)
    assert list(a.table.columns) == ["run", "status", "iterations", "chi2", "starts",
                                     "est_x", "est_y", "est_vx", "est_vy"]
    assert a.table["run"].tolist() == list(range(7))
    assert (a.seed, b.chunk, c.chunk) == (11, 3, 1)


def test_run_data_do_not_depend_on_the_number_of_runs_and_seeds_differ(gu2007):
    few = monte_carlo(gu2007, runs=3, rng=4, progress=False)
    more = monte_carlo(gu2007, runs=5, rng=4, progress=False, chunk=2)
    _same_answers(few.table, more.table.iloc[:3])
    other = monte_carlo(gu2007, runs=3, rng=5, progress=False)
    assert not np.allclose(_estimates(few), _estimates(other))


def test_seed_none_records_entropy_that_reproduces_the_runs(gu2007):
    fresh = monte_carlo(gu2007, runs=2, rng=None, progress=False)
    again = monte_carlo(gu2007, runs=2, rng=fresh.seed, progress=False)
    pd.testing.assert_frame_equal(fresh.table, again.table)


# -- the batched ML path equals estimate() run by run ------------------------------------------
def _assert_matches_estimate(res: MonteCarloResult, scn: tk.Scenario, seed: int,
                             known: bool = False, init=None) -> None:
    children = np.random.SeedSequence(seed).spawn(res.runs)
    est = _estimates(res)
    for r in range(res.runs):
        meas = scn.simulate(np.random.default_rng(children[r]))
        one = estimate(meas, scn.motion, init=init, options=scn.measurement_options,
                       known_nuisance=dict(scn.nuisance) if known else None)
        row = res.table.iloc[r]
        assert row["status"] == one.status, r
        # Batched linear algebra can round a convergence test the other way on the last
        # step: the count may differ by one; the answer may not.
        assert abs(row["iterations"] - one.iterations) <= 1, r
        assert row["starts"] == one.starts, r
        np.testing.assert_allclose(row["chi2"], one.chi2, rtol=1e-6)
        np.testing.assert_allclose(est[r], one.estimate, rtol=1e-6, atol=0)


def test_batched_ml_equals_estimate_run_by_run(gu2007):
    res = monte_carlo(gu2007, runs=8, rng=2, progress=False, chunk=4)
    _assert_matches_estimate(res, gu2007, seed=2)


def test_batched_ml_equals_estimate_with_known_nuisance_and_with_init(gu2007):
    known = monte_carlo(gu2007, runs=3, rng=6, progress=False, known_nuisance=True)
    assert known.known_nuisance
    _assert_matches_estimate(known, gu2007, seed=6, known=True)
    init = {"x": 3000.0, "y": 3500.0, "vx": -20.0, "vy": -10.0}
    started = monte_carlo(gu2007, runs=3, rng=6, progress=False, init=init)
    _assert_matches_estimate(started, gu2007, seed=6, init=init)
    assert (started.table["starts"] == 1).all()
    # The bound follows the nuisance convention: knowing C and f_s can only help.
    unknown = monte_carlo(gu2007, runs=1, rng=6, progress=False)
    assert np.all(known.crlb <= unknown.crlb * (1 + 1e-9))


def test_known_nuisance_reaches_every_run_and_the_bound_as_one_type(gu2007):
    """``True``, a mapping and a KnownNuisance say the same; values it names are the ones
    every run's estimator and the CRLB hold, the scenario's fill the rest."""
    flag = monte_carlo(gu2007, runs=2, rng=6, progress=False, known_nuisance=True)
    typed = monte_carlo(gu2007, runs=2, rng=6, progress=False,
                        known_nuisance=tk.KnownNuisance())
    pd.testing.assert_frame_equal(flag.table, typed.table)
    assert flag.known_nuisance == tk.KnownNuisance(gu2007.nuisance)
    wrong = {"carrier": gu2007.nuisance["carrier"] + 50.0}  # a mis-known carrier
    off = monte_carlo(gu2007, runs=2, rng=6, progress=False, known_nuisance=wrong)
    assert off.known_nuisance.values["carrier"] == wrong["carrier"]
    children = np.random.SeedSequence(6).spawn(2)
    for r in range(2):
        meas = gu2007.simulate(np.random.default_rng(children[r]))
        one = estimate(meas, gu2007.motion, options=gu2007.measurement_options,
                       known_nuisance={**gu2007.nuisance, **wrong})
        np.testing.assert_allclose(_estimates(off)[r], one.estimate, rtol=1e-6)
    assert not np.allclose(_estimates(off), _estimates(flag))
    assert off.bound.nuisance_values["carrier"] == wrong["carrier"]


def test_batched_ml_equals_estimate_with_bearings_whose_grid_depends_on_the_data():
    scn = tk.load_scenario("chen-sun-1")  # azimuth + range differences: grid along bearings
    res = monte_carlo(scn, runs=4, rng=3, progress=False)
    _assert_matches_estimate(res, scn, seed=3)


def test_retries_from_other_starts_are_replicated(gu2007, monkeypatch):
    # Make every first fit look implausible: each run is re-solved from its other starts,
    # and the batched path must do what estimate() does under the same rule.
    import tmakit.batch.ml as ml

    monkeypatch.setattr(ml, "plausible_chi2", lambda chi2, dof: False)  # one rule for both
    res = monte_carlo(gu2007, runs=3, rng=8, progress=False)
    assert (res.table["starts"] > 1).all()
    _assert_matches_estimate(res, gu2007, seed=8)


# -- statistics --------------------------------------------------------------------------------
def test_ml_on_gu2007_is_efficient_and_always_converges(gu2007_40):
    res = gu2007_40
    assert res.convergence_rate == 1.0
    assert res.status_counts == {"converged": 40}
    rows = res.summary_table()
    assert [r["parameter"] for r in rows] == ["x", "y", "vx", "vy"]
    for r in rows:
        assert r["n"] == 40
        assert 0 < r["ratio"] < 1.6, r
        assert r["ratio_low"] < r["ratio"] < r["ratio_high"]
        assert abs(r["bias"]) < 3 * r["crlb"] / np.sqrt(40) + 0.5 * r["crlb"]
    # CRLB with C and f_s unknown, at the scenario's options.
    bound = tk.load_scenario("gu2007")
    from tmakit.bounds.fim import crlb

    b = crlb(bound, known_nuisance=False, options=bound.measurement_options)
    np.testing.assert_allclose(res.crlb, [b.std_of(n) for n in res.parameters])
    assert res.wall_time > 0 and res.runs_per_second > 0


def test_ratio_interval_is_the_chi_square_interval_of_the_mean_square_error():
    low, high = ratio_interval(1.1, 40)
    assert low == pytest.approx(1.1 * np.sqrt(40 / chi2.ppf(0.975, 40)))
    assert high == pytest.approx(1.1 * np.sqrt(40 / chi2.ppf(0.025, 40)))
    assert low < 1.1 < high
    wide = ratio_interval(1.0, 10)
    narrow = ratio_interval(1.0, 1000)
    assert wide[0] < narrow[0] < 1.0 < narrow[1] < wide[1]
    assert all(np.isnan(v) for v in ratio_interval(1.0, 0))


def test_summary_text_and_json(gu2007_40):
    text = gu2007_40.summary()
    for word in ("gu2007", "RMSE/CRLB", "converged 100.0%", "runs/s", " vy "):
        assert word in text
    data = json.loads(gu2007_40.to_json())
    assert data["runs"] == 40 and data["convergence_rate"] == 1.0
    assert data["nuisance"] == "unknown"
    assert [r["parameter"] for r in data["summary"]] == ["x", "y", "vx", "vy"]
    assert set(data["summary"][0]) >= {"bias", "rmse", "crlb", "ratio", "ratio_low",
                                       "ratio_high"}
    assert data["status_counts"] == {"converged": 40}
    with_runs = gu2007_40.as_dict(runs=True)
    assert len(with_runs["table"]) == 40
    json.dumps(with_runs)


# -- saving ------------------------------------------------------------------------------------
def test_save_writes_csv_and_parquet_and_refuses_to_overwrite(gu2007_40, tmp_path):
    from tmakit.io.tables import write_table

    def save(path, force=False):
        return write_table(path, gu2007_40.table, force=force, what="the per-run table")

    csv = tmp_path / "runs.csv"
    save(csv)
    back = pd.read_csv(csv)
    assert list(back.columns) == list(gu2007_40.table.columns)
    np.testing.assert_allclose(back["est_x"], gu2007_40.table["est_x"], rtol=1e-12)
    with pytest.raises(FileExistsError, match="already exists"):
        save(csv)
    save(csv, force=True)

    pq = tmp_path / "runs.parquet"
    save(pq)
    pd.testing.assert_frame_equal(pd.read_parquet(pq), gu2007_40.table,
                                  check_dtype=False)
    with pytest.raises(FileExistsError):
        save(pq)
    with pytest.raises(ValueError, match=r"\.csv or \.parquet"):
        save(tmp_path / "runs.xlsx")


# -- Dask --------------------------------------------------------------------------------------
def test_dask_local_cluster_gives_the_local_table(gu2007):
    distributed = pytest.importorskip("distributed")
    local = monte_carlo(gu2007, runs=10, rng=9, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        remote = monte_carlo(gu2007, runs=10, rng=9, progress=False, dask=client, chunk=3)
        by_address = monte_carlo(gu2007, runs=4, rng=9, progress=False,
                                 dask=cluster.scheduler_address)
    pd.testing.assert_frame_equal(local.table, remote.table)
    pd.testing.assert_frame_equal(local.table.iloc[:4], by_address.table)
    assert remote.executor.startswith("dask ")


def test_simulated_values_are_the_sets_simulate_gives(gu2007):
    """One template and a values array: the draws and rows of simulate(), run by run."""
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(8).spawn(3)]
    template, values = gu2007.simulate_values(rngs)
    for r, child in enumerate(np.random.SeedSequence(8).spawn(3)):
        one = gu2007.simulate(np.random.default_rng(child))
        np.testing.assert_array_equal(values[r], one.value_si)
        np.testing.assert_array_equal(template.time, one.time)
        np.testing.assert_array_equal(template.sigma_si, one.sigma_si)
    sets = gu2007.simulate_many([1, 2])
    assert sets[1].metadata["seed"] == "2"
    np.testing.assert_array_equal(sets[0].value_si, gu2007.simulate(1).value_si)


def test_run_summaries_give_the_status_of_a_full_result(tmp_path):
    """Unobservable (a 3-D bearings-only fit), diverged and failed runs, summarised in one
    batch, read as estimate() and a failed run do."""
    from sample_logs import replay_sample

    from tmakit.batch.ml import Best, MaximumLikelihood
    from tmakit.montecarlo.runs import solve_runs, summarise_runs

    rep = tmp_path / "c.rep"
    rep.write_text(replay_sample(0)[0])
    tall = tk.read_measurements(rep, bearing_sigma_deg=0.5, dim=3)
    motion = tk.motion_from_name("cv3d")
    one = estimate(tall, motion)
    assert one.status == "unobservable"
    problem, bests = solve_runs(MaximumLikelihood(), tall, np.stack([tall.value_si] * 2),
                                motion)
    bests += [Best(np.full(6, np.nan), bests[0].nuisance, np.inf, 3, False, 2),
              ValueError("no start")]
    got = summarise_runs(problem, bests, None)
    assert got.status == ["unobservable", "unobservable", "diverged", "failed"]
    assert got.iterations.tolist() == [one.iterations] * 2 + [3, 0]
    assert got.starts.tolist() == [one.starts] * 2 + [2, 0]
    np.testing.assert_allclose(got.chi2[:2], one.chi2, rtol=1e-9)
    assert np.isinf(got.chi2[2]) and np.isnan(got.chi2[3])
    seen = [k for k, n in enumerate(motion.param_names) if n != "z"]  # z: not observed
    np.testing.assert_allclose(got.estimates[:2, seen], [one.estimate[seen]] * 2, rtol=1e-6)
    assert np.isnan(got.estimates[2:]).all() and got.failures == {3: "ValueError: no start"}


# -- worker processes --------------------------------------------------------------------------
def test_two_worker_processes_give_the_one_process_table(gu2007):
    """Same seed, same chunks: 1 and 2 workers give identical per-run results."""
    one = monte_carlo(gu2007, runs=12, rng=3, progress=False, chunk=3)
    two = monte_carlo(gu2007, runs=12, rng=3, progress=False, chunk=3, workers=2)
    pd.testing.assert_frame_equal(one.table, two.table)
    assert (one.executor, two.executor) == ("local", "2 processes")
    saved = []
    monte_carlo(gu2007, runs=5, rng=3, progress=False, chunk=2, workers=2,
                on_chunk=saved.append)
    assert sorted(o.first_run for o in saved) == [0, 2, 4]
    pd.testing.assert_frame_equal(mc.finished_runs_table(saved, one.parameters),
                                  one.table.iloc[:5])


def test_the_library_changes_no_process_wide_setting_unasked():
    """A study in the user's process leaves the allocator and BLAS splitting as they were
    (checked in a fresh interpreter); `tma montecarlo`, a process of tmakit's own, may."""
    import subprocess
    import sys

    code = ("import tmakit as tk, tmakit.montecarlo.execution as m, tmakit.core.blas as b; "
            "tk.monte_carlo('gu2007', runs=2, progress=False); print(m._done, b._SPLIT)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "False"]


def test_chunks_keep_freed_memory_where_glibc_allows(gu2007):
    """The allocator setting is taken once per process on Linux (glibc), and a study after it
    gives the same table."""
    import sys

    from tmakit.montecarlo import keep_freed_memory

    before = monte_carlo(gu2007, runs=3, rng=12, progress=False)
    if sys.platform.startswith("linux"):
        assert keep_freed_memory() is True
    after = monte_carlo(gu2007, runs=3, rng=12, progress=False)
    pd.testing.assert_frame_equal(before.table, after.table)


# -- the estimator registry --------------------------------------------------------------------
def test_the_registry_names_the_estimators_and_what_they_accept(gu2007):
    assert mc.available_estimators() == tuple(METHODS)
    assert mc.available_estimators()[0] == "ml"
    with pytest.raises(ValueError, match="unknown estimator 'kalman'; expected one of ml, "
                                         "gu-direct, ratio-power"):
        monte_carlo(gu2007, estimator="kalman", runs=2, progress=False)
    # Declared by the estimator's class, not found by inspecting a signature.
    with pytest.raises(ValueError, match="'ratio' cannot be given known nuisance"):
        monte_carlo(gu2007, estimator="ratio", runs=1, known_nuisance=True, progress=False)


def test_other_estimators_run_by_run_through_the_registry(monkeypatch, gu2007):
    calls = []

    class Fake(BatchEstimator):
        name = "fake"

        def __init__(self, init=None, options=None):
            self.init, self.options = init, options

        def fit(self, meas, motion):
            calls.append(("fake", len(meas), self.options))
            if len(calls) == 2:
                raise ValueError("this run has no solution")
            return estimate(meas, motion, init=gu2007.truth, options=self.options)

    monkeypatch.setitem(METHODS, "fake", Method(Fake))
    assert mc.available_estimators()[-1] == "fake"
    res = monte_carlo(gu2007, estimator="fake", runs=3, rng=1, progress=False)
    assert [c[0] for c in calls] == ["fake"] * 3
    assert calls[0][2] == gu2007.measurement_options
    assert res.table["status"].tolist() == ["converged", "failed", "converged"]
    assert np.isnan(_estimates(res)[1]).all()
    assert res.failures == {1: "ValueError: this run has no solution"}
    assert res.convergence_rate == pytest.approx(2 / 3)
    assert res.summary_table()[0]["n"] == 2
    assert "1 runs failed" in res.summary()
    with pytest.raises(ValueError, match="cannot be given known nuisance"):
        monte_carlo(gu2007, estimator="fake", runs=1, known_nuisance=True, progress=False)


# -- arguments ---------------------------------------------------------------------------------
@pytest.mark.parametrize(("kwargs", "message"), [
    ({"runs": 0}, "runs must be a whole number >= 1, got 0"),
    ({"runs": -3}, "runs must be a whole number >= 1"),
    ({"runs": 2.5}, "runs must be a whole number >= 1"),
    ({"runs": True}, "runs must be a whole number >= 1"),
    ({"chunk": 0}, "chunk must be a whole number >= 1"),
    ({"estimator": "magic"}, "unknown estimator 'magic'; expected one of .*ml"),
    ({"rng": -1}, "rng must be a numpy.random.Generator, a whole number >= 0 or None"),
    ({"rng": 1.5}, "rng must be a numpy.random.Generator"),
    ({"init": [1.0, 2.0]}, "init must give 4 values"),
    ({"init": {"x": 1.0}}, "missing y, vx, vy"),
    ({"dask": 42}, "dask must be a scheduler address"),
    ({"workers": 0}, "workers must be a whole number >= 1, got 0"),
    ({"workers": 2, "dask": "tcp://127.0.0.1:1"}, "either dask .* or workers"),
])
def test_bad_arguments_raise_value_error_with_a_clear_message(gu2007, kwargs, message):
    if "dask" in kwargs:
        pytest.importorskip("distributed")
    with pytest.raises(ValueError, match=message):
        monte_carlo(gu2007, **{"runs": 2, "progress": False, **kwargs})


def test_scenario_by_name_and_progress_bar(capsys):
    pytest.importorskip("tqdm")
    res = monte_carlo("gu2007", runs=1, rng=0, progress=True)
    assert res.scenario == "gu2007" and res.runs == 1
    assert "1/1" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown scenario"):
        monte_carlo("no-such-scenario", runs=1, progress=False)
