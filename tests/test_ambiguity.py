"""A towed array's port/starboard ambiguity (tmakit.batch.ambiguity) and own-ship legs.

The figures are ``benchmarks/towed_array.py`` and ``benchmarks/own_legs.py``; these tests pin
what a user relies on: never resolved before a turn (both solutions shown), the true side after
it, turn cuts named and left out (kept on request), the decisions in the command's output and
JSON, and the legs found within one fix with no false turn on a noisy straight run.
"""

from __future__ import annotations

import functools
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.motion import PiecewiseCurvilinear
from tmakit.results.own_legs import contact_legs

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import own_legs as legs_bench  # the benchmarks' own simulations
import towed_array as bench

DATA = Path(__file__).parent / "data" / "debrief" / "asset_ambig"
PAIR = [str(DATA / "Ambig_cuts_TA.rep"), str(DATA / "Ambig_tracks2.rep")]


@functools.cache
def run(seed: int):
    """Seeded run ``seed`` of the benchmark: the set, each cut's true side, the turn's end."""
    return bench.simulate(np.random.default_rng([7, seed]))


@functools.cache
def resolved(seed: int):
    """``tk.resolve_ambiguity`` of run ``seed``, all cuts, cv2d: fitted once a worker (two
    tests read runs 0 and 1; the results are read, never changed)."""
    return tk.resolve_ambiguity(run(seed)[0], "cv2d")


@pytest.mark.parametrize("seed", range(4))
def test_unresolved_before_the_turn_and_the_true_side_after_it(seed):
    meas, side, _ = run(seed)
    early = tk.resolve_ambiguity(meas.take(meas.time <= bench.LEG_S), "cv2d")
    assert early.sides and not any(s.resolved for s in early.sides)
    assert "no own-ship turn within these cuts" in early.sides[0].reason
    assert early.alternatives  # the mirror solution is reported beside the chosen one
    full = resolved(seed)
    assert len(full.legs.legs) == 2
    for s in full.sides:
        assert s.side == bench.true_side(meas, side, s.start, s.stop)
        assert not s.resolved or s.likelihood_ratio >= 100.0


@pytest.mark.long
def test_turn_cuts_are_named_and_left_out_unless_kept():
    meas, _, turn_end = run(0)
    amb = resolved(0)
    flagged = np.array([c.time for c in amb.turn_cuts])
    assert flagged.size and np.all((flagged > bench.LEG_S - 60) & (flagged <= turn_end + 200))
    assert not np.any(np.isin(amb.measurements.time, flagged))
    assert all(c.reason.startswith(("in a turn", "within 180 s after")) for c in amb.turn_cuts)
    kept = tk.resolve_ambiguity(meas, "cv2d", keep_turn_cuts=True)
    assert all(c.kept for c in kept.turn_cuts) and len(kept.measurements) == len(meas)


def test_the_chosen_side_swaps_the_bearing_and_its_twin():
    meas, _, _ = run(1)
    amb = resolved(1)
    both = np.sort(np.column_stack([meas.value_si, meas.ambiguous_si]), axis=1)
    rows = np.isin(meas.time, amb.measurements.time)
    again = np.sort(np.column_stack([amb.measurements.value_si,
                                     amb.measurements.ambiguous_si]), axis=1)
    assert np.allclose(both[rows], again)


