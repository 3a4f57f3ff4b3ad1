"""Whether a track is the same, bit for bit, in fresh processes (and after other work in them).

    python benchmarks/track_reproducible.py [--runs 8] [--alone]

Each run is a fresh ``python`` process that tracks bearings-only-2d seeds 3 and 0 (EKF), then
gu2007 seeds 3, 4 and 2 (UKF), then hoerst2010 seed 2 (EKF) (``--alone``: hoerst2010 only),
with ``OMP_NUM_THREADS=1``, and prints a SHA-256 of the last track's times, states,
covariances and NIS with its start record.  The runs agree when every digest is the same.
Address-space layout randomisation (and so the contents of memory a library reads before it
writes it) differs from process to process: this is how a result that depends on it shows.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys

RUN = """
import hashlib, json
import numpy as np
import tmakit as tk
from tmakit.tracking import start_record
if not {alone}:
    for seed in (3, 0):
        tk.track(tk.load_scenario("bearings-only-2d").simulate(rng=seed), "ekf")
    for seed in (3, 4, 2):
        tk.track(tk.load_scenario("gu2007").simulate(rng=seed), "ukf")
t = tk.track(tk.load_scenario("hoerst2010").simulate(rng=2), "ekf")
h = hashlib.sha256()
for a in (t.times, t.states, t.covariances, t.nis):
    h.update(np.ascontiguousarray(a).tobytes())
start = start_record(t).as_dict()
h.update(json.dumps(start, sort_keys=True).encode())
print(json.dumps({{"digest": h.hexdigest()[:16],
                  "widened": [w["factor"] for w in start.get("widened", [])]}}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=8)
    parser.add_argument("--alone", action="store_true", help="track hoerst2010 only")
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    env["OMP_NUM_THREADS"] = "1"
    code = RUN.format(alone=args.alone)
    seen: collections.Counter[str] = collections.Counter()
    for i in range(args.runs):
        out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                             capture_output=True, text=True).stdout.strip().splitlines()[-1]
        got = json.loads(out)
        seen[got["digest"]] += 1
        print(f"run {i + 1}: {got['digest']}  widening factors {got['widened']}", flush=True)
    print(f"{len(seen)} distinct result(s) in {args.runs} runs: {dict(seen)}")
    sys.exit(0 if len(seen) == 1 else 1)


if __name__ == "__main__":
    main()
