"""Types are checked: mypy on the whole package, ``mypy --strict`` on the public modules.

The public modules are listed in ``pyproject.toml`` (``[tool.tmakit.typing] strict``); the list
must hold every module ``tmakit/__init__.pyi`` imports from and every module that defines a
public name, so that it cannot fall behind the public face.
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
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())
STRICT = CONFIG["tool"]["tmakit"]["typing"]["strict"]

pytest.importorskip("mypy")


def mypy(cache: str, *args: str) -> subprocess.CompletedProcess[str]:
    # One incremental cache a configuration: strict and plain flags invalidate each other's
    # entries, and the two tests run side by side under pytest-xdist.
    return subprocess.run([sys.executable, "-m", "mypy", "--cache-dir",
                           str(ROOT / ".mypy_cache" / cache), *args], cwd=ROOT,
                          capture_output=True, text=True, check=False)


def test_the_strict_list_covers_the_public_face():
    stub = ast.parse((ROOT / "src" / "tmakit" / "__init__.pyi").read_text())
    wanted = {"tmakit"} | {f"tmakit.{node.module}" for node in stub.body
                           if isinstance(node, ast.ImportFrom)}
    for name in tmakit.__all__:
        module = getattr(getattr(tmakit, name), "__module__", "") or ""
        if module.startswith("tmakit"):
            wanted.add(module)
    assert sorted(wanted - set(STRICT)) == []


@pytest.mark.long
def test_mypy_is_clean_on_the_package():
    out = mypy("package")  # files and settings from pyproject.toml
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]


@pytest.mark.long
def test_mypy_strict_is_clean_on_the_public_modules():
    args = [a for m in STRICT for a in ("-m", m)]
    out = mypy("strict", "--strict", "--follow-imports=silent", *args)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
