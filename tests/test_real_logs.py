"""Readers of real logs: Debrief replay, wide CSV/Parquet with a mapping, GPX and NMEA tracks.

Round trips, refusals naming file and line, the surface rule, and the issue's figures on a
few seeds (the full figures: benchmarks/real_logs_replay.py and benchmarks/real_logs_drone.py).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from sample_logs import drone_sample, gpx_nmea_sample, replay_sample
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.io import MeasurementFileError
from tmakit.io.debrief import replay_tracks
from tmakit.io.logs import KNOT, Fixes, local_frame, parse_clock_times, velocity_from_positions

HEAD = ";; test\n"
OWN = ("260504 093000 OWN @A 47 57 00.00 N 005 15 00.00 W 90.0 10.0 0.0\n"
       "260504 093100 OWN @A 47 57 00.00 N 005 14 12.00 W 90.0 10.0 0.0\n")


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def course_speed(est):
    vx, vy = est[2], est[3]
    return np.rad2deg(np.arctan2(vx, vy)) % 360.0, np.hypot(vx, vy) / KNOT


# -- Debrief replay ------------------------------------------------------------------------
def test_replay_round_trip_keeps_clock_time_and_frame(tmp_path):
    text, _ = replay_sample(3)
    rep = write(tmp_path, "s.rep", text)
    ms = tk.read_measurements(rep)
    assert ms.kinds == ["bearing"] and ms.sensors == ["OWNSHIP"] and len(ms) == 720
    assert ms.metadata["time_origin"] == "2026-05-04T09:30:00Z"
    assert ms.time.max() == 3600.0 and ms.dim == 2
    back = tk.read_measurements(tk.write_measurements(ms, tmp_path / "obs.parquet"))
    assert back.equals(ms)
    dsf = tk.read_measurements(write(tmp_path, "s.dsf", text))  # the same line format
    assert np.array_equal(dsf.value, ms.value)
    assert np.array_equal(dsf.sensor_state, ms.sensor_state)


def test_replay_null_positions_follow_the_host_track(tmp_path):
    text, _ = replay_sample(1)
    rep = write(tmp_path, "s.rep", text)
    ms = tk.read_measurements(rep)
    track = replay_tracks(rep)["OWNSHIP"]
    origin = [float(ms.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(track["lat"], track["lon"], 0.0, origin)
    t = (track["time_ns"] - track["time_ns"][0]) / 1e9
    at = np.isin(ms.time, t)  # bearings at the times of track lines: the line's position
    k = np.searchsorted(t, ms.time[at])
    assert np.allclose(ms.sensor_state[at, 0], e[k], atol=1e-6)
    assert np.allclose(ms.sensor_state[at, 1], n[k], atol=1e-6)
    speed = np.hypot(ms.sensor_state[:, 3], ms.sensor_state[:, 4])
    assert np.allclose(speed[at], track["speed"][k] * KNOT, atol=0.01)


def test_replay_sensor2_ranges_frequencies_quotes_and_negative_bearings(tmp_path):
    rep = write(tmp_path, "s.rep", HEAD + OWN.replace("OWN", '"MY SHIP"') +
                ';SENSOR2: 260504 093030 "MY SHIP" @A NULL -10.0 170.0 150.5 1000 TA T1 a\n'
                ";SENSOR: 260504 093045.500 \"MY SHIP\" @A 47 57 00.00 N 005 14 30.00 W "
                "-350.0 NULL TA T1 b\n")
    ms = tk.read_measurements(rep, range_sigma=50.0)
    assert ms.sensors == ["MY SHIP"]
    assert sorted(ms.kinds) == ["bearing", "frequency", "range"]
    b = ms.select(kind="bearing")
    assert np.allclose(b.value, [350.0, 10.0]) and np.allclose(b.time, [30.0, 45.5])
    assert ms.select(kind="range").value_si[0] == pytest.approx(914.4)
    assert ms.select(kind="range").sigma_si[0] == 50.0
    assert ms.select(kind="frequency").value_si[0] == 150.5
    assert ms.metadata["ambiguous_bearings"] == "1"
    # the second track line is 48" of longitude east of the first (the origin): the NULL
    # position at 30 s is halfway, the given one 30" east
    origin = [float(ms.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    east_end = geodetic_to_enu(47.95, -(5 + 14 / 60 + 12 / 3600), 0.0, origin)[0]
    assert np.allclose(b.sensor_state[:, 0], [east_end / 2, east_end * 30 / 48], rtol=1e-6)


def test_replay_sensor3_accuracies_are_the_sigmas_unless_the_user_gives_one(tmp_path):
    """Debrief's ;SENSOR3: line: bearing, its accuracy, frequency, its accuracy, range."""
    rep = write(tmp_path, "s3.rep", HEAD + OWN +
                ";SENSOR3: 260504 093010 OWN @A NULL 45.0 2.5 150.25 0.05 2000 TA T1 a\n"
                ";SENSOR3: 260504 093020 OWN @A NULL 46.0 NULL 150.30 NULL NULL TA T1 b\n")
    ms = tk.read_measurements(rep)
    b, f = ms.select(kind="bearing"), ms.select(kind="frequency")
    assert np.allclose(b.value, [45.0, 46.0]) and np.allclose(f.value, [150.25, 150.30])
    assert np.allclose(b.sigma, [2.5, 1.0])  # the line's accuracy, then the default (deg)
    assert np.allclose(f.sigma_si, [0.05, 0.1])
    assert ms.select(kind="range").value_si[0] == pytest.approx(2000 * 0.9144)
    assert ms.metadata["sigma_from_file"] == "1"
    mine = tk.read_measurements(rep, bearing_sigma_deg=0.5, frequency_sigma=0.2, range_sigma=30.0)
    assert np.allclose(mine.select(kind="bearing").sigma, 0.5)  # the user's word wins
    assert np.allclose(mine.select(kind="frequency").sigma_si, 0.2)
    assert mine.select(kind="range").sigma_si[0] == 30.0
    bad = write(tmp_path, "b3.rep", HEAD + OWN +
                ";SENSOR3: 260504 093010 OWN @A NULL 45.0 0 150.25 0.05 NULL TA T1\n")
    with pytest.raises(MeasurementFileError, match="line 4: expected bearing accuracy > 0"):
        tk.read_measurements(bad)


