"""Large CSV files stream in bounded memory; one set of rules for reader, from_si, simulator."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tmakit as tk
from tmakit.data import MeasurementSet
from tmakit.io import MeasurementFileError, checker, csv_file, read_measurements
from tmakit.io.checker import check_table
from tmakit.io.csv_file import load_csv

HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,sensor_vz"


def full_read(path):
    """The full checker's set (what the reader built before streaming)."""
    return check_table(path, load_csv(path))


def write_rows(path, rows, preamble=("# tmakit measurements v1", "# note: x")):
    path.write_text("\n".join([*preamble, HEADER, *rows]) + "\n", encoding="utf-8")
    return path


def two_sensor_rows(n):
    """Bearings and frequencies from two sensors, interleaved, a new sensor late in the file."""
    rows = []
    for i in range(n):
        t = float(i)
        rows.append(f"{t},ship,bearing,{(37.0 + 0.01 * i) % 360:.6f},1,{5 * t},0,0,5,0,0")
        rows.append(f"{t},ship,frequency,{1000.0 + 0.001 * i:.6f},0.1,{5 * t},0,0,5,0,0")
        if i >= n // 2:
            rows.append(f"{t},buoy 2,bearing,{(300.0 + 0.02 * i) % 360:.6f},2,100,-50,0,0,0,0")
    return rows


