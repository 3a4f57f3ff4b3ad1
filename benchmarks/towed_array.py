"""Issue 29 figure: a towed array's port/starboard ambiguity resolved leg by leg.

1. **Simulated towed-array data with an own-ship zig** (``--runs``, default 200, seeded).  The
   own ship (6 m/s, fixes every 10 s, its course over the ground with 0.5° of navigation
   noise) runs a leg of 20 min, turns by 40° to 100° (either way, at 0.5°/s) and runs a second
   leg of 20 min.  The contact (constant velocity, 2 to 7 m/s, any course) starts 6 to 15 km
   away at any bearing, so on either side of the array.  Every 20 s the array measures the cone
   angle between its axis and the contact (1° noise); its axis lags the ship's heading (first
   order, 40 s), and the cut is reported, as a towed array's processor does, as the two
   bearings mirrored about the ship's heading, in a random order.  Each run is resolved twice
   with :func:`tmakit.resolve_ambiguity` (cv2d, default thresholds, turn cuts left out):

   - on the cuts of the first leg alone (before the turn): the side must be reported
     unresolved, never resolved;
   - on every cut: the side chosen for each of the two legs must be the contact's true side
     (a leg counts as correct when every part of it is: where the contact passes near the
     array's axis it may cross to the other side, and the leg's cuts after it are a part that
     takes its own side).

2. **Debrief's public ambiguous samples** (``tests/data/debrief``): the S2R hover-north replay
   (sensor ``TA``) and the AssetData pair ``Ambig_cuts_TA.rep`` + ``Ambig_tracks2.rep``.  The
   side chosen for each own-ship leg is compared with the side of the subject's truth track
   (its bearing from the own ship at each cut, against the array's axis).

    python benchmarks/towed_array.py [--runs 200]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.batch.ambiguity import PORT, STARBOARD
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.io.debrief import replay_tracks

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "debrief"
SPEED = 6.0            # own ship, m/s
LEG_S = 1200.0         # each leg, s
TURN_RATE = np.deg2rad(0.5)
NAV_NOISE = np.deg2rad(0.5)
CUT_S, FIX_S = 20.0, 10.0
SIGMA = np.deg2rad(1.0)
ARRAY_LAG_S = 40.0


def own_path(turn: float, course0: float, dt: float = 1.0
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The own ship's heading, position and time at 1 s steps; the turn's end time."""
    turn_s = abs(turn) / TURN_RATE
    total = 2 * LEG_S + turn_s
    t = np.arange(0.0, total + dt, dt)
    heading = course0 + np.clip((t - LEG_S) / turn_s, 0.0, 1.0) * turn
    v = SPEED * np.column_stack([np.sin(heading), np.cos(heading)])
    pos = np.vstack([[0.0, 0.0], np.cumsum(v[:-1] * dt, axis=0)])
    return t, heading, pos, LEG_S + turn_s