@pytest.mark.parametrize(("line", "expect"), [
    ("2605x4 093000 OWN @A 47 57 00.00 N 005 15 00.00 W 90.0 10.0 0.0",
     "line 4: expected a date YYMMDD"),
    ("260504 093000 OWN @A 47 57 00.00 Q 005 15 00.00 W 90.0 10.0 0.0",
     "line 4: expected the hemisphere N or S, found 'Q'"),
    ("260504 093000 OWN @A 47 57 00.00 N 005 15 00.00 W 90.0 fast 0.0",
     "line 4: expected a speed (knots), found 'fast'"),
    (";SENSOR: 260504 093000 OWN @A NULL abc NULL TA",
     "line 4: expected a bearing (degrees) or NULL, found 'abc'"),
])
def test_replay_refusals_name_file_and_line(tmp_path, line, expect):
    rep = write(tmp_path, "bad.rep", HEAD + OWN + line + "\n"
                ";SENSOR: 260504 093030 OWN @A NULL 10 NULL TA\n")
    with pytest.raises(MeasurementFileError) as info:
        tk.read_measurements(rep)
    assert str(info.value).startswith(f"{rep}:") and expect in str(info.value)


def test_replay_ownship_and_contact_are_chosen_by_name(tmp_path):
    other = OWN.replace("OWN", "ALLY")
    rep = write(tmp_path, "two.rep", HEAD + OWN + other +
                ";SENSOR: 260504 093030 OWN @A NULL 10 NULL sonar CONTACT_A held\n"
                ";SENSOR: 260504 093040 OWN @A NULL 12 NULL radar CONTACT_B held\n"
                ";SENSOR: 260504 093030 ALLY @A NULL 20 NULL sonar CONTACT_A\n")
    with pytest.raises(MeasurementFileError, match="several tracks \\(OWN, ALLY\\); choose the "
                       "own ship with --ownship NAME"):
        tk.read_measurements(rep)
    with pytest.raises(MeasurementFileError, match="several sensors \\(sonar, radar\\); choose "
                       "one with --contact NAME"):
        tk.read_measurements(rep, ownship="OWN")
    with pytest.raises(MeasurementFileError, match="sensor names: sonar, radar; first words "
                       "of labels: CONTACT_A, CONTACT_B"):
        tk.read_measurements(rep, ownship="OWN", contact="NOBODY")
    with pytest.raises(MeasurementFileError, match="tracks with sensor lines: OWN, ALLY"):
        tk.read_measurements(rep, ownship="NOBODY")
    ms = tk.read_measurements(rep, ownship="OWN", contact="CONTACT_B")
    assert len(ms) == 1 and ms.value[0] == 12.0
    assert len(tk.read_measurements(rep, ownship="OWN", contact="sonar")) == 1


