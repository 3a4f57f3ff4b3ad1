"""Issue 29 figure: own-ship legs and turns found from the navigation (the heading rate).

:func:`tmakit.own_ship_legs` with its default thresholds (a turn: heading rate above 0.1°/s
over a 60 s line fit, changing the heading by 10° or more) on:

1. **Debrief's own-ship tracks** (``tests/data/debrief``, ASSET output: each fix states the
   simulator's course): a true turn starts at the last fix before the course field changes
   (a turn from the first fix has no leg before it and is not counted).
   Each true turn must be found with its start within one fix of it, and no other turn found.
2. **legs_20-style data** (Debrief's ``S2R/legs_20.rep``: an ASSET search with 20 legs, a fix
   every 5 min, each turn over within one fix): ``--runs`` seeded tracks of 20 legs of 30 to
   60 min, turns of 30° to 180° either way at 1°/s.
3. **Simulated zig-zags with navigation noise**: seeded tracks of 6 legs of 10 to 20 min,
   turns of 20° to 90° at 0.3 to 1°/s, a fix every 5 s with 1° of noise on the course over
   the ground and 0.1 m/s on the speed: every turn found, its start within one fix.
4. **Straight legs with navigation noise**: seeded 2 h straight runs (fixes every 5 s, the same
   noise): no turn may be found.

    python benchmarks/own_legs.py [--runs 200]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.io.debrief import replay_tracks
from tmakit.io.logs import KNOT, course_speed_velocity

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "debrief"
TRACKS = [("satc/BlueTrack.rep", "SENSOR"), ("ta_dummy/Freq_BlueTrack.rep", "SENSOR"),
          ("s2r_2553/BlueTrack.rep", "SENSOR"),
          ("s2r_hover_north/Ambig_tracks_hover_north.rep", "SENSOR"),
          ("asset_ambig/Ambig_tracks2.rep", "SENSOR")]


def match(found: list[float], truth: list[float], step: float) -> tuple[int, int]:
    """Count true turns found within ``step`` of their start, and false turns: turns found
    with no true turn within ``step`` (a found turn further from its true turn is both)."""
    hit = sum(any(abs(f - t) <= step + 1e-6 for f in found) for t in truth)
    false = sum(not any(abs(f - t) <= step + 1e-6 for t in truth) for f in found)
    return hit, false


def debrief_tracks() -> None:
    print("1. Debrief's own-ship tracks (true turns: the fixes' course field)")
    for rel, name in TRACKS:
        track = replay_tracks(DATA / rel)[name]
        t = (track["time_ns"] - track["time_ns"][0]) / 1e9
        keep = np.concatenate([[True], np.diff(t) > 0])  # a first fix written twice
        t = t[keep]
        e, n, _ = geodetic_to_enu(track["lat"][keep], track["lon"][keep], np.zeros(t.size),
                                  [track["lat"][0], track["lon"][0], 0.0])
        v = course_speed_velocity(track["course"][keep], track["speed"][keep] * KNOT)
        state = np.column_stack([e, n, np.zeros(t.size), v])
        legs = tk.own_ship_legs(tk.MeasurementSet.from_si(
            t, np.full(t.size, name), np.full(t.size, "bearing"), np.zeros(t.size),
            np.full(t.size, 0.01), state))
        course = track["course"][keep]
        change = np.abs((np.diff(course) + 180.0) % 360.0 - 180.0) > 0.5
        starts = [float(t[k]) for k in np.flatnonzero(change)  # turns between two legs: not
                  if k > 0 and not change[k - 1]]                 # one from the first fix
        step = float(np.median(np.diff(t)))
        big = [s for s in starts if _total_turn(t, course, s) >= 10.0]
        hit, false = match([u.start for u in legs.turns], big, step)
        print(f"   {rel}: {len(big)} true turns of 10 deg or more, {hit} found within one fix "
              f"({step:g} s), {false} other turns found")


def _total_turn(t: np.ndarray, course: np.ndarray, start: float) -> float:
    """The course change (deg) of the turn that starts at ``start``, to where it settles."""
    k = int(np.searchsorted(t, start))
    j = k + 1
    while j + 1 < course.size and abs((course[j + 1] - course[j] + 180.0) % 360.0 - 180.0) > 0.5:
        j += 1
    return float(abs((course[min(j, course.size - 1)] - course[k] + 180.0) % 360.0 - 180.0))


def simulate(rng: np.random.Generator, legs: int, leg_s: tuple[float, float],
             turn_deg: tuple[float, float], rate_deg_s: tuple[float, float], fix_s: float,
             noise_deg: float, speed_noise: float) -> tuple[tk.MeasurementSet, list[float]]:
    """An own ship's fixes on a zig-zag, and the true turns' starts (s)."""
    dt = 1.0
    heading, t_now, starts = [rng.uniform(0, 2 * np.pi)], 0.0, []
    times = [0.0]
    for k in range(legs):
        for _ in range(int(rng.uniform(*leg_s) / dt)):
            t_now += dt
            times.append(t_now)
            heading.append(heading[-1])
        if k == legs - 1:
            break
        starts.append(t_now)
        turn = np.deg2rad(rng.uniform(*turn_deg)) * rng.choice([-1.0, 1.0])
        rate = np.deg2rad(rng.uniform(*rate_deg_s))
        steps = max(int(np.ceil(abs(turn) / rate / dt)), 1)
        for _ in range(steps):
            t_now += dt
            times.append(t_now)
            heading.append(heading[-1] + turn / steps)
    t, h = np.array(times), np.array(heading)
    v = 6.0 * np.column_stack([np.sin(h), np.cos(h)])
    pos = np.vstack([[0.0, 0.0], np.cumsum(v[:-1] * dt, axis=0)])
    fix = np.arange(0, t.size, int(fix_s / dt))
    nav = h[fix] + np.deg2rad(noise_deg) * rng.standard_normal(fix.size)
    speed = 6.0 + speed_noise * rng.standard_normal(fix.size)
    state = np.column_stack([pos[fix], np.zeros(fix.size), speed * np.sin(nav),
                             speed * np.cos(nav), np.zeros(fix.size)])
    meas = tk.MeasurementSet.from_si(t[fix], np.full(fix.size, "OWN"),
                                     np.full(fix.size, "bearing"), np.zeros(fix.size),
                                     np.full(fix.size, 0.01), state)
    return meas, starts


def simulated(title: str, runs: int, seed: int, **kw: object) -> None:
    hit = total = false = 0
    for run in range(runs):
        meas, starts = simulate(np.random.default_rng([seed, run]), **kw)  # type: ignore[arg-type]
        legs = tk.own_ship_legs(meas)
        h, f = match([u.start for u in legs.turns], starts, float(kw["fix_s"]))  # type: ignore[arg-type]
        hit, total, false = hit + h, total + len(starts), false + f
    print(f"{title}: {runs} runs (seed {seed}): {hit} of {total} true turns found with their "
          f"start within one fix; {false} false turns")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=29)
    args = parser.parse_args()
    debrief_tracks()
    simulated("2. legs_20-style (20 legs, a fix every 5 min, turns at 1 deg/s)", args.runs,
              args.seed, legs=20, leg_s=(1800.0, 3600.0), turn_deg=(30.0, 180.0),
              rate_deg_s=(1.0, 1.0), fix_s=300.0, noise_deg=0.0, speed_noise=0.0)
    simulated("3. zig-zags with navigation noise (6 legs, fixes every 5 s, 1 deg)", args.runs,
              args.seed, legs=6, leg_s=(600.0, 1200.0), turn_deg=(20.0, 90.0),
              rate_deg_s=(0.3, 1.0), fix_s=5.0, noise_deg=1.0, speed_noise=0.1)
    simulated("4. straight legs with navigation noise (2 h, fixes every 5 s, 1 deg)", args.runs,
              args.seed, legs=1, leg_s=(7200.0, 7200.0), turn_deg=(0.0, 0.0),
              rate_deg_s=(1.0, 1.0), fix_s=5.0, noise_deg=1.0, speed_noise=0.1)


if __name__ == "__main__":
    main()