def test_a_streamed_file_equals_the_full_checkers_set_across_many_blocks(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setattr(csv_file, "BLOCK_BYTES", 4096)  # ~20 blocks: growth, late sensor
    path = write_rows(tmp_path / "obs.csv", two_sensor_rows(600))
    streamed = csv_file.stream_csv(path)
    assert streamed is not None
    full = full_read(path)
    assert streamed.equals(full)
    assert streamed.sensors == ["ship", "buoy 2"] and streamed.kinds == ["bearing", "frequency"]
    assert streamed.metadata == full.metadata == {"note": "x"}
    np.testing.assert_array_equal(streamed.value_si, full.value_si)
    np.testing.assert_array_equal(streamed.sigma_si, full.sigma_si)
    assert read_measurements(path).equals(full)  # the reader takes the stream


@pytest.mark.parametrize("text", [
    "\ufeff# a: b\n\n# c:d\n" + HEADER + "\n0,ship,bearing,10,1,0,0,0,5,0,0\n",
    (HEADER + "\n0,ship,bearing,10,1,0,0,0,5,0,0\n1,ship,bearing,11,1,5,0,0,5,0,0\n"
     ).replace("\n", "\r\n"),
    HEADER + '\n0,"ship",bearing,"10",1,0,0,0,5,0,0\n1,01,bearing,11,1,5,0,0,5,0,0\n',
    "kind,extra,sensor_y,time,value,sensor,sigma,sensor_x\nbearing,zz,0,0,10,ship,1,0\n",
    " time , sensor,kind,value,sigma,sensor_x,sensor_y,time_ref\n0,7,bearing,1e1,1,0,0,\n",
], ids=["bom-preamble", "crlf", "quoted-ids", "order-extra", "spaces-no-velocity"])
def test_odd_valid_files_stream_to_the_full_checkers_set(tmp_path, text):
    path = tmp_path / "odd.csv"
    path.write_text(text, encoding="utf-8", newline="")
    streamed = csv_file.stream_csv(path)
    assert streamed is not None and streamed.equals(full_read(path))


# 59 KB, 71 KB (past the 64 KiB read first), 1.2 MB (past the 1 MiB searched) of metadata
@pytest.mark.parametrize("lines", [1_000, 1_200, 20_000])
def test_a_long_preamble_streams_until_the_scan_ends(tmp_path, lines):
    preamble = ("# tmakit measurements v1", *(f"# k{i}: {'é' * 25}" for i in range(lines)))
    path = write_rows(tmp_path / "long.csv", two_sensor_rows(20), preamble)
    streamed = csv_file.stream_csv(path, scan=1 << 20)
    if lines == 20_000:  # the header lies past the bytes searched: the checker reads it
        assert streamed is None
        return
    full = full_read(path)
    assert streamed is not None and streamed.equals(full)
    assert streamed.metadata == full.metadata and len(full.metadata) == lines


# a bad byte in a column the stream skips, before 64 KiB, past it, past the 1 MiB scanned
@pytest.mark.parametrize(("row", "refused"), [(100, True), (3_000, True), (30_000, False)])
def test_a_non_utf8_cell_of_an_extra_column_refused_within_the_scan(tmp_path, row, refused):
    rows = [f"{r},x" for r in two_sensor_rows(15_000)]
    rows[row] = rows[row][:-1] + "\udce9t\udce9"  # bytes e9 74 e9: not UTF-8
    path = tmp_path / "note.csv"
    path.write_bytes("\n".join(["# tmakit measurements v1", HEADER + ",note", *rows]).encode(
        "utf-8", "surrogateescape") + b"\n")
    assert (csv_file.stream_csv(path) is None) == refused  # the checker says why
    if refused:
        with pytest.raises(MeasurementFileError, match="not a UTF-8 text file"):
            read_measurements(path)


def test_a_streamed_set_holds_the_stated_bytes_per_row(tmp_path):
    path = write_rows(tmp_path / "obs.csv", two_sensor_rows(500))
    meas = csv_file.stream_csv(path)
    held = [meas.time, meas.sensor_state, meas.kind_code, meas.sensor_code, meas.value,
            meas.sigma, meas.value_si, meas.sigma_si]
    assert sum(a.nbytes for a in held) == csv_file.SET_BYTES_PER_ROW * len(meas)
    # time_ref and the reference state are views of one NaN, not arrays of rows
    assert meas.time_ref.base is not None and meas.time_ref.strides == (0,)
    assert np.isnan(meas.ref_sensor_state).all()
    assert meas.take(np.arange(3)).time_ref.shape == (3,)


GEO_HEADER = "time,sensor,kind,value,sigma,sensor_lat,sensor_lon,sensor_alt,sensor_vx,sensor_vy"
ORIGIN = ("# origin_lat: 43.25", "# origin_lon: 5.375", "# origin_alt: 12")


def geodetic_rows(n, climb):
    """Bearings and frequencies from a ship and a late sensor, altitudes rising by ``climb`` m."""
    rows = []
    for i in range(n):
        t, lat, lon = float(i), 43.25 + 1e-4 * i, 5.375 - 2e-4 * i
        alt = 12.0 + climb * i / n
        rows.append(f"{t},ship,bearing,{(37.0 + 0.01 * i) % 360:.6f},1,{lat:.8f},{lon:.8f},"
                    f"{alt:.3f},5,0")
        rows.append(f"{t},ship,frequency,{1000.0 + 0.001 * i:.6f},0.1,{lat:.8f},{lon:.8f},"
                    f"{alt:.3f},5,0")
        if i >= n // 2:
            rows.append(f"{t},buoy 2,bearing,{(300.0 + 0.02 * i) % 360:.6f},2,43.3,5.4,"
                        f"{alt - 7:.3f},0,0")
    return rows


@pytest.mark.parametrize(("climb", "preamble", "origin", "dim"), [
    (20.0, ORIGIN, None, 2),  # within 25 m of the origin's altitude: a surface
    (400.0, ORIGIN, None, 3),  # climbing 400 m: heights kept
    (20.0, (*ORIGIN, "# dim: 3"), None, 3),  # asked for 3-D
    (400.0, ("# note: x",), (43.2, 5.3, 50.0), 3),  # the origin argument, no metadata
    (5.0, ("# origin_lat: 43.25", "# origin_lon: 5.375"), (43.2, 5.3, 10.0), 2),  # it wins
    (None, ("# origin_lat: 43.25", "# origin_lon: 5.375"), None, 2),  # no altitudes
], ids=["2d", "3d", "asked-3d", "origin-argument", "argument-wins", "no-altitude"])
def test_a_streamed_latlon_file_equals_the_full_checkers_set(tmp_path, monkeypatch, climb,
                                                             preamble, origin, dim):
    monkeypatch.setattr(csv_file, "BLOCK_BYTES", 4096)  # ~20 blocks
    monkeypatch.setattr(checker, "_ENU_ROWS", 97)  # converted in many pieces
    rows, header = geodetic_rows(300, climb or 0.0), GEO_HEADER
    if climb is None:  # drop the sensor_alt column
        rows = [",".join(r.split(",")[:7] + r.split(",")[8:]) for r in rows]
        header = GEO_HEADER.replace(",sensor_alt", "")
    path = tmp_path / "geo.csv"
    path.write_text("\n".join([*preamble, header, *rows]) + "\n", encoding="utf-8")
    streamed = csv_file.stream_csv(path, origin=origin)
    assert streamed is not None
    full = check_table(path, load_csv(path), origin)
    assert streamed.equals(full)  # bit for bit, metadata (origin, dim_rule) included
    assert streamed.metadata == full.metadata
    assert ("dim_rule" in streamed.metadata) == (dim == 2)
    up = streamed.sensor_state[:, 2]
    assert np.all(up == 0) == (dim == 2)
    assert np.ptp(streamed.sensor_state[:, 1]) > 1000  # north, in metres
    assert read_measurements(path, origin).equals(full)  # the reader takes the stream


@pytest.mark.parametrize(("preamble", "edit"), [
    (("# note: x",), None),  # no origin anywhere: the checker says how to give one
    (ORIGIN, lambda r: [*r[:5], r[5].replace(",43.2", ",93.2", 1), *r[6:]]),  # latitude > 90
    (("# origin_lat: 43.25", "# origin_lon: east"), None),  # an unreadable origin
])
def test_a_latlon_file_the_stream_cannot_take_goes_to_the_full_checker(tmp_path, preamble,
                                                                       edit):
    rows = geodetic_rows(20, 0.0)
    path = tmp_path / "geo.csv"
    path.write_text("\n".join([*preamble, GEO_HEADER, *(edit(rows) if edit else rows)]) + "\n",
                    encoding="utf-8")
    assert csv_file.stream_csv(path) is None
    with pytest.raises(MeasurementFileError):
        read_measurements(path)


RD_HEADER = HEADER + ",time_ref,ref_sensor_x,ref_sensor_y"


def range_difference_rows(n):
    """Bearings, and range differences whose time_ref is a row's time, between two rows, or
    given with its own ref_sensor_* cells; a second sensor's range differences late."""
    rows = []
    for i in range(n):
        t, x = float(i), 5.0 * i
        rows.append(f"{t},ship,bearing,{(37.0 + 0.01 * i) % 360:.6f},1,{x},0,0,5,0,0,,,")
        if i >= 2:
            ref = ("", "") if i % 3 else (f"{x - 7.5}", "0.5")
            back = 1.0 if i % 2 else 1.5  # the sensor's row, or between two rows
            rows.append(f"{t},ship,range_difference,{-12.5 + 0.01 * i:.4f},3,{x},0,0,5,0,0,"
                        f"{t - back},{ref[0]},{ref[1]}")
        if i >= n // 2 + 2:
            rows.append(f"{t},buoy,range_difference,{4.0 + 0.02 * i:.4f},2,100,-50,0,0,0,0,"
                        f"{t - 2},,")
        elif i >= n // 2:
            rows.append(f"{t},buoy,bearing,{(300.0 + 0.02 * i) % 360:.6f},2,100,-50,0,0,0,0,,,")
    return rows


def test_a_streamed_file_with_range_differences_equals_the_full_checkers_set(tmp_path,
                                                                             monkeypatch):
    monkeypatch.setattr(csv_file, "BLOCK_BYTES", 4096)  # ~20 blocks
    path = write_rows(tmp_path / "rd.csv", range_difference_rows(300))
    path.write_text(path.read_text().replace(HEADER, RD_HEADER, 1))
    streamed = csv_file.stream_csv(path)
    assert streamed is not None
    full = full_read(path)
    assert streamed.equals(full)
    rd = np.asarray(streamed.kind) == "range_difference"
    assert rd.sum() == 298 + 148 and np.isfinite(streamed.ref_sensor_state[rd]).all()
    assert np.isnan(streamed.ref_sensor_state[~rd]).all() and np.isnan(streamed.time_ref[~rd]).all()
    assert read_measurements(path).equals(full)


def test_a_streamed_latlon_file_with_range_differences_equals_the_full_checkers_set(
        tmp_path, monkeypatch):
    monkeypatch.setattr(csv_file, "BLOCK_BYTES", 4096)
    monkeypatch.setattr(checker, "_ENU_ROWS", 97)
    rows = []
    for row in geodetic_rows(200, 400.0):  # 3-D: the references from the ENU rows
        t = float(row.split(",")[0])
        rows.append(row + ",")
        if row.split(",")[1:3] == ["ship", "bearing"] and t >= 2:
            rows.append(row.replace("bearing", "range_difference", 1) + f",{t - 1.5}")
    path = tmp_path / "geo-rd.csv"
    path.write_text("\n".join([*ORIGIN, GEO_HEADER + ",time_ref", *rows]) + "\n")
    streamed = csv_file.stream_csv(path)
    assert streamed is not None
    full = full_read(path)
    assert streamed.equals(full) and np.ptp(streamed.ref_sensor_state[:, 2][
        np.asarray(streamed.kind) == "range_difference"]) > 100


@pytest.mark.parametrize("edit", [
    lambda r: [r[0].replace(",,,", ",-1,,"), *r[1:]],  # a time_ref on a bearing row
    lambda r: r,  # the control: unchanged, it streams
    lambda r: [*r[:3], r[3].rsplit(",", 3)[0] + ",9,,", *r[4:]],  # time_ref after time
    lambda r: [*r[:3], r[3].rsplit(",", 3)[0] + ",-9,,", *r[4:]],  # before the sensor's rows
    lambda r: [*r[:3], r[3].rsplit(",", 3)[0] + ",1.5,0,", *r[4:]],  # half a ref state
    lambda r: [*r, r[-1]],  # a duplicate (sensor, kind, time, time_ref)
], ids=["on-a-bearing", "unchanged", "after-time", "unknown-position", "half-ref",
        "duplicate"])
def test_a_range_difference_file_with_a_problem_is_not_streamed(tmp_path, edit):
    rows = range_difference_rows(8)
    path = write_rows(tmp_path / "rd.csv", edit(rows))
    path.write_text(path.read_text().replace(HEADER, RD_HEADER, 1))
    streamed = csv_file.stream_csv(path)
    if edit(rows) == rows:
        assert streamed is not None and streamed.equals(full_read(path))
        return
    assert streamed is None
    with pytest.raises(MeasurementFileError):
        read_measurements(path)


@pytest.mark.parametrize(("edit", "words"), [
    (lambda r: [*r[:5], "3.5,ship,bearing,400,1,0,0,0,5,0,0", *r[5:]],
     "column 'value': expected a bearing"),
    (lambda r: [*r[:5], "3.5,ship,bearing,10,,0,0,0,5,0,0", *r[5:]], "column 'sigma'"),
    (lambda r: [*r[:5], "3.5,ship,bearng,10,1,0,0,0,5,0,0", *r[5:]], "column 'kind'"),
    # a kind padded with spaces (' bearing ') is read as the checker strips it: it is not
    # streamed, and its row is then out of time order here (tests/test_files.py reads one)
    (lambda r: [*r[:5], "3.5,ship, bearing ,10,1,0,0,0,5,0,0", *r[5:]], "time decreases"),
    (lambda r: [*r, r[-1]], "one row per (sensor, kind, time, time_ref)"),
    (lambda r: [*r, "0.5,ship,bearing,10,1,0,0,0,5,0,0"], "time decreases for sensor 'ship'"),
    (lambda r: [*r[:5], "3.5,ship,bearing,10,1,0,0,0", *r[5:]], "expected 11 fields"),
])
def test_a_file_with_a_problem_is_not_streamed_and_the_reader_names_row_and_line(
        tmp_path, edit, words):
    path = write_rows(tmp_path / "bad.csv", edit(two_sensor_rows(20)))
    assert csv_file.stream_csv(path) is None
    with pytest.raises(MeasurementFileError) as err:
        read_measurements(path)
    assert words in str(err.value) and "(line " in str(err.value)


def test_from_si_refuses_what_the_reader_refuses_with_its_words():
    state = np.zeros((3, 6))
    args = (["s"] * 3, ["range"] * 3)
    with pytest.raises(ValueError, match=r"row 3, column 'time': expected a time >= 2\.0 s"):
        MeasurementSet.from_si([1.0, 2.0, 1.5], *args, [1.0, 2.0, 3.0], np.ones(3), state)
    with pytest.raises(ValueError, match=r"row 2, column 'value': expected a range"):
        MeasurementSet.from_si([1.0, 2.0, 3.0], *args, [1.0, -2.0, 3.0], np.ones(3), state)
    with pytest.raises(ValueError, match=r"row 1, column 'value': expected a bearing"):
        MeasurementSet.from_si([1.0], ["s"], ["bearing"], [np.radians(400.0)], [0.01],
                               np.zeros((1, 6)))
    # the same words as the constructor (file units), which is the reader's edge
    with pytest.raises(ValueError, match=r"row 2, column 'value': expected a range"):
        MeasurementSet([1.0, 2.0, 3.0], *args, [1.0, -2.0, 3.0], np.ones(3), state)
    rows = MeasurementSet.from_si([2.0, 1.0], ["s", "s"], ["range"] * 2, [1.0, 2.0],
                                  [1.0, 1.0], np.zeros((2, 6)), check=False).sorted()
    assert rows.time.tolist() == [1.0, 2.0]  # out of order: check=False, then sort


CLOSE_RANGE = """
name = "close-range"
[target]
motion = "cv2d"
ref_time = 0.0
truth = {{ x = 50.0, y = 0.0, vx = 0.0, vy = 1.0 }}
[[sensors]]
type = "legs"
id = "radar"
start = [0.0, 0.0]
heading_deg = 0.0
speed = 1.0
legs = [{{ duration = inf }}]
[[measurements]]
kind = "range"
sensor = "radar"
times = {{ start = 0.0, stop = 99.0, step = 1.0 }}
sigma = {sigma}
"""


def test_the_simulator_refuses_a_negative_noisy_range_naming_row_and_seed(tmp_path):
    path = tmp_path / "close.toml"
    path.write_text(CLOSE_RANGE.format(sigma=40.0))
    scn = tk.load_scenario(path)
    with pytest.raises(ValueError) as err:
        scn.simulate(rng=3)
    text = str(err.value)
    assert "impossible range with seed 3" in text and "sensor 'radar' at t = " in text
    assert "noise-free 50" in text and "sigma 40" in text and "lower the plan's sigma" in text
    path.write_text(CLOSE_RANGE.format(sigma=1.0))  # 50 sigma from the limit: simulated
    meas = tk.load_scenario(path).simulate(rng=3)
    assert (meas.value > 0).all()
    out = tk.write_measurements(meas, tmp_path / "close.csv")
    assert read_measurements(out).equals(meas)


def test_the_command_line_refuses_an_impossible_draw_with_exit_2(tmp_path):
    from typer.testing import CliRunner

    from tmakit.cli import app

    path = tmp_path / "close.toml"
    path.write_text(CLOSE_RANGE.format(sigma=40.0))
    res = CliRunner().invoke(app, ["simulate", str(path), "--seed", "3", "-o",
                                   str(tmp_path / "x.csv")])
    assert res.exit_code == 2, res.output
    assert "impossible range" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("name", ["bearings-only-2d", "hurtado2008"])
def test_a_fit_of_many_rows_summed_by_chunks_equals_the_whole_jacobians(name, monkeypatch):
    from tmakit.core import blas

    meas = tk.load_scenario(name).simulate(rng=2)
    whole = tk.estimate(meas, meas.metadata["motion"])
    monkeypatch.setattr(blas, "CHUNKED_ROWS", 100)  # these few rows count as many
    monkeypatch.setattr(blas, "CHUNK_ROWS", 77)
    chunked = tk.estimate(meas, meas.metadata["motion"])
    assert chunked.status == whole.status == "converged"
    assert chunked.iterations == whole.iterations
    assert np.all(np.abs(chunked.estimate - whole.estimate) <= 1e-9 * whole.std)
    np.testing.assert_allclose(chunked.std, whole.std, rtol=1e-9)
    assert chunked.chi2 == pytest.approx(whole.chi2, rel=1e-12)


PEAK_OF_A_READ = """
import sys
from pathlib import Path
from tmakit.io import read_measurements


def peak():  # this process's own peak (ru_maxrss would carry the parent's over exec)
    with open("/proc/self/status") as f:
        return next(int(x.split()[1]) * 1024 for x in f if x.startswith("VmHWM"))


read_measurements(Path(sys.argv[2]))  # a small file first: the libraries are loaded
before = peak()
meas = read_measurements(Path(sys.argv[1]))
print(len(meas), peak() - before)
"""


def peak_of_reading(tmp_path, n, geodetic=False):
    """Write an n-row bearings file; return its size and the growth of a child's peak RSS.

    ``geodetic``: positions as latitude, longitude and altitude (a 3-D file with an origin).
    """
    import subprocess
    import sys

    t = np.arange(n) * 0.01
    b = np.degrees(np.arctan2(4000.0 - 11 * t, 9000.0 - 3 * t)) % 360
    path = tmp_path / f"big{n}.csv"
    with open(path, "w") as f:
        if geodetic:
            f.write("\n".join([*ORIGIN, GEO_HEADER]) + "\n")
            f.writelines(f"{ti:.2f},ship,bearing,{bi:.6f},1,{43.25 + 4e-5 * ti:.7f},5.375,"
                         f"{12 + ti:.2f},5,0\n" for ti, bi in zip(t, b, strict=True))
        else:
            f.write(HEADER + "\n")
            f.writelines(f"{ti:.2f},ship,bearing,{bi:.6f},1,{5 * ti:.3f},0,0,5,0,0\n"
                         for ti, bi in zip(t, b, strict=True))
    small = tmp_path / "small.csv"  # of the same layout: the same libraries are loaded
    if geodetic:
        small.write_text("\n".join([*ORIGIN, GEO_HEADER, *geodetic_rows(50, 400.0)]) + "\n")
    else:
        write_rows(small, two_sensor_rows(50))
    out = subprocess.run([sys.executable, "-c", PEAK_OF_A_READ, str(path), str(small)],
                         check=True, capture_output=True, text=True).stdout.split()
    assert int(out[0]) == n
    return path.stat().st_size, int(out[1])


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("geodetic", [False, True], ids=["enu", "latlon"])
def test_reading_costs_less_than_three_times_the_bytes_of_each_row(tmp_path, geodetic):
    size_small, grown_small = peak_of_reading(tmp_path, 100_000, geodetic)
    size_big, grown_big = peak_of_reading(tmp_path, 400_000, geodetic)
    per_row_memory = (grown_big - grown_small) / 300_000
    per_row_file = (size_big - size_small) / 300_000
    assert per_row_memory <= 3 * per_row_file, (per_row_memory, per_row_file)
    # the measure sees the set (a difference of two peaks whose fixed parts differ: 77-82
    # bytes a row measured against the set's 93)
    assert per_row_memory >= csv_file.SET_BYTES_PER_ROW * 0.6, (grown_small, grown_big)


def peak_of_reading_range_differences(tmp_path, n):
    """As :func:`peak_of_reading`, every other row a range difference (ENU, velocities).

    The reference time of a range difference is the row before's time, or every fourth one
    between two rows (interpolated).
    """
    import subprocess
    import sys

    t = np.arange(n) * 0.01
    b = np.degrees(np.arctan2(4000.0 - 11 * t, 9000.0 - 3 * t)) % 360
    path = tmp_path / f"rd{n}.csv"
    with open(path, "w") as f:
        f.write(HEADER + ",time_ref\n")
        f.writelines(f"{t[i]:.2f},ship,bearing,{b[i]:.6f},1,{5 * t[i]:.3f},0,0,5,0,0,\n"
                     if i % 2 == 0 else
                     f"{t[i]:.2f},ship,range_difference,{0.01 * (i % 97):.2f},1,"
                     f"{5 * t[i]:.3f},0,0,5,0,0,{t[i - 1] + (0.005 if i % 8 == 1 else 0):.3f}\n"
                     for i in range(n))
    small = tmp_path / "small-rd.csv"  # of the same layout: the same libraries are loaded
    small.write_text(HEADER + ",time_ref\n0,ship,bearing,10,1,0,0,0,5,0,0,\n"
                     "1,ship,range_difference,1,1,5,0,0,5,0,0,0.5\n"
                     "2,ship,range_difference,1,1,10,0,0,5,0,0,1\n")
    out = subprocess.run([sys.executable, "-c", PEAK_OF_A_READ, str(path), str(small)],
                         check=True, capture_output=True, text=True).stdout.split()
    assert int(out[0]) == n
    return path.stat().st_size, int(out[1])


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
def test_reading_range_differences_costs_less_than_three_times_the_bytes_of_each_row(tmp_path):
    size_small, grown_small = peak_of_reading_range_differences(tmp_path, 100_000)
    size_big, grown_big = peak_of_reading_range_differences(tmp_path, 400_000)
    per_row_memory = (grown_big - grown_small) / 300_000
    per_row_file = (size_big - size_small) / 300_000
    assert per_row_memory <= 3 * per_row_file, (per_row_memory, per_row_file)
    assert per_row_memory >= csv_file.SET_BYTES_PER_ROW * 0.9, (grown_small, grown_big)