@pytest.mark.parametrize("seed", [0, 1, 4])
def test_replay_figure_course_and_speed_on_a_few_seeds(tmp_path, seed):
    """The issue's figure: course within 1 deg, speed within 0.2 kn (observable geometry)."""
    text, truth = replay_sample(seed)
    ms = tk.read_measurements(write(tmp_path, "c.rep", text), ownship="OWNSHIP",
                              contact="CONTACT", bearing_sigma_deg=0.5)
    result = tk.estimate(ms, tk.motion_from_name("cv2d"))
    course, speed = course_speed(result.estimate)
    assert result.status == "converged"
    assert abs((course - truth["course"] + 180) % 360 - 180) < 1.0
    assert abs(speed - truth["speed"]) < 0.2


# -- wide logs -------------------------------------------------------------------------------
def drone_files(tmp_path, seed=0):
    csv, mapping, truth = drone_sample(seed)
    return write(tmp_path, "drone.csv", csv), write(tmp_path, "drone.toml", mapping), truth


def test_drone_log_round_trip_velocity_and_origin(tmp_path):
    log, mapping, _ = drone_files(tmp_path)
    ms = tk.read_measurements(log, format="wide", mapping=mapping)
    assert ms.kinds == ["frequency", "power"] and len(ms) == 360 and ms.dim == 2
    assert ms.metadata["time_origin"] == "2026-05-04T09:30:00Z"
    assert ms.metadata["altitude_reference"] == "msl"
    first = log.read_text().splitlines()[1].split(",")
    assert float(ms.metadata["origin_lat"]) == float(first[1])  # the first fix
    assert np.allclose(ms.sensor_state[0, :3], 0.0, atol=1e-6)
    # NED velocity columns: vn -> north (y), ve -> east (x)
    assert ms.sensor_state[0, 4] == float(first[4]) and ms.sensor_state[0, 3] == float(first[5])
    assert ms.select(kind="power").value[0] == pytest.approx(float(first[7]), rel=1e-14)
    back = tk.read_measurements(tk.write_measurements(ms, tmp_path / "o.parquet"))
    assert back.equals(ms)


@pytest.mark.parametrize("sep", [";", "\t"])
def test_a_spreadsheets_semicolon_or_tab_log_with_decimal_commas_reads_like_the_csv(tmp_path,
                                                                                   sep):
    log, mapping, _ = drone_files(tmp_path)
    rows = [r.split(",") for r in log.read_text().splitlines()]
    text = "\n".join(sep.join([r[0], *(c.replace(".", ",") for c in r[1:])]) for r in rows)
    other = write(tmp_path, "excel.csv", text + "\n")  # 47,95000069;-5,25000243;...
    a = tk.read_measurements(other, format="wide", mapping=mapping)
    b = tk.read_measurements(log, format="wide", mapping=mapping)
    for column in ("time", "value_si", "sigma_si", "sensor_state"):
        assert np.array_equal(getattr(a, column), getattr(b, column)), column
    guess = CliRunner().invoke(app, ["import", "wide", str(other), "--guess"])
    assert guess.exit_code == 0 and 'time = "utc"' in guess.output, guess.output


def test_velocity_derived_from_positions_when_the_log_has_none(tmp_path):
    log, mapping, _ = drone_files(tmp_path)
    text = mapping.read_text()
    no_velocity = text[:text.index("\n[velocity]")] + text[text.index("\n[[measurement]]"):]
    ms = tk.read_measurements(log, format="wide", mapping=write(tmp_path, "nv.toml",
                                                                 no_velocity))
    given = tk.read_measurements(log, format="wide", mapping=mapping)
    assert "derived from positions" in ms.metadata["velocity_source"]
    inner = (ms.time > 10) & (ms.time < 50)  # the straight leg, away from the ends
    assert np.allclose(ms.sensor_state[inner, 3:5], given.sensor_state[inner, 3:5], atol=0.3)


