"""Real receivers' NMEA logs (gpsd's test captures, tests/data/nmea) and GPX quirks as own tracks.

Each log is one a valid tool (gpsd) reads: the sentences tmakit does not use (GSV, GSA, GLL,
proprietary ``$P...``, AIS ``!AIVDM``) are skipped, a sentence without a checksum is read, the
date comes from RMC or ZDA, and the positions and times are the file's.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.io import MeasurementFileError
from tmakit.io.errors import reader_notes
from tmakit.io.wide_log import read_gpx_fixes, read_nmea_fixes, read_track_fixes

DATA = Path(__file__).parent / "data" / "nmea"
GPX = Path(__file__).parent / "data" / "gpx"


def stamp(fixes, k):
    return str(np.datetime64(int(fixes.time_ns[k]), "ns"))


def dm(degrees, minutes):
    return degrees + minutes / 60.0


def test_gga_before_the_first_valid_rmc_is_dated_and_keeps_its_altitude():
    # beidou-bd.log: void RMCs, then the first fix is a GGA (line 54) before its RMC (line 66)
    fx = read_nmea_fixes(DATA / "beidou-bd.log")
    assert len(fx.time_ns) == 5 and fx.lines[0] == 54
    assert stamp(fx, 0) == "2015-02-25T07:41:55.799000000"
    assert fx.lat[0] == pytest.approx(dm(31, 14.8770)) and fx.lon[0] == pytest.approx(
        dm(121, 35.2463))
    assert fx.alt[0] == pytest.approx(156.9 + 8.3)  # above MSL + geoid separation
    assert np.all(fx.alt > 150.0)  # no fix at altitude 0 beside fixes at 200 m


def test_sentences_without_checksum_and_a_zda_date_are_read():
    # hp58534a.log: GGA and ZDA without checksums, proprietary $PFEC lines
    fx = read_nmea_fixes(DATA / "hp58534a.log")
    assert [stamp(fx, k) for k in range(2)] == ["2010-10-25T22:24:49.000000000",
                                                "2010-10-25T22:24:50.000000000"]
    assert fx.lat[0] == pytest.approx(-dm(33, 49.0337))
    assert fx.lon[0] == pytest.approx(dm(18, 43.9282))
    assert fx.alt[0] == pytest.approx(115.4 + 33.3)
    assert fx.notes == []


def test_a_sentence_cut_short_by_the_next_is_left_out_with_a_note():
    # triton400.log line 19: "$GPGGA,030130.00,...,030130$GPGLL,..." (the GGA unterminated)
    fx = read_nmea_fixes(DATA / "triton400.log")
    times = [stamp(fx, k)[11:19] for k in range(len(fx.time_ns))]
    assert times == ["03:01:29", "03:01:31", "03:01:32", "03:01:33"]
    assert fx.notes == ["note: 1 NMEA sentences without a checksum and cut short (line 19) "
                        "are left out"]


def test_ais_and_proprietary_sentences_beside_the_fixes_are_skipped():
    fx = read_nmea_fixes(DATA / "saab-r4.log")  # a ship's AIS/GPS unit: !AIVDM, $PFEC, ...
    assert len(fx.time_ns) == 12 and stamp(fx, 0) == "2011-06-01T13:07:11.000000000"
    assert fx.velocity is not None  # speed and course over the ground from RMC


def test_a_log_without_any_fix_says_what_the_receiver_reported():
    with pytest.raises(MeasurementFileError, match=r"no fix with a date and time: 11 GGA "
                       r"sentences without a fix \(quality 0\); 11 RMC sentences void"):
        read_nmea_fixes(DATA / "holux-gm-210.log")


def nmea(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


def test_line_numbers_are_an_editors_despite_control_bytes(tmp_path):
    # a receiver's binary message between the sentences may hold \x1c-\x1e, \x0b, \x0c
    log = nmea(tmp_path / "mixed.nmea", [
        "$GPRMC,120000,A,4807.038,N,01131.000,E,0.0,0.0,230394,,*0B", "\x1d\x0b\x0c junk",
        "$GPRMC,120001,A,4807.038,N,01131.000,E,0.0,0.0,230394,,*00"])
    with pytest.raises(MeasurementFileError, match="line 3: cannot read the NMEA sentence"):
        read_nmea_fixes(log)


def test_gga_after_midnight_takes_the_next_day(tmp_path):
    log = nmea(tmp_path / "midnight.nmea", [
        "$GPRMC,235959,A,4807.038,N,01131.000,E,0.0,0.0,311224,,",
        "$GPGGA,235959,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
        "$GPGGA,000000,4807.039,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
        "$GPRMC,000000,A,4807.039,N,01131.000,E,0.0,0.0,010125,,",
        "$GPGGA,000001,4807.040,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"])
    fx = read_nmea_fixes(log)
    assert [stamp(fx, k)[:19] for k in range(3)] == [
        "2024-12-31T23:59:59", "2025-01-01T00:00:00", "2025-01-01T00:00:01"]
    assert np.all(fx.alt == pytest.approx(545.4 + 46.9))


def test_gpx_points_without_elevation_or_time(tmp_path):
    pts = [(0, "<ele>500.0</ele>"), (10, ""), (20, "<ele>510.0</ele>"), (None, "<ele>1</ele>")]
    body = "".join(
        f'<trkpt lat="{45 + k * 1e-4}" lon="14.0">{ele}'
        + ("" if s is None else f"<time>2020-01-01T00:00:{s:02d}Z</time>") + "</trkpt>"
        for k, (s, ele) in enumerate(pts))
    gpx = tmp_path / "t.gpx"
    gpx.write_text('<?xml version="1.0"?><gpx version="1.1" creator="x" '
                   'xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
                   f"{body}</trkseg></trk></gpx>")
    fx = read_gpx_fixes(gpx)
    assert fx.alt.tolist() == pytest.approx([500.0, 505.0, 510.0])  # not 0 m between them
    assert fx.notes[0] == "note: 1 of 4 GPX points have no <time> and are left out"
    assert "altitude of 1 of 3 fixes (no <ele>) interpolated" in fx.notes[1]


def bearings_log(tmp_path, fixes):
    """Bearings from the track's fixes to a point 2 km north-east, and a mapping without track."""
    t = fixes.time_ns / 1e9
    log = tmp_path / "bearings.csv"
    log.write_text("epoch_s,bearing_deg\n" + "".join(
        f"{s:.3f},45.0\n" for s in np.linspace(t[0], t[-1], 6)))
    toml = tmp_path / "bearings.toml"
    toml.write_text('time = "epoch_s"\nsensor = "ship"\n[[measurement]]\ncolumn = "bearing_deg"'
                    '\nkind = "bearing"\nunit = "deg"\nsigma = 1.0\n')
    return log, toml


