"""Fuzzing the ``tma`` command: hostile files, scenarios and options (hypothesis).

For every case: exit 0 with a valid result, exit 4 with an honest status, or exit 2 with an
``error:`` naming what is wrong; never a traceback or internal error, never a changed file that
was not to be written, never more than 10 s.  Few examples per property keep the normal suite
fast; ``TMA_FUZZ_EXAMPLES=500`` (or benchmarks/fuzz_outcomes.py) runs a longer profile.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from fuzzing import (
    GOOD,
    base_file,
    latlon_range_difference_files,
    measurement_files,
    option_cases,
    plan_scenarios,
    run_case,
    toml_scenarios,
)
from hypothesis import HealthCheck, given, settings

import tmakit as tk

EXAMPLES = int(os.environ.get("TMA_FUZZ_EXAMPLES", "12"))
LIMIT_S = 10.0
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@FUZZ
@given(case=measurement_files())
def test_hostile_measurement_files_give_a_result_or_a_clear_error(case):
    what, data = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        path = folder / "obs.csv"
        path.write_bytes(data)
        for args in (["show", str(path)], ["crlb", str(path)]):
            outcome = run_case(args, folder)
            assert outcome.kind in GOOD, (what, args, outcome)
            assert outcome.seconds < LIMIT_S, (what, args, outcome.seconds)
            if outcome.exit_code == 2:
                assert "obs.csv" in outcome.output or "--" in outcome.output, (what, outcome)


@FUZZ
@given(case=toml_scenarios())
def test_hostile_scenarios_are_refused_or_simulate_a_file_the_reader_accepts(case):
    field, data = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        toml = folder / "s.toml"
        toml.write_bytes(data)
        outcome = run_case(["simulate", str(toml), "-o", str(folder / "out.csv")], folder,
                           may_write=("out.csv",))
        assert outcome.kind in GOOD, (field, outcome)
        assert outcome.seconds < LIMIT_S, (field, outcome.seconds)
        if outcome.exit_code == 0:  # the library writes only what the library reads
            assert len(tk.read_measurements(folder / "out.csv")) > 0
        else:
            assert not (folder / "out.csv").exists()


@FUZZ
@given(case=option_cases())
def test_hostile_option_values_give_a_result_or_name_the_option(case):
    option, args = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        path = folder / "obs.csv"
        path.write_text(base_file())
        outcome = run_case([a.replace("{file}", str(path)) for a in args], folder)
        assert outcome.kind in GOOD, (option, args, outcome)
        assert outcome.seconds < LIMIT_S, (option, outcome.seconds)


@FUZZ
@given(case=latlon_range_difference_files())
def test_latlon_files_with_range_differences_give_a_fit_or_name_the_row(case):
    what, data = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        path = folder / "obs.csv"
        path.write_bytes(data)
        for args in (["show", str(path)], ["estimate", str(path), "--motion", "cv3d"]):
            outcome = run_case(args, folder)
            assert outcome.kind in GOOD, (what, args, outcome)
            assert outcome.seconds < LIMIT_S, (what, args, outcome.seconds)
            if outcome.exit_code == 2:
                assert "obs.csv" in outcome.output or "range differences" in outcome.output, (
                    what, outcome)


@FUZZ
@given(case=plan_scenarios())
def test_odd_planning_tables_are_refused_by_field_or_planned(case):
    field, data = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        toml = folder / "s.toml"
        toml.write_bytes(data)
        outcome = run_case(["plan", str(toml), "--runs", "1", "--duration", "20",
                            "--particles", "50", "--no-progress", "-o", str(folder / "p.csv")],
                           folder, may_write=("p.csv",))
        assert outcome.kind in GOOD, (field, outcome)
        assert outcome.seconds < LIMIT_S, (field, outcome.seconds)
        if outcome.exit_code == 2:
            assert "s.toml" in outcome.output or "--duration" in outcome.output, (field, outcome)
            assert not (folder / "p.csv").exists()
