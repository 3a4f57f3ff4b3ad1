"""Types are checked: mypy on the whole package, every flag of ``--strict`` on the public modules.

One mypy run: the public modules are listed in ``pyproject.toml`` (the ``[[tool.mypy.overrides]]``
that holds them to the flags of ``mypy --strict``); the list must hold every module
``tmakit/__init__.pyi`` imports from and every module that defines a public name, so that it
cannot fall behind the public face, and the flags must be every flag ``--strict`` sets.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import tmakit

ROOT = Path(__file__).resolve().parents[1]
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
PUBLIC = next(o for o in CONFIG["overrides"] if o.get("disallow_untyped_defs"))
STRICT = PUBLIC["module"]

pytest.importorskip("mypy")


def test_the_strict_list_covers_the_public_face():
    stub = ast.parse((ROOT / "src" / "tmakit" / "__init__.pyi").read_text())
    wanted = {"tmakit"} | {f"tmakit.{node.module}" for node in stub.body
                           if isinstance(node, ast.ImportFrom)}
    for name in tmakit.__all__:
        module = getattr(getattr(tmakit, name), "__module__", "") or ""
        if module.startswith("tmakit"):
            wanted.add(module)
    assert sorted(wanted - set(STRICT)) == []


def test_the_public_modules_have_every_flag_of_strict():
    """What ``mypy --strict`` sets: per module on the public ones, the rest for the whole run."""
    from mypy.main import define_options
    from mypy.options import PER_MODULE_OPTIONS

    _, _, strict_flags = define_options()
    assert len(strict_flags) >= 10
    for flag, value in strict_flags:
        if flag in PER_MODULE_OPTIONS:
            assert PUBLIC.get(flag, CONFIG.get(flag)) == value, flag
        else:
            assert CONFIG.get(flag) == value, flag
    # every module's, tmakit's included, as --strict has it
    assert CONFIG["implicit_reexport"] is False
    assert all(o.get("implicit_reexport", False) is False for o in CONFIG["overrides"])


@pytest.mark.long
def test_mypy_is_clean_on_the_package_and_strict_on_the_public_modules():
    # files and settings from pyproject.toml; the cache is the checkout's, as a user's mypy's
    out = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True,
                         text=True, check=False)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