def gpx_points(path):
    import gpxpy

    with open(path, "rb") as f:
        g = gpxpy.parse(f)
    return [p for t in g.tracks for s in t.segments for p in s.points if p.time is not None]


@pytest.mark.parametrize("name", ["around-visnjan-with-car.gpx", "track-with-empty-segment.gpx"])
def test_real_gpx_tracks_are_read_point_for_point_as_gpxpy_reads_them(name):
    points, fixes = gpx_points(GPX / name), read_track_fixes(GPX / name)
    assert fixes.time_ns.tolist() == [int(p.time.timestamp()) * 10**9 for p in points]
    assert fixes.lat.tolist() == [p.latitude for p in points]
    assert fixes.lon.tolist() == [p.longitude for p in points]
    assert fixes.alt.tolist() == [p.elevation for p in points]


def test_a_real_gpx_whose_clock_reads_1901_is_refused_for_its_times():
    with pytest.raises(MeasurementFileError) as info:
        read_track_fixes(GPX / "Mojstrovka.gpx")
    said = str(info.value)
    assert said.startswith(str(GPX / "Mojstrovka.gpx"))
    assert "point at 1901-12-13T20:45:52.207Z, time: expected a date between 1970 and 2200" in said


def test_a_real_car_track_with_bearings_fits_and_its_stops_are_legs_without_a_heading(
        tmp_path):
    # gpxpy's car drive as the own track; bearings every 5 s to a point 3.5 km away, 1 deg noise
    track = GPX / "around-visnjan-with-car.gpx"
    fixes = read_track_fixes(track)
    t = np.arange(fixes.time_ns[0] / 1e9 + 1, fixes.time_ns[-1] / 1e9 - 1, 5.0)
    lat, lon = (np.interp(t, fixes.time_ns / 1e9, v) for v in (fixes.lat, fixes.lon))
    e, n, _ = tk.geodetic_to_enu(lat, lon, np.zeros(t.size), (45.3035, 13.7342, 0.0))
    noise = np.random.default_rng(3).normal(0.0, 1.0, t.size)
    bearing = (np.degrees(np.arctan2(-e, -n)) + noise) % 360.0
    log = tmp_path / "bearings.csv"
    log.write_text("epoch_s,bearing_deg\n" + "".join(
        f"{a:.3f},{b:.3f}\n" for a, b in zip(t, bearing, strict=True)))
    mapping = tmp_path / "car.toml"
    mapping.write_text(f'time = "epoch_s"\nsensor = "car"\ntrack = "{track}"\n'
                       '[[measurement]]\ncolumn = "bearing_deg"\nkind = "bearing"\n'
                       'unit = "deg"\nsigma = 1.0\n')
    result = CliRunner().invoke(app, ["estimate", str(log), "--mapping", str(mapping),
                                      "--motion", "static2d", "--json"])
    assert result.exit_code == 0, result.output
    answer = json.loads(result.stdout)["answer"]
    assert abs(answer["position"]["lat_deg"] - 45.3035) * 111e3 < 300
    text = CliRunner().invoke(app, ["estimate", str(log), "--mapping", str(mapping),
                                    "--motion", "static2d"]).output
    stops = [x for x in text.splitlines() if x.startswith("  leg ") and "stationary at" in x]
    assert len(stops) == 2, text  # the car stands still at 06:19:41-06:22:31 and at the end


