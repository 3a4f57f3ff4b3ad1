"""Issue 12 figure: a Debrief replay file in one command recovers the contact's course and speed.

Each seeded replay file (``tmakit.io.samples.replay_sample``: own ship zig-zagging at 8 m/s,
a constant-velocity contact at 8-14 kn 6-9 km away, 720 bearings with 0.5 deg noise over one
hour, ``NULL`` sensor positions taken from the own ship's track) is read by the Debrief
reader and fitted by maximum likelihood (cv2d), exactly as

    tma estimate contact.rep --ownship OWNSHIP --contact CONTACT --motion cv2d --bearing-sigma 0.5

does.  Course = atan2(vx, vy) in degrees true and speed in knots, from the estimate; compared
with the contact's true course and speed.  Target: within 1 deg and 0.2 kn.

    python benchmarks/real_logs_replay.py --runs 100 --seed 0
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.io.logs import KNOT
from tmakit.io.samples import replay_sample

COMMAND = ["--ownship", "OWNSHIP", "--contact", "CONTACT", "--motion", "cv2d",
           "--bearing-sigma", "0.5"]


def one_command(folder: Path) -> None:
    text, truth = replay_sample(0)
    rep = folder / "contact.rep"
    rep.write_text(text)
    print(f"$ tma estimate contact.rep {' '.join(COMMAND)}   (seed 0; truth: course "
          f"{truth['course']:.2f} deg, speed {truth['speed']:.3f} kn)")
    result = CliRunner().invoke(app, ["estimate", str(rep), *COMMAND])
    print(result.output)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        one_command(folder)
        dc, ds, status = [], [], []
        for seed in range(args.seed, args.seed + args.runs):
            text, truth = replay_sample(seed)
            rep = folder / f"c{seed}.rep"
            rep.write_text(text)
            meas = tk.read_measurements(rep, ownship="OWNSHIP", contact="CONTACT",
                                        bearing_sigma=0.5)
            result = tk.estimate(meas, tk.motion_from_name("cv2d"))
            vx, vy = result.estimate[2], result.estimate[3]
            course = np.rad2deg(np.arctan2(vx, vy)) % 360.0
            dc.append(abs((course - truth["course"] + 180.0) % 360.0 - 180.0))
            ds.append(abs(np.hypot(vx, vy) / KNOT - truth["speed"]))
            status.append(result.status == "converged")
    dc, ds = np.array(dc), np.array(ds)
    both = (dc < 1.0) & (ds < 0.2)
    print(f"{args.runs} seeded replay files (seeds {args.seed}..{args.seed + args.runs - 1}): "
          f"{np.mean(status):.0%} converged")
    print(f"  |course error| deg: median {np.median(dc):.3f}, 95th pct {np.percentile(dc, 95):.3f}"
          f", max {dc.max():.3f}; within 1 deg: {np.mean(dc < 1.0):.0%}")
    print(f"  |speed error| kn:   median {np.median(ds):.3f}, 95th pct {np.percentile(ds, 95):.3f}"
          f", max {ds.max():.3f}; within 0.2 kn: {np.mean(ds < 0.2):.0%}")
    print(f"  both within (1 deg, 0.2 kn): {np.mean(both):.0%} of the files")


if __name__ == "__main__":
    main()