def test_epoch_and_iso_clock_times():
    t, bad = parse_clock_times(["2026-05-04T09:30:00.25Z", "1777887000.5",
                                "2026-05-04 11:30:00+02:00", "yesterday"])
    assert bad.tolist() == [False, False, False, True]
    assert (t[0] - t[2]) == 250_000_000 and (t[1] - t[2]) == 500_000_000


def test_iso_clock_times_beyond_the_nanosecond_years_are_refused_as_cells():
    """pandas keeps 2500 and 1500 at microseconds; they were pandas' 'Out of bounds' error."""
    t, bad = parse_clock_times(["2026-05-04T09:30:00Z", "2500-05-04T09:30:03Z",
                                "1500-05-04T09:30:03Z", "2199-12-31T23:59:59Z"])
    assert bad.tolist() == [False, True, True, False]
    assert t[3] - t[0] > 0


@pytest.mark.parametrize(("edit", "expect"), [
    (lambda s: s.replace("2026-05-04T09:30:03.000Z", "09h30"),
     "row 4 (line 5), column 'utc': expected an ISO-8601 time or epoch seconds (since "
     "1970-01-01 UTC) between 1970 and 2200, found '09h30'"),
    (lambda s: s.replace("2026-05-04T09:30:03.000Z", "2500-05-04T09:30:03Z"),
     "row 4 (line 5), column 'utc': expected an ISO-8601 time or epoch seconds (since "
     "1970-01-01 UTC) between 1970 and 2200, found '2500-05-04T09:30:03Z'"),
    (lambda s: s.replace(",47.95", ",97.95", 1),
     "row 1 (line 2), column 'lat': expected a latitude within [-90, 90] deg, found 97.95"),
    (lambda s: s.replace("rssi_dbm", "rssi"), "column 'rssi_dbm' (power in dBm) is missing"),
])
def test_wide_log_refusals_name_row_line_and_column(tmp_path, edit, expect):
    log, mapping, _ = drone_files(tmp_path)
    log.write_text(edit(log.read_text()))
    with pytest.raises(MeasurementFileError) as info:
        tk.read_measurements(log, format="wide", mapping=mapping)
    assert str(info.value).startswith(f"{log}:") and expect in str(info.value)


def test_mapping_errors_name_the_key(tmp_path):
    log, mapping, _ = drone_files(tmp_path)
    mapping.write_text(mapping.read_text().replace('unit = "dBm"', 'unit = "mW"'))
    with pytest.raises(MeasurementFileError, match=r"measurement\.0: unit 'mW' of power: "
                       "expected one of dBm, dBW"):
        tk.read_measurements(log, format="wide", mapping=mapping)