def test_bad_ambiguous_bearings_are_refused_naming_what_is_wrong():
    meas, _, _ = bench.simulate(np.random.default_rng([7, 2]))
    with pytest.raises(ValueError, match="no cut carries a second, ambiguous bearing"):
        tk.resolve_ambiguity(meas.with_ambiguous(None), "cv2d")
    with pytest.raises(ValueError, match="3 values for"):
        meas.with_ambiguous([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="settle_s"):
        tk.resolve_ambiguity(meas, "cv2d", settle_s=-1.0)


def test_debrief_s_ambiguous_pair_is_resolved_on_the_truth_s_side_from_the_command():
    result = CliRunner().invoke(app, ["estimate", *PAIR, "--motion", "cv2d", "--from", "13:58",
                                      "--units", "nautical"])
    assert result.exit_code == 0, result.output
    sides = [line for line in result.output.splitlines() if line.startswith("  leg ")
             and "cuts):" in line]
    assert len(sides) == 6 and all(line.endswith("resolved") for line in sides)
    chosen = [line.split("cuts): ")[1].split(",")[0] for line in sides]
    assert chosen == ["starboard"] * 3 + ["port"] * 3  # the sides of the truth track
    assert result.output.count("turn cut at") == 13
    rows = {p[0]: p[1] for p in ([c.strip() for c in line.strip("│ ").split("│")]
                                 for line in result.output.splitlines()) if len(p) == 4}
    assert abs(float(rows["course (true)"]) - 160.76) < 1.0  # the subject's truth
    assert abs(float(rows["speed"]) - 6.0) < 0.2
    assert "own-ship legs of SENSOR (a turn: heading rate above 0.1 deg/s" in result.output


def test_the_json_carries_legs_sides_turn_cuts_and_the_other_solutions():
    result = CliRunner().invoke(app, ["estimate", *PAIR, "--motion", "cv2d", "--leg", "2",
                                      "--json"])
    assert result.exit_code == 4  # one straight leg: range unobservable, no answer
    data = json.loads(result.stdout)
    (side,) = data["ambiguity"]["sides"]
    assert side["status"] == "unresolved" and side["leg"] == 2
    assert len(data["ambiguity"]["other_solutions"]) == 1
    assert len(data["legs"]["legs"]) == 6 and data["legs"]["turn_rate_deg_s"] == 0.1
    assert "unresolved (no own-ship turn within these cuts" in result.stderr


def test_leg_options_are_checked():
    runner = CliRunner()
    bad = runner.invoke(app, ["estimate", *PAIR, "--motion", "cv2d", "--leg", "9"])
    assert bad.exit_code == 2 and "--leg 9: the own ship has 6 leg(s)" in bad.output
    both = runner.invoke(app, ["estimate", *PAIR, "--motion", "cv2d", "--leg", "1", "--from",
                               "14:00"])
    assert both.exit_code == 2 and "--leg N sets the window" in both.output


def test_snap_moves_the_window_to_the_legs_ends():
    result = CliRunner().invoke(app, ["estimate", *PAIR, "--motion", "cv2d", "--from", "14:09",
                                      "--to", "14:40", "--snap", "--json"])
    sides = json.loads(result.stdout)["ambiguity"]["sides"]
    assert [s["leg"] for s in sides] == [2, 3, 4]
    assert sides[-1]["stop"] == 9840.0  # 14:44, the end of leg 4


@pytest.mark.parametrize("seed", range(3))
def test_turns_are_found_within_one_fix_on_noisy_zig_zags(seed):
    meas, starts = legs_bench.simulate(
        np.random.default_rng([11, seed]), legs=6, leg_s=(600.0, 1200.0),
        turn_deg=(20.0, 90.0), rate_deg_s=(0.3, 1.0), fix_s=5.0, noise_deg=1.0,
        speed_noise=0.1)
    found = [u.start for u in tk.own_ship_legs(meas).turns]
    assert legs_bench.match(found, starts, 5.0) == (len(starts), 0)


def test_no_turn_on_a_noisy_straight_run():
    for seed in range(3):
        meas, _ = legs_bench.simulate(
            np.random.default_rng([12, seed]), legs=1, leg_s=(7200.0, 7200.0),
            turn_deg=(0.0, 0.0), rate_deg_s=(1.0, 1.0), fix_s=5.0, noise_deg=1.0,
            speed_noise=0.1)
        legs = tk.own_ship_legs(meas)
        assert len(legs.legs) == 1 and not legs.turns


def test_a_manoeuvre_fit_s_segments_are_the_contact_s_legs():
    class Fit:  # what contact_legs reads of a result
        motion = PiecewiseCurvilinear(1)
        estimate = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 100.0])

    meas, _, _ = bench.simulate(np.random.default_rng([7, 3]))
    legs = contact_legs(Fit(), meas.take(meas.time <= 300.0))
    assert [(leg["start"], leg["stop"]) for leg in legs] == [(0.0, 100.0), (100.0, 300.0)]
    assert all(abs(leg["speed"] - 5.0) < 1e-9 and abs(leg["turn_deg"]) < 1e-9 for leg in legs)


def test_a_wide_log_s_second_bearing_column_is_the_twin(tmp_path):
    (tmp_path / "log.csv").write_text(
        "utc,lat,lon,brg,brg2\n2024-01-01T00:00:00Z,50.0,-4.0,30.0,150.0\n"
        "2024-01-01T00:00:10Z,50.0001,-4.0,31.0,149.0\n2024-01-01T00:00:20Z,50.0002,-4.0,32.0,\n")
    (tmp_path / "m.toml").write_text(
        'time = "utc"\nsensor = "own"\n[position]\nlat = "lat"\nlon = "lon"\n'
        '[[measurement]]\ncolumn = "brg"\nkind = "bearing"\nunit = "deg"\nsigma = 1.0\n'
        'ambiguous = "brg2"\n')
    with pytest.raises(tk.MeasurementFileError, match=r"row 3.*brg2.*has no ambiguous twin"):
        tk.read_measurements(tmp_path / "log.csv", format="wide", mapping=tmp_path / "m.toml")
    (tmp_path / "log.csv").write_text(
        (tmp_path / "log.csv").read_text().replace("32.0,\n", ",\n"))
    meas = tk.read_measurements(tmp_path / "log.csv", format="wide", mapping=tmp_path / "m.toml")
    assert np.allclose(np.degrees(meas.ambiguous_si), [150.0, 149.0])


def test_track_takes_the_sides_the_batch_fit_resolves_and_crlb_says_what_it_assumes():
    """tma track reads both bearings: each leg's side as tma estimate chooses it (the truth's),
    the decisions printed; tma crlb says it takes the side as known."""
    result = CliRunner().invoke(app, ["track", *PAIR, "--json"])
    assert result.exit_code == 0, result.output
    sides = [line for line in result.output.splitlines() if line.startswith("  leg ")
             and "cuts):" in line]
    assert [line.split("cuts): ")[1].split(",")[0] for line in sides] == (
        ["starboard"] * 3 + ["port"] * 3)
    assert all(line.endswith("resolved") for line in sides)
    assert result.output.count("turn cut at") == 15  # from 13:40: two more than from 13:58
    bound = CliRunner().invoke(app, ["crlb", *PAIR, "--motion", "cv2d", "--truth",
                                     "x=-20000,y=-20000,vx=1,vy=-3"])
    assert bound.exit_code == 0, bound.output
    assert "the bound takes the side of the 50 towed-array cuts as known" in bound.output
