"""Every third-party package that `src/` imports is declared in pyproject.toml (deptry).

A fresh machine has only what the package declares: an import that some other package happens
to pull in (click through dask, once) breaks `pip install . && tma demo` while the test extras
keep the suite green. `.ci/run` installs into a new virtual environment as well.
"""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _deptry(folder: Path, target: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "deptry", target], cwd=folder,
                          capture_output=True, text=True, timeout=120)


def test_every_import_of_src_is_declared():
    run = _deptry(ROOT, "src")
    assert run.returncode == 0, run.stdout + run.stderr


def test_an_undeclared_import_is_caught(tmp_path):
    (tmp_path / "pyproject.toml").write_text(textwrap.dedent("""\
        [project]
        name = "probe"
        version = "0"
        dependencies = ["numpy"]
        """))
    (tmp_path / "src" / "probe").mkdir(parents=True)
    (tmp_path / "src" / "probe" / "__init__.py").write_text("import numpy\nimport click\n")
    run = _deptry(tmp_path, "src")
    assert run.returncode != 0
    assert "click" in run.stdout + run.stderr