def array_axis(t: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """The array's axis: the ship's heading through a first-order lag (1 s steps)."""
    axis = np.empty_like(heading)
    axis[0] = heading[0]
    a = 1.0 / ARRAY_LAG_S
    for k in range(1, t.size):
        axis[k] = axis[k - 1] + a * (heading[k - 1] - axis[k - 1])
    return axis


def simulate(rng: np.random.Generator) -> tuple[tk.MeasurementSet, np.ndarray, float]:
    """One run: the set (twins in random order), each cut's true side, the turn's end."""
    turn = rng.choice([-1.0, 1.0]) * np.deg2rad(rng.uniform(40.0, 100.0))
    t, heading, pos, turn_end = own_path(turn, rng.uniform(0.0, 2 * np.pi))
    axis = array_axis(t, heading)
    r0, b0 = rng.uniform(6000.0, 15000.0), rng.uniform(0.0, 2 * np.pi)
    speed, course = rng.uniform(2.0, 7.0), rng.uniform(0.0, 2 * np.pi)
    cut_t = np.arange(0.0, t[-1], CUT_S)
    k = np.searchsorted(t, cut_t)
    target = r0 * np.array([np.sin(b0), np.cos(b0)]) + np.outer(
        cut_t, speed * np.array([np.sin(course), np.cos(course)]))
    d = target - pos[k]
    true_bearing = np.arctan2(d[:, 0], d[:, 1])
    cone = np.arccos(np.cos(true_bearing - axis[k])) + SIGMA * rng.standard_normal(k.size)
    side = np.sign(np.sin(true_bearing - axis[k]))
    pair = np.column_stack([heading[k] + cone, heading[k] - cone])
    swap = rng.random(k.size) < 0.5
    first = np.where(swap, pair[:, 1], pair[:, 0])
    twin = np.where(swap, pair[:, 0], pair[:, 1])
    nav = heading[k] + NAV_NOISE * rng.standard_normal(k.size)
    state = np.column_stack([pos[k], np.zeros(k.size), SPEED * np.sin(nav),
                             SPEED * np.cos(nav), np.zeros(k.size)])
    meas = tk.MeasurementSet.from_si(cut_t, np.full(k.size, "OWN"), np.full(k.size, "bearing"),
                                     np.mod(first, 2 * np.pi), np.full(k.size, SIGMA), state)
    return meas.with_ambiguous(np.mod(twin, 2 * np.pi)), side, turn_end


def true_side(meas: tk.MeasurementSet, side: np.ndarray, start: float, stop: float) -> str:
    """The contact's side on a leg: that of most of its cuts."""
    rows = (meas.time >= start) & (meas.time <= stop)
    return STARBOARD if np.sum(side[rows]) > 0 else PORT


def simulated(runs: int, seed: int) -> None:
    """Resolve every run before and after the turn; print the counts."""
    before_resolved = legs = legs_right = parts = parts_right = resolved = resolved_wrong = 0
    for run in range(runs):
        rng = np.random.default_rng([seed, run])
        meas, side, _ = simulate(rng)
        early = tk.resolve_ambiguity(meas.take(meas.time <= LEG_S), "cv2d")
        before_resolved += any(s.resolved for s in early.sides)
        full = tk.resolve_ambiguity(meas, "cv2d")
        right: dict[int, bool] = {}
        for s in full.sides:
            ok = s.side == true_side(meas, side, s.start, s.stop)
            right[s.leg] = right.get(s.leg, True) and ok
            parts, parts_right = parts + 1, parts_right + ok
            resolved += s.resolved
            resolved_wrong += s.resolved and not ok
        legs, legs_right = legs + len(right), legs_right + sum(right.values())
    print(f"1. simulated towed array with an own-ship zig: {runs} runs (seed {seed})")
    print(f"   before the turn (first leg only): reported resolved in {before_resolved} of "
          f"{runs} runs (must be 0)")
    print(f"   after the turn: own-ship legs with the correct side on every part: {legs_right} of "
          f"{legs} ({100.0 * legs_right / max(legs, 1):.1f} %); parts (a new part where the "
          f"contact passes near the axis): {parts_right} of {parts} correct; resolved "
          f"{resolved} parts, of which on the wrong side {resolved_wrong}")


def sample_sides(name: str, files: list[Path], contact: str | None, truth_file: Path,
                 window: tuple[str | None, str | None] = (None, None)) -> tuple[int, int]:
    """Resolve one Debrief sample; compare each leg's side with the truth track's."""
    meas = tk.read_measurements(files if len(files) > 1 else files[0], contact=contact,
                                window=window)
    amb = tk.resolve_ambiguity(meas, "cv2d")
    truth = replay_tracks(truth_file)["SUBJECT"]
    t0 = np.datetime64(meas.metadata["time_origin"].rstrip("Z"), "ns").astype(np.int64)
    origin = [float(meas.metadata[f"origin_{k}"]) for k in ("lat", "lon", "alt")]
    right = 0
    for s in amb.sides:
        rows = (meas.time >= s.start) & (meas.time <= s.stop) & ~np.isnan(meas.ambiguous_si)
        t_ns = t0 + np.round(meas.time[rows] * 1e9).astype(np.int64)
        lat, lon = (np.interp(t_ns, truth["time_ns"], truth[k]) for k in ("lat", "lon"))
        e, n, _ = geodetic_to_enu(lat, lon, np.zeros(lat.shape), origin)
        st = meas.sensor_state[rows]
        bearing = np.arctan2(e - st[:, 0], n - st[:, 1])
        heading = np.arctan2(st[:, 3], st[:, 4])
        truth_side = STARBOARD if np.sum(np.sign(np.sin(bearing - heading))) > 0 else PORT
        right += s.side == truth_side
        print(f"   {name} leg {s.leg + 1} ({s.cuts} cuts, own course {s.course_deg:.1f}): "
              f"chosen {s.side} ({'resolved' if s.resolved else 'unresolved'}, "
              f"Δχ² {s.delta_chi2:.3g}), truth {truth_side}")
    return right, len(amb.sides)


def debrief_samples() -> None:
    print("2. Debrief's public ambiguous samples (side chosen against the subject's truth)")
    hover = DATA / "s2r_hover_north" / "Ambig_tracks_hover_north.rep"
    pair = [DATA / "asset_ambig" / "Ambig_cuts_TA.rep", DATA / "asset_ambig" / "Ambig_tracks2.rep"]
    right = total = 0
    for name, files, contact, truth, window in (
            ("S2R hover north TA", [hover], "TA", hover, (None, None)),
            ("AssetData Ambig TA", pair, None, pair[1], (None, None))):
        r, n = sample_sides(name, files, contact, truth, window)
        right, total = right + r, total + n
    print(f"   legs whose side matches the truth: {right} of {total}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=29)
    args = parser.parse_args()
    simulated(args.runs, args.seed)
    debrief_samples()


if __name__ == "__main__":
    main()
