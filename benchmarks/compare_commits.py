"""Speed of this tree beside an earlier commit, workload by workload (a refactor's check).

    python benchmarks/compare_commits.py --base 77818d8 [--repeat 7]

The base commit's ``src`` is exported to a temporary folder; every workload then runs in a
fresh subprocess for each tree, alternating base and head ``--repeat`` times, and reports the
median CPU time of the workload itself (``time.process_time`` around it, so imports and other
processes on the machine do not count; BLAS held to one thread) with its interquartile range,
and head / base.
The workloads use only APIs both trees have (``tmakit.estimate``, ``tmakit.track``,
``tmakit.bounds.crlb``, ``tmakit.montecarlo.monte_carlo``, ``tmakit.read_measurements``,
``tmakit.planning.Planner``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

_PLANNER_SETUP = """
import numpy as np
from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, Planner, SensorPlan
from tmakit.sensors import PlatformState, platform_configuration
cfg = platform_configuration("hurtado_nehorai_2008"); TARGET = np.array([-2e3, 15e3, 25.0, 0.0])
post = PosteriorInformation.from_prior(np.diag([500.0**2, 500.0**2, 100.0, 100.0]),
                                       NearlyConstantVelocity(dim=2, q=0.1), time=0.0)
START, bel = PlatformState((0.0, 0.0), 0.0, 50.0), Belief(post, TARGET)
base = dict(kinematics=cfg.kinematics, actions=cfg.actions, interval=cfg.interval)
"""  # the two planner workloads' belief and platform

WORKLOADS = {
    "planner decision hurtado2008 x2000 (compiled)": _PLANNER_SETUP + """
p = Planner(**base, plan=SensorPlan(["bearing", "range"], (0.0175, 30.0))); p.recommend(START, bel)
t = time.process_time()
for _ in range(2000): p.recommend(START, bel)
""",
    "planner H=2 over 1,000 particles x20 (general path)": _PLANNER_SETUP + """
cloud = TARGET + np.random.default_rng(0).standard_normal((1000, 4)) * [500, 500, 10, 10]
p = Planner(**base, plan=SensorPlan(["bearing", "range"], (0.0175, 30.0)), gamma="cloud",
            horizon=2); bel = Belief(post, cloud); p.recommend(START, bel)
t = time.process_time()
for _ in range(20): p.recommend(START, bel)
""",
    "planner 3-D, climbing, over 1,000 particles x40 (geometric cloud)": """
import numpy as np
from tmakit.bounds.pcrb_recursion import PosteriorInformation
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.planning import Belief, Planner, SensorPlan
from tmakit.sensors import Actions, PlatformState, platform_configuration
cfg = platform_configuration("hurtado_nehorai_2008"); rng = np.random.default_rng(3)
post = PosteriorInformation.from_prior(np.diag([500.0**2] * 3 + [100.0] * 3),
                                       NearlyConstantVelocity(dim=3, q=0.1), time=0.0)
cloud = ([-2e3, 15e3, 900.0, 25.0, 0.0, 0.0]
         + rng.standard_normal((1000, 6)) * [500, 500, 100, 10, 10, 1])
p = Planner(cfg.kinematics, Actions.grid(np.radians([-10.0, 0.0, 10.0]), [0.9, 1.0, 1.1],
                                         climb_rates=[-5.0, 0.0, 5.0]), cfg.interval,
            SensorPlan(["bearing", "range", "range_rate", "elevation"], (0.0175, 30.0, 0.5, 0.02),
                       dim=3), gamma="cloud")
START, bel = PlatformState((0.0, 0.0, 100.0), 0.0, 50.0), Belief(post, cloud)
p.recommend(START, bel)
t = time.process_time()
for _ in range(40): p.recommend(START, bel)
""",
    "ml no-guess, gu2007 x20": """
scn = tk.load_scenario("gu2007"); data = [scn.simulate(rng=s) for s in range(20)]
t = time.process_time()
for m in data: tk.estimate(m, scn.motion)
""",
    "ml no-guess, gu2007 x20, after one estimate (its imports made)": """
scn = tk.load_scenario("gu2007"); data = [scn.simulate(rng=s) for s in range(20)]
tk.estimate(data[0], scn.motion)
t = time.process_time()
for m in data: tk.estimate(m, scn.motion)
""",
    "crlb gu2007 x20": """
from tmakit.bounds import crlb
scn = tk.load_scenario("gu2007"); crlb(scn)
t = time.process_time()
for _ in range(20): crlb(scn)
""",
    "track ekf bearings-only-2d": """
m = tk.load_scenario("bearings-only-2d").simulate(rng=3); tk.track(m, "ekf")
t = time.process_time()
for _ in range(3): tk.track(m, "ekf")
""",
    "track ukf gu2007": """
# (a start's covariance widened to its profile likelihood: not computed before commit 0a9b5f5)
m = tk.load_scenario("gu2007").simulate(rng=3); tk.track(m, "ukf")
t = time.process_time()
for _ in range(3): tk.track(m, "ukf")
""",
    "track ukf gu2007 seed 4 (a start's profile ends left short by Gauss-Newton)": """
