"""`tma --help` and `tma scenarios` start without the numerical core or pydantic.

Each command runs in a fresh interpreter (`python -c`), which then reports the modules it
imported; nothing here is timed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import tmakit

# Imported only inside the commands that need them.
HEAVY = ("scipy", "pandas", "pyarrow", "pandera", "matplotlib", "dask",
         "tmakit.batch", "tmakit.bounds", "tmakit.filters", "tmakit.tracking",
         "tmakit.montecarlo", "tmakit.reproduce", "tmakit.montecarlo.geometries", "tmakit.plot",
         "tmakit.io", "tmakit.results", "tmakit.scenario.files")

SCRIPT = """
import json, sys
sys.argv = ["tma", *{args!r}]
from tmakit.cli import main
try:
    main()
except SystemExit as e:
    code = e.code
print(json.dumps({{"code": code, "modules": sorted(sys.modules)}}))
"""


def imported_by(*args: str) -> list[str]:
    src = str(Path(tmakit.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (src, os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT.format(args=list(args))],
                          capture_output=True, text=True, env=env, check=True)
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["code"] in (0, None), proc.stderr
    return report["modules"]


def heavy(modules: list[str]) -> list[str]:
    return [m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY)]


def test_help_imports_neither_the_numerical_core_nor_pydantic():
    modules = imported_by("--help")
    assert heavy(modules) == []
    assert not [m for m in modules if m == "pydantic" or m.startswith("pydantic.")]


# Below, pydantic itself may be imported by typer (>= 0.2x coerces a command's parameters
# with it, even those of --help); tmakit's own heavy modules must still stay out.
@pytest.mark.parametrize("args", [("estimate", "--help"), ("track", "--help"),
                                  ("montecarlo", "--help")])
def test_a_command_help_imports_no_numerical_core(args):
    assert heavy(imported_by(*args)) == []


def test_listing_the_scenarios_needs_no_scenario_parser():
    # The titles are read with tomllib, without tmakit.scenario.files's pydantic models.
    modules = imported_by("scenarios")
    assert heavy(modules) == []
    assert "tmakit.scenario.catalog" in modules
    # Nor pydantic: typer would import it to coerce parameters; the listing has none.
    assert not [m for m in modules if m == "pydantic" or m.startswith("pydantic.")]


def test_help_does_not_load_the_markdown_renderer():
    # typer's rich help imports rich.markdown (and markdown_it): the help is plain instead.
    modules = imported_by("--help")
    assert not [m for m in modules if m.startswith(("rich.markdown", "markdown_it",
                                                    "typer.rich_utils"))]
    # Nor rich's tables: the commands import them where they make one.
    assert "rich.table" not in modules


@pytest.mark.parametrize("args", [[], ["-h"], ["--help"]])
def test_the_listing_is_the_full_apps_help(args):
    # `tma`, `tma -h` and `tma --help` are answered by an app whose commands have no
    # parameters (typer builds none): its output and exit status must be the full app's.
    from typer.testing import CliRunner

    from tmakit.cli import app, listing_app

    runner = CliRunner()
    full, listing = runner.invoke(app, args), runner.invoke(listing_app(), args)
    assert listing.output == full.output and listing.exit_code == full.exit_code
    assert "estimate" in full.output and "Options:" in full.output


def test_main_answers_the_bare_help_with_the_listing(monkeypatch, capsys):
    import typer.main

    import tmakit.cli as cli

    built = []
    original = typer.main.get_params_from_function
    monkeypatch.setattr(typer.main, "get_params_from_function",
                        lambda f: built.append(f) or original(f))
    monkeypatch.setattr(sys, "argv", ["tma", "--help"])
    with pytest.raises(SystemExit) as ended:
        cli.main()
    assert ended.value.code == 0 and "Commands:" in capsys.readouterr().out
    # the root's options and the stand-ins were built, no command's parameters
    commands = {info.callback for info in cli.app.registered_commands}
    assert len(built) > len(commands) and not commands & set(built)
