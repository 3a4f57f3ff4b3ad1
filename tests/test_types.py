"""Types are checked: mypy on the whole package, every flag of ``--strict`` on the public modules.

One mypy run: the public modules are listed in ``pyproject.toml`` (the ``[[tool.mypy.overrides]]``
that holds them to the flags of ``mypy --strict``); the list must hold every module
``tmakit/__init__.pyi`` imports from and every module that defines a public name, so that it
cannot fall behind the public face, and the flags must be every flag ``--strict`` sets. The same
run checks a user's script (:data:`USER_SCRIPT`): a misspelt keyword is a type error.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
import uuid
from pathlib import Path

import pytest

import tmakit

ROOT = Path(__file__).resolve().parents[1]
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
PUBLIC = next(o for o in CONFIG["overrides"] if o.get("disallow_untyped_defs"))
STRICT = PUBLIC["module"]

pytest.importorskip("mypy")

#: A user's script: each line marked ``# error: code`` must be that mypy error, no other line one.
USER_SCRIPT = """\
import numpy as np
import tmakit as tk
from tmakit.batch.methods import estimate_with, estimator
from tmakit.filters import (FILTERS, BearingPrior, ExtendedKalmanFilter, FirstBearing,
                            GaussianSumFilter, ModifiedPolarEKF, MultipleModelParticleFilter,
                            ParticleFilter, TrackingFilter)


def starts(res: tk.EstimateResult, prior: BearingPrior, first: FirstBearing,
           meas: tk.MeasurementSet) -> None:
    ekf: ExtendedKalmanFilter = ExtendedKalmanFilter.from_estimate(res, 10.0, iterations=2)
    pf: TrackingFilter = FILTERS["pf"].from_first_bearing(prior, first, particles=10, rng=1)
    ExtendedKalmanFilter.from_estimate(res, 10.0, bogus_option=3)  # error: call-arg
    ExtendedKalmanFilter.from_estimate(res, 10.0, q="0.1")  # error: arg-type
    ParticleFilter.from_first_bearing(prior, first, partcles=10)  # error: call-arg
    ModifiedPolarEKF.from_first_bearing(prior, first, 3, dynamic=None)  # error: call-arg
    GaussianSumFilter.from_mixture([1.0], [[1.0] * 4], [np.eye(4)], componet="")  # error: call-arg
    MultipleModelParticleFilter(np.zeros(4), np.eye(4), bogus_option=3)  # error: call-arg
    ExtendedKalmanFilter(np.zeros(4), np.eye(4), iteration=2)  # error: call-arg
    FILTERS["ekf"].from_estimate(res, 10.0, bogus_option=3)  # error: call-arg
    tk.estimate(meas, tk.ConstantVelocity(2), bogus=1)  # error: call-arg
    cv = tk.ConstantVelocity(2)
    estimate_with("gu-direct", meas, cv, tols=1e-6)  # error: call-arg
    estimate_with("ml", meas, cv, init={"x": 1.0}, max_iter=5, exact=True)
    estimator("ml", grid=3)  # error: arg-type
"""


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
def test_mypy_is_clean_on_the_package_and_strict_on_the_public_modules(tmp_path):
    # settings from pyproject.toml; the cache is the checkout's, as a user's mypy's
    # a module name of its own each run: mypy's cache keeps a module's path from the run before
    script = tmp_path / f"user_script_{uuid.uuid4().hex}.py"
    script.write_text(USER_SCRIPT)
    out = subprocess.run([sys.executable, "-m", "mypy", *CONFIG["files"], str(script)],
                         cwd=ROOT, capture_output=True, text=True, check=False)
    found = re.findall(r"^(.*?):(\d+): error: .*\[([a-z-]+)\]$", out.stdout, re.MULTILINE)
    wanted = [(str(script), str(i), m.group(1))
              for i, line in enumerate(USER_SCRIPT.splitlines(), 1)
              if (m := re.search(r"# error: ([a-z-]+)$", line))]
    assert sorted(found) == sorted(wanted), out.stdout[-4000:] + out.stderr[-2000:]
    assert out.returncode == 1 and "error: " not in out.stderr, out.stderr[-2000:]
