"""Debrief replay files as analysts have them (issue 26): carries, problems outside the data
used, several files as one replay, fixes written twice, cuts outside the track, placeholder
ranges, stray spaces, ``--kinds``, clock times of the day and the notes that say all this."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.io import MeasurementFileError
from tmakit.io.errors import reader_notes
from tmakit.io.logs import seconds_of_time_text

OWN = ("260504 093000 OWN @A 47 57 00.00 N 005 15 00.00 W 90.0 10.0 0.0\n"
       "260504 093100 OWN @A 47 57 00.00 N 005 14 12.00 W 90.0 10.0 0.0\n"
       "260504 093200 OWN @A 47 57 00.00 N 005 13 24.00 W 90.0 10.0 0.0\n")
CUTS = "".join(f";SENSOR: 260504 0930{s:02d} OWN @A NULL {40 + s / 10:.1f} NULL TA T1\n"
               for s in range(10, 60, 10))
runner = CliRunner()


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def notes(meas):
    return "\n".join(reader_notes(meas.metadata))


def test_a_position_written_with_60_seconds_is_a_carry_with_a_note(tmp_path):
    carried = OWN.replace("005 14 12.00 W", "005 14 60.00 W")
    meas = tk.read_measurements(write(tmp_path, "c.rep", carried + CUTS))
    same = tk.read_measurements(write(tmp_path, "s.rep", OWN.replace(
        "005 14 12.00 W", "005 15 00.00 W") + CUTS))
    assert np.allclose(meas.sensor_state, same.sensor_state)
    assert "line 2 005 14 60.00 W" in notes(meas) and "carry" in notes(meas)
    with pytest.raises(MeasurementFileError, match="line 2: expected minutes and seconds"):
        tk.read_measurements(write(tmp_path, "b.rep", OWN.replace("12.00 W", "60.01 W") + CUTS))


def test_a_broken_line_of_a_track_not_used_warns_and_one_of_the_own_ship_refuses(tmp_path):
    other = "260504 093000 FISHER @C 47 59 00.00 N 005 10 00.00 W 9x.0 5.0 0.0\n"
    meas = tk.read_measurements(write(tmp_path, "o.rep", OWN + other + CUTS))
    assert len(meas) == 5
    assert "warning: 1 line(s) of tracks not used" in notes(meas) and "'FISHER'" in notes(meas)
    own = OWN + "260504 093300 OWN @A 47 57 00.00 N 005 12 36.00 W 9x.0 10.0 0.0\n"
    with pytest.raises(MeasurementFileError, match="line 4: expected a course"):
        tk.read_measurements(write(tmp_path, "w.rep", own + CUTS))


def test_several_files_are_one_replay_in_any_order(tmp_path):
    track, cuts = write(tmp_path, "own.rep", OWN), write(tmp_path, "s.dsf", CUTS)
    one = tk.read_measurements([track, cuts])
    other = tk.read_measurements([cuts, track])
    assert len(one) == 5 and np.array_equal(one.time, other.time)
    assert np.array_equal(one.value, other.value)
    assert np.array_equal(one.sensor_state, other.sensor_state)
    with pytest.raises(MeasurementFileError, match=r"sensor positions NULL \(line 1, line 2, "
                       r".*give the own ship's track file in the same command"):
        tk.read_measurements(cuts)
    with pytest.raises(MeasurementFileError, match="only for Debrief replays"):
        tk.read_measurements([track, write(tmp_path, "x.csv", "t\n")])


def test_the_same_fix_twice_is_one_fix_and_two_different_fixes_are_refused(tmp_path):
    first = OWN.splitlines(keepends=True)[0]
    track, cuts = write(tmp_path, "own.rep", OWN), write(tmp_path, "s.dsf", first + CUTS)
    meas = tk.read_measurements([track, cuts])
    assert len(meas) == 5 and "s.dsf line 1 repeats own.rep line 1" in notes(meas)
    moved = first.replace("47 57 00.00 N", "47 57 30.00 N")
    with pytest.raises(MeasurementFileError, match=r"d.dsf line 1: own ship 'OWN' has two "
                       r"different fixes at 2026-05-04T09:30:00Z: own.rep line 1 \(47.950000"):
        tk.read_measurements([track, write(tmp_path, "d.dsf", moved + CUTS)])


def test_a_track_file_alone_is_refused_naming_its_tracks_and_how_to_pair_it(tmp_path):
    with pytest.raises(MeasurementFileError, match=r"nothing measured; the tracks read \(OWN\) "
                       r"are positions: give an own ship's track with its sensor file"):
        tk.read_measurements(write(tmp_path, "own.rep", OWN))
    with pytest.raises(MeasurementFileError, match=r"nothing measured$"):
        tk.read_measurements(write(tmp_path, "empty.rep", ";; a comment\n"))


def test_one_sensor_s_cuts_in_two_files_merge_when_equal_and_are_two_runs_otherwise(
        tmp_path):
    """A sensor file given with a replay that holds the same sensor's cuts (Debrief's S2R
    hover-north sample): the same cut twice is one; other values at one time are another run
    of the sensor, as Debrief reads it (two sensors of one name): the sensor file's run is
    fitted, in any order of the files, and a note names the run left out and how to fit it."""
    track, cuts = write(tmp_path, "own.rep", OWN + CUTS), write(tmp_path, "s.dsf", CUTS)
    assert len(tk.read_measurements([track, cuts])) == 5
    other = write(tmp_path, "o.dsf", CUTS.replace(" 41.0 NULL", " 45.0 NULL"))
    for files in ([track, other], [other, track]):
        meas = tk.read_measurements(files)
        assert 45.0 in meas.value and 41.0 not in meas.value and len(meas) == 5
        assert ("own.rep holds another run of sensor 'TA' of 'OWN' than o.dsf (1 of its 5 cuts "
                "at the times of o.dsf's have other values): Debrief reads them as two sensors "
                "named 'TA'") in notes(meas)
        assert "the 5 cuts of own.rep are not used (give own.rep without o.dsf" in notes(meas)


def test_cuts_outside_the_track_are_left_out_with_a_warning_the_window_first(tmp_path):
    late = ";SENSOR: 260504 093500 OWN @A NULL 50.0 NULL TA T1\n"
    path = write(tmp_path, "l.rep", OWN + CUTS + late)
    meas = tk.read_measurements(path)
    assert len(meas) == 5 and "warning: 1 cut(s) with a NULL position fall outside" in notes(meas)
    assert "line 9" in notes(meas)
    windowed = tk.read_measurements(path, window=("09:30:00", "09:31:00"))
    assert len(windowed) == 5 and "outside" not in notes(windowed)
    with pytest.raises(MeasurementFileError, match="no cut is left"):
        tk.read_measurements(path, window=("09:34", None))


def test_placeholder_ranges_are_left_out_unless_asked(tmp_path):
    cuts = CUTS.replace(" NULL TA", " 12000 TA")
    path = write(tmp_path, "r.rep", OWN + cuts)
    meas = tk.read_measurements(path)
    assert set(meas.kinds) == {"bearing"} and "every cut states 12000 yd" in notes(meas)
    assert len(tk.read_measurements(path, ranges="use").select(kind="range")) == 5
    real = write(tmp_path, "q.rep", OWN + "".join(
        line.replace(" NULL TA", f" {2000 + 10 * k} TA")
        for k, line in enumerate(CUTS.splitlines(keepends=True))))
    assert len(tk.read_measurements(real).select(kind="range")) == 5
    ignored = tk.read_measurements(real, ranges="ignore")
    assert set(ignored.kinds) == {"bearing"} and "(--ranges ignore)" in notes(ignored)
    zero = write(tmp_path, "z.rep", OWN + CUTS.replace(" NULL TA", " 0000 TA"))
    assert "range(s) of 0 yd left out" in notes(tk.read_measurements(zero))


def test_names_with_stray_spaces_are_one_sensor_and_ambiguous_bearings_are_noted(tmp_path):
    cuts = "".join(f';SENSOR2: 260504 0930{s:02d} " OWN " @A NULL {40 + s / 10:.1f} 200.0 '
                   f'150.0 NULL "{pad}Optic5{pad[::-1]}" T1\n'
                   for s, pad in ((10, " "), (20, ""), (30, "  ")))
    meas = tk.read_measurements(write(tmp_path, "n.rep", OWN + cuts), contact=" Optic5")
    assert len(meas.select(kind="bearing")) == 3
    assert "3 cut(s) carry a second, ambiguous bearing" in notes(meas)
    assert meas.metadata["ambiguous_bearings"] == "3"
    assert np.allclose(np.degrees(meas.select(kind="bearing").ambiguous_si), 200.0)


def test_clock_times_of_the_day_are_read_on_one_day_and_refused_over_two():
    day = 1_478_304_000 * 10**9  # 2016-11-05T00:00:00Z
    origin = day + 15 * 3600 * 10**9
    span = (origin, origin + 6 * 3600 * 10**9)
    assert seconds_of_time_text("19:30", "--from", origin, span) == 4.5 * 3600
    assert seconds_of_time_text("15:00:30.5", "--to", origin, span) == 30.5
    assert seconds_of_time_text("2016-11-05T19:30:00Z", "--from", origin, span) == 4.5 * 3600
    with pytest.raises(ValueError, match=r"more than one UTC day .*give the date, e.g. "
                       r"2016-11-05T23:30Z"):
        seconds_of_time_text("23:30", "--from", origin, (origin, origin + 10 * 3600 * 10**9))
    with pytest.raises(ValueError, match="expected a clock time HH:MM"):
        seconds_of_time_text("25:10", "--from", origin, span)
    with pytest.raises(ValueError, match="needs the file's time origin"):
        seconds_of_time_text("19:30", "--from", None, None)


def test_the_commands_take_several_files_kinds_and_clock_times(tmp_path):
    track = write(tmp_path, "own.rep", OWN)
    cuts = write(tmp_path, "s.dsf", CUTS.replace(" NULL TA", " 3000 TA").replace(
        "0930", "0931"))
    out = tmp_path / "obs.csv"
    result = runner.invoke(app, ["import", "dsf", str(cuts), str(track), "-o", str(out),
                                 "--kinds", "bearing", "--ranges", "use"])
    assert result.exit_code == 0, result.output
    assert "5 bearing (deg) from OWN" in result.output and "range" not in result.output.split(
        "\n")[0]
    shown = runner.invoke(app, ["show", str(track), str(cuts), "--ranges", "use"])
    assert shown.exit_code == 0 and "range" in shown.output
    window = runner.invoke(app, ["estimate", str(cuts), str(track), "--motion", "static2d",
                                 "--ranges", "use", "--from", "09:31:15", "--to", "09:31:45"])
    assert window.exit_code == 0, window.output
    refused = runner.invoke(app, ["show", str(out), "--kinds", "bering"])
    assert refused.exit_code == 2 and "--kinds 'bering': expected measurement kinds" in (
        refused.output)
    none = runner.invoke(app, ["show", str(out), "--kinds", "frequency"])
    assert none.exit_code == 2 and "has no measurement of these kinds (it has bearing)" in (
        none.output)
    bad = runner.invoke(app, ["show", str(out), "--ranges", "use"])
    assert bad.exit_code == 2 and "--ranges applies to Debrief files" in bad.output
    kept = runner.invoke(app, ["show", str(out), "--kinds", "bearing"])
    assert kept.exit_code == 0, kept.output


# Debrief's SATC "B_Rate" pair (sample_data/SATC/B_Rate_Ownship.rep and B_Rate_Sensor.dsf,
# commit 2e4d42e143dfecb38444c9845a905b69354079cf): the own ship's times are written without
# their leading zero ("63503.91" is 06:35:03.91, as Debrief pads them) and the date is 1900.
B_RATE_OWN = ("19001212\t63503.91\tOWNSHIP\t@A\t51\t11\t35.55\tN\t152\t42\t48.69\tW\t204.9\t4.5"
              "\t19.41\n"
              "19001212\t63511.91\tOWNSHIP\t@A\t51\t11\t35.01\tN\t152\t42\t49.17\tW\t208.87\t4.59"
              "\t20.13\n"
              "19001212\t64003.93\tOWNSHIP\t@A\t51\t11\t0.72\tN\t152\t44\t1.68\tW\t230.54\t6.42"
              "\t57.98\n")
B_RATE_SENSOR = (";SENSOR2: 19001212\t063838.000\tOWNSHIP\t@C\tNULL\t213.0\tNULL\tNULL\tNULL"
                 "\tARRAY\tLabel\n"
                 ";SENSOR2: 19001212\t063856.000\tOWNSHIP\t@C\tNULL\t216.4\tNULL\tNULL\tNULL"
                 "\tARRAY\tLabel\n")


def test_times_without_leading_zeros_are_read_as_debrief_reads_them(tmp_path):
    own = write(tmp_path, "B_Rate_Ownship.rep", B_RATE_OWN)
    ms = tk.read_measurements([own, write(tmp_path, "B_Rate_Sensor.dsf", B_RATE_SENSOR)])
    assert ms.metadata["time_origin"] == "1900-12-12T06:35:03Z"
    assert ms.time.tolist() == pytest.approx([215.0, 233.0])  # 06:38:38 and 06:38:56
    padded = B_RATE_OWN.replace("\t6", "\t06")
    same = tk.read_measurements([write(tmp_path, "p.rep", padded),
                                 write(tmp_path, "s.dsf", B_RATE_SENSOR)])
    assert np.array_equal(same.sensor_state, ms.sensor_state)


# Debrief's MultiStatics/Offset_null_positions.rep (commit
# a8eaf3c33d54a9f085f025320257ac8acacefdc3): two sensors of the own ship (TAIL_BRG, BOW_BRG)
# with a bearing of SUBJECT at each time.
OFFSET = ("100112 120000 SENSOR FA 60 10 48.00 N 000 12 00.00 E 200.00  12.00  0.00 \n"
          ";SENSOR: 100112 120000 SENSOR @A NULL 166.1 0000 TAIL_BRG SUBJECT held on TAIL_BRG\n"
          ";SENSOR: 100112 120000 SENSOR @A NULL 162.6 0000 BOW_BRG SUBJECT held on BOW_BRG\n"
          "100112 120020 SENSOR FA 60 10 44.24 N 000 11 57.25 E 200.00  12.00  0.00 \n"
          ";SENSOR: 100112 120020 SENSOR @A NULL 166.0 0000 TAIL_BRG SUBJECT held on TAIL_BRG\n"
          ";SENSOR: 100112 120020 SENSOR @A NULL 162.3 0000 BOW_BRG SUBJECT held on BOW_BRG\n")


def test_two_sensors_with_cuts_at_one_time_are_read_together_each_by_its_name(tmp_path):
    rep = write(tmp_path, "Offset_null_positions.rep", OFFSET)
    both = tk.read_measurements(rep)
    assert sorted(both.sensors) == ["SENSOR/BOW_BRG", "SENSOR/TAIL_BRG"]
    tail = both.sensor_mask("SENSOR/TAIL_BRG")
    assert np.rad2deg(both.value_si[tail]).tolist() == pytest.approx([166.1, 166.0])
    assert np.array_equal(both.sensor_state[tail], both.sensor_state[~tail])  # NULL: the ship's
    assert "2 sensors of own ship 'SENSOR' (TAIL_BRG; BOW_BRG) measure bearing" in "\n".join(
        reader_notes(both.metadata))
    bow = tk.read_measurements(rep, contact="BOW_BRG")
    assert np.rad2deg(bow.value_si).tolist() == pytest.approx([162.6, 162.3])