def test_a_blank_sensor_id_is_refused_by_key_or_by_cell(tmp_path):
    """sensor = "" and an empty cell of a sensor_column gave sets with sensor '', which
    tma import wrote to a file that tmakit then refused."""
    log, mapping, _ = drone_files(tmp_path)
    text = mapping.read_text()
    mapping.write_text(text.replace('sensor = "drone"', 'sensor = ""'))
    with pytest.raises(MeasurementFileError, match="sensor: expected a sensor id"):
        tk.read_measurements(log, format="wide", mapping=mapping)
    mapping.write_text(text.replace('sensor = "drone"', 'sensor_column = "rx"'))
    lines = log.read_text().splitlines()
    log.write_text("\n".join([lines[0] + ",rx"] + [
        line + ("," if k == 3 else ",d1") for k, line in enumerate(lines[1:], 1)]) + "\n")
    with pytest.raises(MeasurementFileError, match=re.escape(
            "row 3 (line 4), column 'rx': expected a sensor id (text), found an empty cell")):
        tk.read_measurements(log, format="wide", mapping=mapping)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_drone_figure_transmitter_within_three_sigma(tmp_path, seed):
    """The issue's figure on a few seeds: 2-D Mahalanobis distance of the error <= 3.

    With ``tma estimate``'s defaults: the drone flies 90 m above the transmitter, so the
    height is fitted (:func:`tmakit.batch.height.choose_height`; tests/test_trust.py).
    """
    from tmakit.batch.height import choose_height

    log, mapping, truth = drone_files(tmp_path, seed)
    ms = tk.read_measurements(log, format="wide", mapping=mapping)
    result = choose_height(ms, tk.estimate(ms, tk.motion_from_name("static2d"))).result
    origin = [float(ms.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(truth["lat"], truth["lon"], origin[2], origin)
    err = result.estimate[:2] - np.array([float(e), float(n)])
    assert result.status == "converged" and result.motion.name == "static3d"
    assert np.sqrt(err @ np.linalg.solve(result.covariance[:2, :2], err)) <= 3.0


# -- the surface rule --------------------------------------------------------------------------
def fixes(alt, north_km=20.0):
    lat = 47.95 + np.linspace(0.0, north_km / 111.2, len(alt))
    return Fixes(np.arange(len(alt), dtype=np.int64), lat, np.full(len(alt), -5.25),
                 np.asarray(alt, float))


def test_surface_rule_flattens_curvature_and_gps_noise_only():
    noisy = fixes(100.0 + np.random.default_rng(1).normal(0, 5.0, 50))
    frame = local_frame([noisy], None, None)
    assert frame.dim == 2 and "tolerance 25 m" in frame.rule
    pos = frame.enu(noisy.lat, noisy.lon, noisy.alt)
    assert np.all(pos[:, 2] == 0.0) and pos[-1, 1] == pytest.approx(20000.0, rel=0.01)
    up = geodetic_to_enu(noisy.lat[-1], noisy.lon[-1], frame.origin[2], frame.origin)[2]
    assert up < -25.0  # 20 km away, the same altitude is 31 m below the tangent plane
    climbing = fixes(np.linspace(100.0, 300.0, 50))
    assert local_frame([climbing], None, None).dim == 3
    assert local_frame([noisy], None, 3).dim == 3
    assert local_frame([climbing], None, 2).dim == 2


def test_velocity_fit_recovers_a_straight_line():
    t = np.arange(0.0, 60.0, 1.0)
    pos = np.column_stack([3.0 * t + 5.0, -2.0 * t])
    assert np.allclose(velocity_from_positions(t, pos, 10.0), [3.0, -2.0])


# -- GPX and NMEA own tracks -----------------------------------------------------------------
def boat_files(tmp_path, seed=0):
    gpx, nmea, bearings, mapping, truth = gpx_nmea_sample(seed)
    return (write(tmp_path, "own.gpx", gpx), write(tmp_path, "own.nmea", nmea),
            write(tmp_path, "bearings.csv", bearings), write(tmp_path, "bearings.toml", mapping),
            truth)


def test_gpx_and_nmea_tracks_give_the_same_bearings_set(tmp_path):
    gpx, nmea, log, mapping, truth = boat_files(tmp_path)
    a = tk.read_measurements(gpx, measurements=log, mapping=mapping)
    b = tk.read_measurements(nmea, measurements=log, mapping=mapping)
    c = tk.read_measurements(log, format="wide", mapping=mapping)  # the mapping's track
    assert c.equals(a) and len(a) == 119
    assert np.allclose(a.sensor_state[:, :2], b.sensor_state[:, :2], atol=0.5)
    assert "speed and course" in b.metadata["velocity_source"]
    result = tk.estimate(b, tk.motion_from_name("static2d"))
    origin = [float(b.metadata[k]) for k in ("origin_lat", "origin_lon", "origin_alt")]
    e, n, _ = geodetic_to_enu(truth["lat"], truth["lon"], origin[2], origin)
    err = result.estimate[:2] - np.array([float(e), float(n)])
    assert np.sqrt(err @ np.linalg.solve(result.covariance[:2, :2], err)) <= 3.0


def test_nmea_bad_checksum_and_times_outside_the_track_name_the_line(tmp_path):
    gpx, nmea, log, mapping, _ = boat_files(tmp_path)
    lines = nmea.read_text().splitlines()
    lines[5] = lines[5][:-2] + ("00" if lines[5][-2:] != "00" else "11")
    nmea.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementFileError, match="line 6: cannot read the NMEA sentence"):
        tk.read_measurements(nmea, measurements=log, mapping=mapping)
    rows = log.read_text().splitlines()
    rows.append(f"{float(rows[-1].split(',')[0]) + 3600:.3f},100.0")
    log.write_text("\n".join(rows) + "\n")
    with pytest.raises(MeasurementFileError, match=r"row 120 \(line 121\), column 'time'.*"
                       "outside the own track"):
        tk.read_measurements(gpx, measurements=log, mapping=mapping)
    with pytest.raises(MeasurementFileError, match="give the measurement log too"):
        tk.read_measurements(gpx)


def test_a_log_wholly_outside_its_track_is_one_problem_naming_both_spans(tmp_path):
    gpx, _, log, mapping, _ = boat_files(tmp_path)
    rows = log.read_text().splitlines()  # the log's clock two hours ahead of the track's
    log.write_text("\n".join([rows[0]] + [f"{float(r.split(',')[0]) + 7200:.3f},"
                                          f"{r.split(',')[1]}" for r in rows[1:]]) + "\n")
    with pytest.raises(MeasurementFileError) as info:
        tk.read_measurements(gpx, measurements=log, mapping=mapping)
    assert info.value.problems == [
        "every measurement time (2026-05-04T11:30:10Z to 2026-05-04T11:49:50Z, 119 rows) is "
        "outside the own track (2026-05-04T09:30:00Z to 2026-05-04T09:50:00Z): is the log's "
        "clock local time read as UTC (give the zone in the times, e.g. "
        "2026-05-04T11:30:00+02:00), or the track of another day?"]


def test_tmakits_own_file_given_a_column_mapping_is_said_to_be_one(tmp_path):
    _, _, _, mapping, _ = boat_files(tmp_path)
    own = tmp_path / "obs.csv"
    tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=1), own)
    with pytest.raises(MeasurementFileError) as info:  # pandas' tokenizer error before
        tk.read_measurements(own, format="wide", mapping=mapping)
    assert info.value.problems == [
        "is tmakit's own measurement file (its first line says so), not a wide log: read it "
        "without --mapping, --map or --format"]


