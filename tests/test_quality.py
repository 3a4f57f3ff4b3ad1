"""House rules that a test can check: lint clean, fast core import, console script."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent


@pytest.mark.skipif(shutil.which("ruff") is None and not shutil.which(
    str(Path(sys.executable).with_name("ruff"))), reason="ruff not installed")
def test_ruff_is_clean():
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    folders = [d for d in ("src", "tests", "benchmarks") if (ROOT / d).is_dir()]
    result = subprocess.run([ruff, "check", *folders], cwd=ROOT,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_core_import_is_light():
    code = ("import sys, time; t = time.perf_counter(); import tmakit; "
            "dt = time.perf_counter() - t; "
            "heavy = [m for m in ('pandas', 'pandera', 'pydantic', 'matplotlib', 'pyarrow', "
            "'typer') if m in sys.modules]; print(heavy, dt)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "[]", f"import tmakit pulled in {' '.join(out[:-1])}"