def test_a_gpx_without_any_point_says_so(tmp_path):
    path = tmp_path / "empty.gpx"  # as gpxpy's default_schema_locations.gpx: metadata only
    path.write_text('<?xml version="1.0"?><gpx version="1.1" creator="x" '
                    'xmlns="http://www.topografix.com/GPX/1/1"><metadata/></gpx>')
    with pytest.raises(MeasurementFileError) as info:
        read_track_fixes(path)
    assert info.value.problems == [
        "no GPX point (no <trkpt>, <rtept> or <wpt>): a sensor track needs timed points"]


def test_gpx_points_at_one_time_are_read_once_when_equal_and_refused_when_apart(tmp_path):
    # the real car track written twice in one file (two <trk>), then with the second copy moved
    text = (GPX / "around-visnjan-with-car.gpx").read_text(encoding="utf-8")
    head, trk = text.split("<trk>", 1)
    trk, tail = ("<trk>" + trk).rsplit("</trk>", 1)
    twice = tmp_path / "twice.gpx"
    twice.write_text(head + trk + "</trk>" + trk + "</trk>" + tail, encoding="utf-8")
    fixes = read_track_fixes(twice)
    assert fixes.time_ns.tolist() == read_track_fixes(GPX / "around-visnjan-with-car.gpx"
                                                      ).time_ns.tolist()
    assert fixes.notes[0].startswith("note: 104 GPX point(s) written twice (same time and "
                                     "position) read once: track 2 segment 1 point 1 repeats "
                                     "track 1 segment 1 point 1;")
    moved = tmp_path / "moved.gpx"
    moved.write_text(head + trk + "</trk>" + trk.replace('lat="45.', 'lat="46.') + "</trk>"
                     + tail, encoding="utf-8")
    with pytest.raises(MeasurementFileError) as info:
        read_track_fixes(moved)
    first = info.value.problems[0]
    assert first.startswith("track 2 segment 1 point 1: two different positions at "
                            "2020-12-18T06:15:50Z: track 1 segment 1 point 1 (lat 45.")
    assert "and track 2 segment 1 point 1 (lat 46." in first