m = tk.load_scenario("gu2007").simulate(rng=4); tk.track(m, "ukf")
t = time.process_time()
for _ in range(3): tk.track(m, "ukf")
""",
    "track pf 2000 bearings-only-2d": """
m = tk.load_scenario("bearings-only-2d").simulate(rng=3)
# (the first track of a process imports tmakit.filters and scipy.linalg here, about 0.15 s, which
# load_scenario imported at commit fc22db2 (not counted there); not a numba compile)
t = time.process_time()
tk.track(m, "pf", particles=2000, rng=1)
""",
    "track pf 2000 bearings-only-2d, second call": """
m = tk.load_scenario("bearings-only-2d").simulate(rng=3); tk.track(m, "pf", particles=2000, rng=1)
t = time.process_time()
tk.track(m, "pf", particles=2000, rng=1)
""",
    "track pf 2000 bearings-only-2d, whole process": """
t = 0.0  # process CPU time from the interpreter's start: the imports counted wherever made
m = tk.load_scenario("bearings-only-2d").simulate(rng=3)
tk.track(m, "pf", particles=2000, rng=1)
""",
    "monte carlo gu2007 300 runs": """
from tmakit.montecarlo import monte_carlo
scn = tk.load_scenario("gu2007")
t = time.process_time()
monte_carlo(scn, runs=300, seed=1, progress=False)
""",
    "monte carlo gu2007 300 runs, freed memory kept": """
from tmakit.montecarlo import monte_carlo
try:  # opt-in since issue 27; the base commit (fc22db2) made it in every chunk itself
    from tmakit.montecarlo import keep_freed_memory
    keep_freed_memory()
except ImportError:
    pass
scn = tk.load_scenario("gu2007")
t = time.process_time()
monte_carlo(scn, runs=300, seed=1, progress=False)
""",
    "read 100k-row csv": """
import numpy as np
scn = tk.load_scenario("bearings-only-2d")
parts = []
for s in range(167):  # 167 copies of 600 rows, each 1000 s later than the last
    m = scn.simulate(rng=s)
    parts.append(tk.MeasurementSet(m.time + 1000.0 * s, m.sensor, m.kind, m.value, m.sigma,
                                   m.sensor_state, m.time_ref, m.ref_sensor_state,
                                   dict(m.metadata)))
big = tk.MeasurementSet.concatenate(parts)
import tempfile, os
d = tempfile.mkdtemp(); p = os.path.join(d, "big.csv"); tk.write_measurements(big, p)
t = time.process_time()
tk.read_measurements(p)
""",
    "read 100k-row csv, one bad cell": """
import numpy as np
from tmakit.io import MeasurementFileError
scn = tk.load_scenario("bearings-only-2d")
parts = []
for s in range(167):  # the file of "read 100k-row csv", one sigma negative: the checker reads it
    m = scn.simulate(rng=s)
    parts.append(tk.MeasurementSet(m.time + 1000.0 * s, m.sensor, m.kind, m.value, m.sigma,
                                   m.sensor_state, m.time_ref, m.ref_sensor_state,
                                   dict(m.metadata)))
big = tk.MeasurementSet.concatenate(parts)
import tempfile, os
d = tempfile.mkdtemp(); p = os.path.join(d, "big.csv"); tk.write_measurements(big, p)
lines = open(p).read().split(chr(10)); cells = lines[50_000].split(","); cells[4] = "-1"
lines[50_000] = ",".join(cells); open(p, "w").write(chr(10).join(lines))
t = time.process_time()
try:
    tk.read_measurements(p)
except MeasurementFileError as e:
    assert "column 'sigma'" in str(e)
""",
    "manoeuvres hoerst2010 curvilinear:2": """
m = tk.load_scenario("hoerst2010").simulate(rng=2)
t = time.process_time()
tk.estimate(m, "curvilinear:2")
""",
    "manoeuvres hoerst2010 curvilinear:3": """
m = tk.load_scenario("hoerst2010").simulate(rng=2)
t = time.process_time()
tk.estimate(m, "curvilinear:3")
""",
    "monte carlo gu2007 2000 runs (compiled)": """
from tmakit.montecarlo import monte_carlo
scn = tk.load_scenario("gu2007")
t = time.process_time()
monte_carlo(scn, runs=2000, seed=1, progress=False)
""",
    "no-guess bearings-only 10^5 rows x3": """
import dataclasses, numpy as np
scn = tk.load_scenario("bearings-only-2d"); lo, hi = scn.time_span()
plans = [dataclasses.replace(p, times=np.linspace(lo, hi, 100_000)) for p in scn.plans]
scn = dataclasses.replace(scn, plans=plans); m = scn.simulate(np.random.default_rng(0))
t = time.process_time()
for _ in range(3): tk.estimate(m, scn.motion)
""",
    "estimate init= bearings-only 100 rows x300": """
