"""The fuzz outcome table: hostile files, scenarios and options, counted by outcome.

    python benchmarks/fuzz_outcomes.py [--files 120] [--scenarios 100] [--options 120]
        [--latlon 60] [--plans 60]

Draws cases from the strategies of tests/fuzzing.py (seeded: the same cases every run), runs
each in-process and prints the count per outcome, the slowest case and every case that is not
an acceptable outcome (exit 0, exit 1 with an honest status, exit 2 with a clear error).
Peak memory of the whole run is printed too (each case runs in this process).
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

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


def collect(strategy, n: int) -> list:
    cases: list = []
    if n < 1:
        return cases

    @settings(max_examples=n, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(case=strategy)
    def draw(case):
        cases.append(case)

    draw()
    return cases


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--files", type=int, default=120)
    ap.add_argument("--scenarios", type=int, default=100)
    ap.add_argument("--options", type=int, default=120)
    ap.add_argument("--latlon", type=int, default=60, help="lat/lon files with range "
                    "differences (show and estimate each)")
    ap.add_argument("--plans", type=int, default=60, help="odd [planning] tables (tma plan)")
    a = ap.parse_args()
    counts: Counter[str] = Counter()
    bad: list[tuple[str, str, str]] = []
    slowest = (0.0, "")
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        jobs = []
        for what, data in collect(measurement_files(), a.files):
            for cmd in ("show", "crlb"):
                jobs.append((f"file {what} / {cmd}", data, [cmd, "{file}"], ()))
        for field, data in collect(toml_scenarios(), a.scenarios):
            jobs.append((f"toml {field}", data, ["simulate", "{toml}", "-o", "{out}"],
                         ("out.csv",)))
        for option, args in collect(option_cases(), a.options):
            jobs.append((f"option {option}", base_file().encode(), args, ()))
        for what, data in collect(latlon_range_difference_files(), a.latlon):
            for args in (["show", "{file}"], ["estimate", "{file}", "--motion", "cv3d"]):
                jobs.append((f"{what} / {args[0]}", data, args, ()))
        for field, data in collect(plan_scenarios(), a.plans):
            jobs.append((f"plan {field}", data, ["plan", "{toml}", "--runs", "1", "--duration",
                                                 "20", "--particles", "50", "--no-progress",
                                                 "-o", "{out}"], ("out.csv",)))
        for label, data, args, may_write in jobs:
            for p in folder.iterdir():
                p.unlink()
            target = folder / ("s.toml" if "{toml}" in args else "obs.csv")
            target.write_bytes(data)
            argv = [x.replace("{file}", str(target)).replace("{toml}", str(target))
                    .replace("{out}", str(folder / "out.csv")) for x in args]
            o = run_case(argv, folder, may_write)
            kind = o.kind if o.seconds < 10 else "over 10 s"
            counts[kind] += 1
            if o.seconds > slowest[0]:
                slowest = (o.seconds, label)
            if kind not in GOOD:
                bad.append((kind, label, o.output.strip().splitlines()[-1:][0]
                            if o.output.strip() else ""))
    total = sum(counts.values())
    print(f"{total} cases ({a.files} files x 2 commands, {a.scenarios} scenarios, "
          f"{a.options} option strings, {a.latlon} lat/lon range-difference files x 2 "
          f"commands, {a.plans} planning tables)")
    print("| outcome | count |\n|---|---|")
    for kind in (*GOOD, "unclear error", "traceback", "changed file", "nonsense",
                 "over 10 s"):
        print(f"| {kind} | {counts.get(kind, 0)} |")
    print(f"slowest case: {slowest[0]:.2f} s ({slowest[1]})")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory of the whole run: {peak:.0f} MB")
    for kind, label, last in bad:
        print(f"  {kind}: {label}: {last[:160]}")


if __name__ == "__main__":
    main()