def test_import_nmea_takes_the_track_of_the_command_line_with_a_mapping_without_one(tmp_path):
    track = DATA / "saab-r4.log"
    log, toml = bearings_log(tmp_path, read_nmea_fixes(track))
    runner = CliRunner()
    out = tmp_path / "obs.parquet"
    result = runner.invoke(app, ["import", "nmea", str(track), str(log), "--mapping", str(toml),
                                 "-o", str(out)])
    assert result.exit_code == 0, result.output
    ms = tk.read_measurements(out)
    assert len(ms) == 6 and float(ms.metadata["origin_lat"]) == pytest.approx(50.21318)
    inline = runner.invoke(app, ["import", "nmea", str(track), str(log), "--map",
                                 "time=epoch_s,sensor=ship", "--measure",
                                 "bearing_deg=bearing:deg:1", "-o", str(tmp_path / "i.csv")])
    assert inline.exit_code == 0, inline.output
    notes = tk.read_measurements(DATA / "triton400.log", measurements=bearings_log(
        tmp_path, read_nmea_fixes(DATA / "triton400.log"))[0], mapping=toml, format="nmea")
    assert any("line 19" in n for n in reader_notes(notes.metadata))


def test_an_error_with_brackets_is_printed_as_written(tmp_path):
    log, _ = bearings_log(tmp_path, read_nmea_fixes(DATA / "saab-r4.log"))
    toml = tmp_path / "nopos.toml"
    toml.write_text('time = "epoch_s"\n[[measurement]]\ncolumn = "bearing_deg"\n'
                    'kind = "bearing"\nunit = "deg"\nsigma = 1.0\n')
    for out, said in ((tmp_path / "[final]" / "o.csv", "[final] does not exist"),
                      (tmp_path / "o.csv", "give [position] columns or a track file")):
        result = CliRunner().invoke(app, ["import", "wide", str(log), "--mapping", str(toml),
                                          "-o", str(out)])
        assert result.exit_code == 2 and said in result.output, result.output


# -- PX4 flight-controller GPS logs (tests/data/px4) ----------------------------------------
PX4 = Path(__file__).parent / "data" / "px4"


def px4_with_rssi(tmp_path, name):
    """The real log with a power column added (the logs hold no measurement of an emitter)."""
    import pandas as pd

    log = pd.read_csv(PX4 / name)
    log["rssi_dbm"] = -70.0 + 0.1 * np.arange(len(log))
    path = tmp_path / name
    log.to_csv(path, index=False)
    return path, log


def test_px4_logs_before_v1_14_write_positions_in_1e7_degrees_and_millimetres(tmp_path):
    path, log = px4_with_rssi(tmp_path, "sample_log_small_vehicle_gps_position_0.csv")
    runner = CliRunner()
    guess = runner.invoke(app, ["import", "wide", str(path), "--guess"])
    assert guess.exit_code == 0, guess.output
    assert 'lat_lon_unit = "1e-7 deg"' in guess.output and 'alt_unit = "mm"' in guess.output
    assert "heading" not in guess.output.split("# columns not used")[0]  # radians, unused
    mapping = tmp_path / "px4.toml"
    mapping.write_text(guess.output)
    out = tmp_path / "px4.parquet"
    done = runner.invoke(app, ["import", "wide", str(path), "--mapping", str(mapping), "-o",
                               str(out)])
    assert done.exit_code == 0, done.output
    ms = tk.read_measurements(out)
    assert float(ms.metadata["origin_lat"]) == pytest.approx(log["lat"][0] * 1e-7)
    assert float(ms.metadata["origin_lon"]) == pytest.approx(log["lon"][0] * 1e-7)
    assert float(ms.metadata["origin_alt"]) == pytest.approx(log["alt_ellipsoid"][0] / 1e3)
    assert ms.metadata["time_origin"] == "2021-04-21T06:30:58Z"  # time_utc_usec 1618986658.6 s
    mapping.write_text(guess.output.replace('lat_lon_unit = "1e-7 deg"', ""))
    refused = runner.invoke(app, ["import", "wide", str(path), "--mapping", str(mapping), "-o",
                                  str(tmp_path / "no.csv")])
    assert refused.exit_code == 2
    assert "holds integers up to 634170622: latitudes in 1e-7 degrees" in refused.output