import dataclasses, numpy as np
scn = tk.load_scenario("bearings-only-2d"); lo, hi = scn.time_span()
plans = [dataclasses.replace(p, times=np.linspace(lo, hi, 100)) for p in scn.plans]
scn = dataclasses.replace(scn, plans=plans); m = scn.simulate(np.random.default_rng(0))
start = scn.theta + 3.0 * tk.crlb(scn).std[:4] * np.array([1.0, -1.0, 1.0, -1.0])
tk.estimate(m, scn.motion, init=start)
t = time.process_time()
for _ in range(300): tk.estimate(m, scn.motion, init=start)
""",
    "crlb bearings-only 1000 rows x300": """
import dataclasses, numpy as np
scn = tk.load_scenario("bearings-only-2d"); lo, hi = scn.time_span()
plans = [dataclasses.replace(p, times=np.linspace(lo, hi, 1000)) for p in scn.plans]
scn = dataclasses.replace(scn, plans=plans); m = scn.simulate(np.random.default_rng(0))
tk.crlb(m, scn.motion, scn.truth)
t = time.process_time()
for _ in range(300): tk.crlb(m, scn.motion, scn.truth)
""",
    "estimate chen-sun-1 (bearing + range differences)": """
m = tk.load_scenario("chen-sun-1").simulate(rng=2)
t = time.process_time()
tk.estimate(m, tk.load_scenario("chen-sun-1").motion)
""",
    "estimate hoerst2010 cv2d (bearing + azimuth rate)": """
m = tk.load_scenario("hoerst2010").simulate(rng=2)
t = time.process_time()
tk.estimate(m, "cv2d")
""",
    # The three rows above time a process's first estimate: since issue 27 the batch package and
    # scipy's optimisers are imported there, where fc22db2 imported them with tmakit.  The rows
    # below time the same estimates after one (the imports made), and one whole process.
    "no-guess bearings-only 10^5 rows x3, after one estimate": """
import dataclasses, numpy as np
scn = tk.load_scenario("bearings-only-2d"); lo, hi = scn.time_span()
plans = [dataclasses.replace(p, times=np.linspace(lo, hi, 100_000)) for p in scn.plans]
scn = dataclasses.replace(scn, plans=plans); m = scn.simulate(np.random.default_rng(0))
tk.estimate(m, scn.motion)
t = time.process_time()
for _ in range(3): tk.estimate(m, scn.motion)
""",
    "estimate chen-sun-1 x20, after one estimate": """
scn = tk.load_scenario("chen-sun-1"); m = scn.simulate(rng=2); tk.estimate(m, scn.motion)
t = time.process_time()
for _ in range(20): tk.estimate(m, scn.motion)
""",
    "estimate chen-sun-1, whole process": """
t = 0.0  # process CPU time from the interpreter's start: the imports counted wherever made
scn = tk.load_scenario("chen-sun-1"); tk.estimate(scn.simulate(rng=2), scn.motion)
""",
    "estimate hoerst2010 cv2d x3, after one estimate": """
m = tk.load_scenario("hoerst2010").simulate(rng=2); tk.estimate(m, "cv2d")
t = time.process_time()
for _ in range(3): tk.estimate(m, "cv2d")
""",
}


def export(rev: str, into: Path) -> Path:
    """The ``src`` folder of commit ``rev``, unpacked below ``into``."""
    data = subprocess.run(["git", "archive", rev, "src"], cwd=ROOT, check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(data)) as tar:
        tar.extractall(into, filter="data")
    return into / "src"


def run(src: Path, body: str) -> float:
    """CPU seconds of one workload in a fresh interpreter on the package in ``src``."""
    code = ("import time, json\nimport tmakit as tk\n" + body.strip()
            + "\nprint(json.dumps(time.process_time() - t))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={"PYTHONPATH": str(src), "PATH": "/usr/bin:/bin",
                              "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"},
                         check=False)
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-2000:])
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", required=True, help="the commit to compare with")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", default=None, help="run the workloads whose name has this text")
    args = ap.parse_args()
    head = ROOT / "src"
    with tempfile.TemporaryDirectory() as tmp:
        base = export(args.base, Path(tmp))
        print(f"{'workload':38s} {'base (s)':>16s} {'head (s)':>16s} {'head/base':>9s}")
        for name, body in WORKLOADS.items():
            if args.only and args.only not in name:
                continue
            times = {"base": [], "head": []}
            run(base, body)  # untimed: a fresh export compiles its numba kernels once
            run(head, body)
            for _ in range(args.repeat):
                times["base"].append(run(base, body))
                times["head"].append(run(head, body))
            stats = {}
            for k, v in times.items():
                q1, med, q3 = np.percentile(v, [25, 50, 75])
                stats[k] = (med, q3 - q1)
            ratio = stats["head"][0] / stats["base"][0]
            print(f"{name:38s} {stats['base'][0]:9.4f} ±{stats['base'][1]:5.3f} "
                  f"{stats['head'][0]:9.4f} ±{stats['head'][1]:5.3f} {ratio:9.3f}", flush=True)
        print("medians of CPU time in fresh processes, base and head alternating; "
              "± is the interquartile range")


if __name__ == "__main__":
    main()