def test_surface_rule_in_tmakits_own_lat_lon_files(tmp_path):
    rows = ["0,a,bearing,10,1,48.0,11.5,3", "60,a,bearing,11,1,48.18,11.5,-2"]  # 20 km north
    text = "time,sensor,kind,value,sigma,sensor_lat,sensor_lon,sensor_alt\n" + "\n".join(rows)
    flat = write(tmp_path, "flat.csv", "# origin_lat: 48.0\n# origin_lon: 11.5\n" + text)
    ms = tk.read_measurements(flat)
    assert np.all(ms.sensor_state[:, 2] == 0.0) and ms.dim == 2
    assert ms.sensor_state[1, 1] == pytest.approx(20000.0, rel=0.01)
    kept = write(tmp_path, "kept.csv", "# origin_lat: 48.0\n# origin_lon: 11.5\n# dim: 3\n" + text)
    assert tk.read_measurements(kept).sensor_state[1, 2] < -25.0  # curvature as height


def test_dsf_sensor_lines_with_tabs_eight_digit_dates_and_no_track_lines(tmp_path):
    lines = [f";SENSOR:\t20100112\t1213{s:02d}\tOWNSHIP  @A\t0\t4\t{s / 10:.1f}\tS\t30\t0\t10\tW"
             f"\t{2.4 + s / 10:.1f}\t12000\tPlain\tCookie SUBJECT held" for s in range(0, 60, 10)]
    dsf = write(tmp_path, "s.dsf", "\n".join(lines) + "\n;TA_MODULES: 20100112 NULL\n")
    ms = tk.read_measurements(dsf, range_sigma=100.0, ranges="use")
    assert ms.metadata["time_origin"] == "2010-01-12T12:13:00Z"
    assert len(ms.select(kind="bearing")) == 6 and len(ms.select(kind="range")) == 6
    assert ms.select(kind="range").value_si[0] == pytest.approx(12000 * 0.9144)
    b = ms.select(kind="bearing")  # 1" of latitude south per 10 s: 3.09 m/s south
    assert np.allclose(b.sensor_state[:, 4], -30.87 / 10, rtol=0.02)
    assert "derived from the sensor lines" in ms.metadata["velocity_source"]
    null = write(tmp_path, "n.dsf", ";SENSOR: 100112 121300 OWNSHIP @A NULL 2.0 NULL TA\n")
    with pytest.raises(MeasurementFileError, match=r"sensor positions NULL \(line 1\), but own "
                       "ship 'OWNSHIP' has no track lines.*give the own ship's track file"):
        tk.read_measurements(null)