def test_power_alone_from_a_vehicle_standing_still_gives_no_ellipse_to_trust(tmp_path):
    # The real log's vehicle stands still (its fixes wander 1.8 m by GPS noise); an emitter 120 m
    # east gives it the same power at every fix, 2 dB noise.  With the power constant unknown the
    # range is unobservable, but the fit explains the noise by the fixes' wander with the emitter
    # a few metres away, where the linearised ellipse is 29 x 1.8 m and misses the truth: the
    # answer must say that this ellipse is no bound (it said only "the ellipse is wide").
    import pandas as pd

    log = pd.read_csv(PX4 / "sample_log_small_vehicle_gps_position_0.csv")
    log["rssi_dbm"] = -60.0 + np.random.default_rng(0).normal(0.0, 2.0, len(log))
    path = tmp_path / "standing.csv"
    log.to_csv(path, index=False)
    runner = CliRunner()
    mapping = tmp_path / "standing.toml"
    mapping.write_text(runner.invoke(app, ["import", "wide", str(path), "--guess"]).output)
    meas = tk.read_measurements(path, format="wide", mapping=mapping)
    res = tk.estimate(meas, "static2d")
    truth = np.mean(meas.sensor_state[:, :2], axis=0) + np.array([120.0, 0.0])
    miss = res.estimate[:2] - truth
    assert miss @ np.linalg.solve(res.covariance[:2, :2], miss) > 5.99  # outside its 95 % ellipse
    assert "ellipse-not-a-bound" in [w.code for w in res.warnings(meas)]
    out = runner.invoke(app, ["estimate", str(path), "--mapping", str(mapping), "--motion",
                              "static2d"])
    text = " ".join(out.output.split())
    assert "(not a bound: range undetermined)" in text
    assert "cannot be trusted to hold the truth" in text
    data = json.loads(runner.invoke(app, ["estimate", str(path), "--mapping", str(mapping),
                                          "--motion", "static2d", "--json"]).stdout)
    assert "ellipse-not-a-bound" in [w["code"] for w in data["trust_reasons"]]


def test_px4_logs_from_v1_14_read_with_the_guessed_mapping(tmp_path):
    path, log = px4_with_rssi(tmp_path, "sample_px4_events_vehicle_gps_position_0_head30.csv")
    runner = CliRunner()
    guess = runner.invoke(app, ["import", "wide", str(path), "--guess"])
    assert guess.exit_code == 0 and "lat_lon_unit" not in guess.output, guess.output
    mapping = tmp_path / "px4.toml"
    mapping.write_text(guess.output)
    ms = tk.read_measurements(path, format="wide", mapping=mapping)
    assert len(ms) == 30 and float(ms.metadata["origin_lat"]) == pytest.approx(
        log["latitude_deg"][0])


