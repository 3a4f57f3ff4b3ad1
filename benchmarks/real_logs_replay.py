"""Issue 12 figure: a Debrief replay file in one command recovers the contact's course and speed.

Each seeded replay file (``sample_logs.replay_sample``: own ship zig-zagging at 8 m/s,
a constant-velocity contact at 8-14 kn 6-9 km away, 720 bearings with 0.5 deg noise over one
hour, ``NULL`` sensor positions taken from the own ship's track) is read by the Debrief
reader and fitted by maximum likelihood (cv2d), exactly as

    tma estimate contact.rep --ownship OWNSHIP --contact CONTACT --motion cv2d \
        --bearing-sigma 0.5 --units nautical

does.  Course (degrees true) and speed (knots) are the answers that command prints, from
``EstimateResult.answer()`` (the shared computation of ``tmakit.results.answers``), at the last
measurement; compared with the contact's true course and speed (constant over the hour).
Target: within 1 deg and 0.2 kn.  The one command is checked to print range, bearing, course
and speed, each with its std, in nautical units.

    python benchmarks/real_logs_replay.py --runs 100 --seed 0
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from sample_logs import replay_sample
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

COMMAND = ["--ownship", "OWNSHIP", "--contact", "CONTACT", "--motion", "cv2d",
           "--bearing-sigma", "0.5", "--units", "nautical"]
#: The rows the one command must print with a value, a std and the unit (nautical units).
ROWS = {"course (true)": "deg", "speed": "kn", "range from OWNSHIP": "nmi",
        "bearing from OWNSHIP (true)": "deg"}


def one_command(folder: Path) -> None:
    text, truth = replay_sample(0)
    rep = folder / "contact.rep"
    rep.write_text(text)
    print(f"$ tma estimate contact.rep {' '.join(COMMAND)}   (seed 0; truth: course "
          f"{truth['course']:.2f} deg, speed {truth['speed']:.3f} kn)")
    result = CliRunner().invoke(app, ["estimate", str(rep), *COMMAND])
    print(result.output)
    cells = {}
    for line in result.output.splitlines():
        parts = [p.strip() for p in line.strip("│ ").split("│")]
        if len(parts) == 4 and parts[0] in ROWS:
            cells[parts[0]] = parts[1:]
    for name, unit in ROWS.items():
        value, std, shown_unit = cells.get(name, ("", "", ""))
        ok = bool(value) and bool(std) and shown_unit == unit
        print(f"  printed {name}: {value} +- {std} {shown_unit} "
              f"({'ok' if ok else 'MISSING: expected value, std and ' + unit})")


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
            answer = result.answer(meas)  # what tma estimate prints
            dc.append(abs((answer.course_deg - truth["course"] + 180.0) % 360.0 - 180.0))
            ds.append(abs(answer.speed_knots - truth["speed"]))
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