def test_relative_bearings_take_the_heading_from_hdt_or_a_column(tmp_path):
    gpx, nmea, log, mapping, _ = boat_files(tmp_path)
    true = tk.read_measurements(nmea, measurements=log, mapping=mapping)
    # the sample's HDT heading is the course over the ground: relative = true - course
    course = np.rad2deg(np.arctan2(true.sensor_state[:, 3], true.sensor_state[:, 4]))
    rows = log.read_text().splitlines()
    rel = [f"{r.split(',')[0]},{(float(r.split(',')[1]) - c) % 360:.6f},{c % 360:.6f}"
           for r, c in zip(rows[1:], course, strict=True)]
    write(tmp_path, "rel.csv", "epoch_s,bearing_deg,hdg\n" + "\n".join(rel) + "\n")
    text = mapping.read_text().replace('kind = "bearing"', 'kind = "bearing"\nreference = '
                                       '"relative"')
    write(tmp_path, "rel.toml", text)
    from_hdt = tk.read_measurements(nmea, measurements=tmp_path / "rel.csv",
                                    mapping=tmp_path / "rel.toml")
    assert np.allclose(np.angle(np.exp(1j * (from_hdt.value_si - true.value_si))), 0.0,
                       atol=np.deg2rad(0.06))  # HDT is written to 0.1 deg
    write(tmp_path, "col.toml", 'heading = "hdg"\n' + text)
    from_column = tk.read_measurements(gpx, measurements=tmp_path / "rel.csv",
                                       mapping=tmp_path / "col.toml")
    assert np.allclose(np.angle(np.exp(1j * (from_column.value_si - true.value_si))), 0.0,
                       atol=1e-6)
    with pytest.raises(MeasurementFileError, match="row 1 \\(line 2\\), column 'bearing_deg': "
                       "a bearing relative to the heading needs the heading"):
        tk.read_measurements(gpx, measurements=tmp_path / "rel.csv",
                             mapping=tmp_path / "rel.toml")


def test_clock_times_of_a_set_from_its_time_origin(tmp_path):
    from tmakit.io.logs import clock_times

    log, mapping, _ = drone_files(tmp_path)
    ms = tk.read_measurements(tk.write_measurements(
        tk.read_measurements(log, format="wide", mapping=mapping), tmp_path / "o.csv"))
    stamps = clock_times(ms.metadata, ms.time[:3])
    assert [str(s) for s in stamps] == ["2026-05-04T09:30:00.000000000"] * 2 + [
        "2026-05-04T09:30:01.000000000"]
    assert clock_times({}, ms.time) is None
    assert ms.time.max() < 200.0  # seconds from the origin, no epoch in the numbers


def test_a_parquet_wide_log_with_a_timestamp_column_reads_like_the_csv(tmp_path):
    import pandas as pd

    log, mapping, _ = drone_files(tmp_path)
    frame = pd.read_csv(log)
    frame["utc"] = pd.to_datetime(frame["utc"])
    frame.to_parquet(tmp_path / "drone.parquet")
    a = tk.read_measurements(log, format="wide", mapping=mapping)
    b = tk.read_measurements(tmp_path / "drone.parquet", format="wide", mapping=mapping)
    assert np.array_equal(a.time, b.time) and np.array_equal(a.value, b.value)
    assert np.allclose(a.sensor_state, b.sensor_state, atol=1e-9)
    assert b.metadata["time_origin"] == a.metadata["time_origin"]
    frame.set_index("utc").to_parquet(tmp_path / "indexed.parquet")  # 'utc' was missing
    c = tk.read_measurements(tmp_path / "indexed.parquet", format="wide", mapping=mapping)
    assert np.array_equal(a.time, c.time) and np.array_equal(a.value, c.value)


def test_the_shipped_samples_are_the_simulations_output():
    """src/tmakit/examples is what benchmarks/make_sample_logs.py writes (seed 0; drone 6)."""
    from importlib import resources

    shipped = resources.files("tmakit") / "examples"
    rep, _ = replay_sample(0)
    drone, drone_map, _ = drone_sample(6)
    gpx, nmea, bearings, bearings_map, _ = gpx_nmea_sample(0)
    for name, text in (("contact.rep", rep), ("drone.csv", drone), ("drone.toml", drone_map),
                       ("own.nmea", nmea), ("bearings.csv", bearings),
                       ("bearings.toml", bearings_map)):
        assert (shipped / name).read_text(encoding="utf-8") == text, name
    import gpxpy  # the GPX points (gpxpy's XML layout may change between versions)

    def points(xml):
        return [(p.latitude, p.longitude, p.elevation, p.time)
                for p in gpxpy.parse(xml).tracks[0].segments[0].points]

    assert points((shipped / "own.gpx").read_text(encoding="utf-8")) == points(gpx)