def test_measurements_in_a_long_gap_of_the_own_track_are_warned_of(tmp_path):
    # fixes every 10 s, then none for 20 minutes (a GPX track's two segments, a receiver off)
    seconds = [*range(0, 100, 10), *range(1300, 1400, 10)]
    body = "".join(f'<trkpt lat="{45 + k * 1e-4}" lon="14.0"><time>'
                   f"{np.datetime64('2020-01-01T00:00:00') + np.timedelta64(s, 's')}Z</time>"
                   "</trkpt>" for k, s in enumerate(seconds))
    gpx = tmp_path / "t.gpx"
    gpx.write_text('<?xml version="1.0"?><gpx version="1.1" creator="x" '
                   'xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
                   f"{body}</trkseg></trk></gpx>")
    epoch = 1577836800  # 2020-01-01T00:00:00Z
    log = tmp_path / "b.csv"
    log.write_text("epoch_s,bearing_deg\n" + "".join(
        f"{epoch + s},45\n" for s in (5, 50, 600, 700, 1350)))
    toml = tmp_path / "b.toml"
    toml.write_text('time = "epoch_s"\nsensor = "ship"\n[[measurement]]\ncolumn = "bearing_deg"'
                    '\nkind = "bearing"\nunit = "deg"\nsigma = 1.0\n')
    ms = tk.read_measurements(gpx, measurements=log, mapping=toml)
    warned = [n for n in reader_notes(ms.metadata) if n.startswith("warning")]
    assert len(warned) == 1 and warned[0].startswith(
        "warning: 2 measurements fall where the own track has no fix for more than 100 s "
        "(the longest gap: 1210 s, from 2020-01-01T00:01:30Z)")


def test_binary_packets_between_the_sentences_are_skipped_as_gpsd_skips_them():
    fx = read_track_fixes(DATA / "ac12_binary.log")  # Ashtech $PASHR binary packets, NUL bytes
    assert (DATA / "ac12_binary.log").read_bytes().count(b"\0") > 0
    assert [stamp(fx, k)[11:19] for k in (0, 4)] == ["18:35:30", "18:35:34"]
    assert fx.lines.tolist() == [14, 31, 46, 62, 77]
    assert fx.lat[0] == pytest.approx(dm(20, 37.76012)) and fx.lon[0] == pytest.approx(
        -dm(87, 4.07373))


def test_following_an_own_track_alone_is_refused_at_once_not_awaited(tmp_path):
    track = tmp_path / "own.nmea"
    track.write_bytes((DATA / "saab-r4.log").read_bytes())
    runner = CliRunner()
    for args, given in ((["track", "--follow", str(track)], None),
                        (["track", "--follow", "-", "--format", "nmea"], track.read_text())):
        result = runner.invoke(app, [*args, "--max-updates", "1", "--interval", "0.01"],
                               input=given)
        assert result.exit_code == 2, result.output
        assert "a GPX or NMEA own track gives the sensor's positions only; follow the " \
               "measurement log" in " ".join(result.output.split())


OWN = Path(tk.__file__).parent / "examples" / "own.nmea"


def sentence(body: str) -> str:
    checksum = 0
    for c in body.encode():
        checksum ^= c
    return f"${body}*{checksum:02X}"


def second_receiver(talker: str, kinds: tuple[str, ...], north_m: float,
                    seconds: float = 0.0) -> list[str]:
    """own.nmea's RMC/GGA fixes again from another receiver: ``north_m`` further north,
    ``seconds`` later, under ``talker``."""
    lines = []
    for line in OWN.read_text().splitlines():
        fields = line.split("*")[0].lstrip("$").split(",")
        if fields[0][2:] not in kinds:
            continue
        at = 3 if fields[0].endswith("RMC") else 2
        fields[at] = f"{float(fields[at]) + north_m / 1852.0:.6f}"
        clock = float(fields[1]) + seconds
        fields[1] = f"{int(clock // 10000):02d}{int(clock % 10000 // 100):02d}{clock % 100:05.2f}"
        lines.append(sentence(",".join([talker + fields[0][2:], *fields[1:]])))
    return lines


def two_logs(tmp_path, extra: list[str]) -> Path:
    """own.nmea with a second receiver's sentences, each after the first's of its fix."""
    own = OWN.read_text().splitlines()
    merged, k = [], 0
    for line in own:
        merged.append(line)
        if line.startswith("$HEHDT") and k < len(extra):
            merged.append(extra[k])
            k += 1
    path = tmp_path / "two.nmea"
    path.write_text("\n".join(merged) + "\n")
    return path


