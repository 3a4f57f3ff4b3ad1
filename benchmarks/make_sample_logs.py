"""Write the sample logs shipped with tmakit (``src/tmakit/examples``) from its own simulation.

``tma examples DIR`` copies them out; ``docs/your-own-data.md`` walks through them.  The
files are made by ``sample_logs.py`` (seed 0 unless ``--seed``; the drone log seed 6
unless ``--drone-seed``):

- ``contact.rep``: a Debrief replay file (own ship ``OWNSHIP``, bearings of ``CONTACT`` and
  its true track);
- ``drone.csv`` + ``drone.toml``: a drone receiver log (ISO UTC, lat/lon/alt, NED velocity,
  RSSI dBm, frequency Hz) and its column mapping.  The drone flies 90 m above a transmitter
  on the ground; seed 6 is a flight that passes 113 m from it, where a fit that puts the
  transmitter in the drone's plane is 14 m off with an ellipse of 4 m (the case that
  ``tmakit.batch.height`` exists for; seeds 2-11 are alike, 0 and 1 pass farther);
- ``own.gpx``, ``own.nmea``, ``bearings.csv`` + ``bearings.toml``: a boat's own track as GPX
  and NMEA 0183 and its bearings to a fixed beacon.

    python benchmarks/make_sample_logs.py [--out src/tmakit/examples] [--seed 0] [--drone-seed 6]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from sample_logs import drone_sample, gpx_nmea_sample, replay_sample

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "src" / "tmakit" / "examples")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--drone-seed", type=int, default=6)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rep, rep_truth = replay_sample(args.seed)
    drone, drone_map, drone_truth = drone_sample(args.drone_seed)
    gpx, nmea, bearings, bearings_map, beacon = gpx_nmea_sample(args.seed)
    files = {"contact.rep": rep, "drone.csv": drone, "drone.toml": drone_map, "own.gpx": gpx,
             "own.nmea": nmea, "bearings.csv": bearings, "bearings.toml": bearings_map,
             "truth.json": json.dumps({"contact.rep": rep_truth, "drone.csv": drone_truth,
                                       "bearings.csv": beacon}, indent=2) + "\n"}
    for name, text in files.items():
        (args.out / name).write_text(text, encoding="utf-8", newline="\n")
        print(f"wrote {args.out / name}")


if __name__ == "__main__":
    main()