@pytest.mark.parametrize(("talker", "kinds"), [("GN", ("RMC",)), ("GP", ("GGA",))])
def test_two_receivers_giving_positions_at_one_time_are_refused_naming_the_talkers(
        tmp_path, talker, kinds):
    """Was: a $GPRMC/$GPGGA receiver and a $GNRMC one 20 m apart (or two GGA streams) merged
    into one track, fix by fix, silently."""
    path = two_logs(tmp_path, second_receiver(talker, kinds, north_m=20.0))
    with pytest.raises(MeasurementFileError) as caught:
        read_nmea_fixes(path)
    text = str(caught.value)
    assert str(path) in text
    assert (f"line 1 ($GPRMC) and line 5 (${talker}{kinds[0]}): two positions 20 m apart at "
            "2026-05-04T09:30:00Z") in text or (
        f"line 2 ($GPGGA) and line 5 (${talker}{kinds[0]}): two positions 20 m apart at "
        "2026-05-04T09:30:00Z") in text
    named = "talkers GN, GP" if talker == "GN" else "talker GP"
    assert f"a log of two receivers ({named})? A sensor is at one place at a time" in text
    result = CliRunner().invoke(app, ["import", "nmea", str(path),
                                      str(OWN.with_name("bearings.csv")), "--mapping",
                                      str(OWN.with_name("bearings.toml")), "-o",
                                      str(tmp_path / "out.csv")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "two positions 20 m apart" in " ".join(result.output.split())
    assert not (tmp_path / "out.csv").exists()


def test_two_talkers_of_one_receiver_agreeing_are_read_as_one_with_a_note(tmp_path):
    path = two_logs(tmp_path, second_receiver("GN", ("RMC",), north_m=0.0))
    fixes = read_nmea_fixes(path)
    alone = read_nmea_fixes(OWN)
    np.testing.assert_array_equal(fixes.time_ns, alone.time_ns)
    np.testing.assert_allclose(fixes.lat, alone.lat, rtol=0, atol=1e-9)
    assert any("talkers GN and GP give positions within 1 m of each other at their 241 "
               "common times: read as one receiver" in n for n in fixes.notes)


def test_two_talkers_interleaving_without_a_common_time_are_refused(tmp_path):
    path = two_logs(tmp_path, second_receiver("GN", ("RMC",), north_m=0.0, seconds=2.5))
    with pytest.raises(MeasurementFileError, match="the fixes of talkers GN and GP interleave "
                                                  "in time without one common time"):
        read_nmea_fixes(path)


def test_a_log_with_binary_messages_is_read_by_import_as_by_a_mapping(tmp_path):
    """Was: ``tma import nmea ac12_binary.log LOG`` refused the log as binary (its NUL bytes),
    while the same log named by a mapping's ``track`` was read, its binary messages skipped."""
    log = tmp_path / "log.csv"
    log.write_text("epoch_s,bearing_deg\n" + "".join(
        f"{1198434931 + k},{10 + k}\n" for k in range(3)))
    mapping = tmp_path / "map.toml"
    mapping.write_text('time = "epoch_s"\nsensor = "boat"\n\n[[measurement]]\n'
                       'column = "bearing_deg"\nkind = "bearing"\nunit = "deg"\nsigma = 1.0\n')
    fixes = read_track_fixes(DATA / "ac12_binary.log")
    by_api = tk.read_measurements(DATA / "ac12_binary.log", format="nmea", measurements=log,
                                  mapping=mapping)
    assert len(by_api) == 3
    assert fixes.time_ns[0] <= 1198434931 * 10**9 and fixes.time_ns[-1] >= 1198434933 * 10**9
    out = tmp_path / "obs.csv"
    result = CliRunner().invoke(app, ["import", "nmea", str(DATA / "ac12_binary.log"), str(log),
                                      "--mapping", str(mapping), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert len(tk.read_measurements(out)) == 3
