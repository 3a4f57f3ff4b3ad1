"""Measurement files (tmakit.io.measurement_files): exact round trips, refusals that name row,
line and column, lat/lon positions, range-difference reference states, and safe writing."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tmakit import rules
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.data import MeasurementSet
from tmakit.io.measurement_files import (
    COLUMN_ORDER,
    FORMAT_LINE,
    MeasurementFileError,
    read_measurements,
    write_measurements,
)
from tmakit.measurements import KINDS
from tmakit.sensors import RecordedTrack

SRC = Path(__file__).resolve().parents[1] / "src"
SUFFIXES = [".csv", ".parquet", ".pq"]


# -- helpers -------------------------------------------------------------------------------


def realistic_set() -> MeasurementSet:
    """Three sensors (ids that look numeric, or like NA), every kind, range differences, TDOA
    and FDOA with time_ref and reference states, NaNs where unused, metadata."""
    rng = np.random.default_rng(7)
    cols: dict[str, list] = {k: [] for k in ("t", "s", "k", "v", "sg", "st", "tr", "rs")}
    value_of = {
        "bearing": lambda: rng.uniform(0, 360), "elevation": lambda: rng.uniform(-90, 90),
        "azimuth_rate": lambda: rng.normal(0, 0.3), "range": lambda: rng.uniform(1e3, 5e4),
        "range_rate": lambda: rng.normal(0, 30), "frequency": lambda: 9.4e9 + rng.normal(0, 5e3),
        "power": lambda: rng.normal(-70, 5), "range_difference": lambda: rng.normal(0, 300),
        "tdoa": lambda: rng.normal(0, 1e-5), "fdoa": lambda: rng.normal(0, 50),
        "altitude": lambda: rng.uniform(-50, 3000)}
    for sensor in ("1", "uav-1", "NA"):
        start = rng.normal(0, 5e3, 3)
        vel = rng.normal(0, 50, 3)
        for i in range(6):
            t = 0.1 * i + rng.uniform(0, 1e-3) / 3
            for kind in KINDS:
                pos = start + vel * t if kind != "altitude" else np.zeros(3)
                cols["t"].append(t)
                cols["s"].append(sensor)
                cols["k"].append(kind)
                cols["v"].append(value_of[kind]())
                cols["sg"].append(rng.uniform(0.01, 3))
                cols["st"].append(np.concatenate([pos, vel]))
                if kind == "range_difference":
                    tr = t - 0.05 - rng.uniform(0, 1e-3)
                    cols["tr"].append(tr)
                    cols["rs"].append(np.concatenate([start + vel * tr, vel]))
                elif kind in ("tdoa", "fdoa"):  # against a reference sensor at the same time
                    cols["tr"].append(t)
                    cols["rs"].append(np.concatenate([pos + 1e3, vel]))
                else:
                    cols["tr"].append(np.nan)
                    cols["rs"].append(np.full(6, np.nan))
    meta = {"scenario": "three sensors", "seed": "7", "truth": '{"x0": 1000.5, "vx": -3}',
            "origin_lat": "48.1", "origin_lon": "11.5", "origin_alt": "520.0", "empty": ""}
    return MeasurementSet(cols["t"], cols["s"], cols["k"], cols["v"], cols["sg"], cols["st"],
                          cols["tr"], cols["rs"], meta)


HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_vx,sensor_vy,time_ref"
GOOD_ROWS = [
    "0,s1,bearing,10,1,0,0,5,0,",
    "0,s1,frequency,1e9,2,0,0,5,0,",
    "1,s1,power,-60,1,5,0,5,0,",
    "1,s1,frequency,1e9,2,5,0,5,0,",
    "2,s1,range_difference,15,3,10,0,5,0,1",
]


def write_csv(tmp_path: Path, rows: list[str], header: str = HEADER,
              meta: tuple[str, ...] = (FORMAT_LINE,), name: str = "obs.csv") -> Path:
    """A CSV file: ``meta`` comment lines, the header, then ``rows`` (data row R is on line
    R + len(meta) + 1)."""
    path = tmp_path / name
    path.write_text("\n".join([*meta, header, *rows]) + "\n", encoding="utf-8")
    return path


def refused(path: Path, **kwargs) -> str:
    with pytest.raises(MeasurementFileError) as info:
        read_measurements(path, **kwargs)
    message = str(info.value)
    assert message.startswith(str(path))
    assert info.value.path == path
    return message


# -- round trips ---------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_round_trip_is_exact(tmp_path, suffix):
    ms = realistic_set()
    assert set(ms.kind) == set(KINDS)
    path = write_measurements(ms, tmp_path / f"obs{suffix}")
    assert path == tmp_path / f"obs{suffix}"
    back = read_measurements(path)
    assert back.equals(ms)
    assert back.sensors == ["1", "uav-1", "NA"]
    assert back.metadata == ms.metadata
    plain = ~np.isin(back.kind, ["range_difference", "tdoa", "fdoa"])
    assert np.isnan(back.time_ref[plain]).all()
    assert np.isnan(back.ref_sensor_state[plain]).all()
    between = np.isin(back.kind, ["tdoa", "fdoa"])
    assert np.array_equal(back.time_ref[between], back.time[between])
    # written again from what was read: the same bytes
    again = write_measurements(back, tmp_path / f"again{suffix}")
    if suffix == ".csv":
        assert again.read_bytes() == path.read_bytes()


def test_csv_layout(tmp_path):
    ms = realistic_set()
    lines = write_measurements(ms, tmp_path / "obs.csv").read_text().splitlines()
    assert lines[0] == FORMAT_LINE
    assert lines[1:8] == [f"# {k}: {v}" if v else f"# {k}:" for k, v in ms.metadata.items()]
    header = lines[8].split(",")
    assert tuple(header[:12]) == COLUMN_ORDER
    assert header[12:] == ["ref_sensor_x", "ref_sensor_y", "ref_sensor_z", "ref_sensor_vx",
                           "ref_sensor_vy", "ref_sensor_vz"]
    first = lines[9].split(",")
    assert first[1:3] == ["1", "bearing"] and first[11:] == [""] * 7  # time_ref etc. empty
    # without range differences (nor tdoa, fdoa) there are no ref_sensor_* columns
    no_rd = ms.take(~np.isin(ms.kind, ["range_difference", "tdoa", "fdoa"]))
    header = write_measurements(no_rd, tmp_path / "no_rd.csv").read_text().splitlines()[8]
    assert tuple(header.split(",")) == COLUMN_ORDER
    assert read_measurements(tmp_path / "no_rd.csv").equals(no_rd)


finite = st.floats(allow_nan=False, allow_infinity=False)
positive = st.floats(min_value=0.0, exclude_min=True, allow_infinity=False)


#: The values each kind may hold (tmakit.rules: the kind's range, positions within reach).
_VALUES = {"range_rate": st.floats(-299_792_458.0, 299_792_458.0),
           "power": st.floats(-400.0, 400.0), "azimuth_rate": finite,
           "range_difference": st.floats(-1e9, 1e9)}


@st.composite
def random_sets(draw) -> MeasurementSet:
    n = draw(st.integers(1, 6))
    # within 1e4 s of each other: no time is far from the rest (rules.far_times)
    times = sorted(draw(st.lists(st.floats(-5e3, 5e3), min_size=n, max_size=n,
                                 unique=True)))
    kinds = draw(st.lists(st.sampled_from(list(_VALUES)), min_size=n, max_size=n))
    time_ref = np.full(n, np.nan)
    ref = np.full((n, 6), np.nan)
    for i, k in enumerate(kinds):
        if k == "range_difference":
            time_ref[i] = draw(st.floats(max_value=times[i], exclude_max=True,
                                         allow_infinity=False))
            ref[i] = draw(st.lists(finite, min_size=6, max_size=6))
    sensor = draw(st.sampled_from(["1", "007", "uav-1", "NaN", "a,b", ' q"x ']))
    values = [draw(_VALUES[k]) for k in kinds]
    sigmas = [draw(st.floats(min_value=1e-12 * max(abs(v), 1.0), allow_infinity=False,
                             max_value=rules.sigma_ceiling(k) or None))
              for k, v in zip(kinds, values, strict=True)]
    state = np.array(draw(st.lists(st.floats(-1e9, 1e9), min_size=3 * n, max_size=3 * n))
                     + draw(st.lists(st.floats(-2.99e8, 2.99e8), min_size=3 * n, max_size=3 * n)))
    state = np.concatenate([state[:3 * n].reshape(n, 3), state[3 * n:].reshape(n, 3)], axis=1)
    return MeasurementSet(
        times, [sensor] * n, kinds, values, sigmas, state,
        time_ref, ref, {"note": draw(st.text("abc:#, é", max_size=8)).strip() or "x"})


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(ms=random_sets())
def test_round_trip_random_floats(tmp_path, ms):
    for suffix in (".csv", ".parquet"):
        path = write_measurements(ms, tmp_path / f"r{suffix}", force=True)
        assert read_measurements(path).equals(ms)


def test_sensor_ids_stay_text(tmp_path):
    path = write_csv(tmp_path, ["0,007,power,-60,1,0,0,0,0,", "0,1.0,power,-60,1,0,0,0,0,",
                                "0,NA,power,-60,1,0,0,0,0,"])
    assert read_measurements(path).sensor.tolist() == ["007", "1.0", "NA"]


def test_optional_columns_default_to_zero_and_extra_columns_are_ignored(tmp_path):
    path = write_csv(tmp_path, ["0,a,bearing,10,1,3,4,what", "1,a,range,10,1,3,4,ever"],
                     header="time,sensor,kind,value,sigma,sensor_x,sensor_y,notes")
    ms = read_measurements(path)
    assert ms.sensor_state.tolist() == [[3, 4, 0, 0, 0, 0]] * 2
    assert np.isnan(ms.time_ref).all()
    assert ms.metadata == {}


def test_parquet_with_foreign_types(tmp_path):
    """Parquet from elsewhere: integer sensor ids and integer times are read as text and
    floats; metadata under 'tmakit:' keys."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({"time": [0, 1], "sensor": [1, 1], "kind": ["bearing", "bearing"],
                      "value": [1.5, 2.5], "sigma": [1.0, 1.0], "sensor_x": [0.0, 1.0],
                      "sensor_y": [0.0, 0.0]})
    table = table.replace_schema_metadata({b"tmakit:site": b"north", b"other": b"x"})
    pq.write_table(table, tmp_path / "f.parquet")
    ms = read_measurements(tmp_path / "f.parquet")
    assert ms.sensor.tolist() == ["1", "1"]
    assert ms.time.tolist() == [0.0, 1.0]
    assert ms.metadata == {"site": "north"}


def test_parquet_written_by_pandas_with_an_index_reads_its_columns(tmp_path):
    """df.set_index("time").to_parquet(), and to_parquet(index=True), ended with pandas'
    'Length mismatch: Expected axis has 11 elements, new values have 12 elements'."""
    import pandas as pd

    path = write_csv(tmp_path, GOOD_ROWS)
    want = read_measurements(path)
    frame = pd.read_csv(path, comment="#")
    for name, written in (("indexed", frame.set_index("time")),
                          ("multi", frame.set_index(["sensor", "time"])),
                          ("range", frame)):
        written.to_parquet(tmp_path / f"{name}.parquet", index=True)
        got = read_measurements(tmp_path / f"{name}.parquet")
        assert np.array_equal(got.time, want.time) and np.array_equal(got.value, want.value)


# -- refusals ------------------------------------------------------------------------------

# (rows replaced in GOOD_ROWS: {index: row}, row number, column, words in the message)
BAD_CELLS = {
    "unknown kind": ({1: "0,s1,freq,1e9,2,0,0,5,0,"}, 2, "kind",
                     ["'freq'", ", ".join(KINDS)]),
    "empty value": ({2: "1,s1,power,,1,5,0,5,0,"}, 3, "value", ["a number", "empty"]),
    "non-numeric value": ({2: "1,s1,power,loud,1,5,0,5,0,"}, 3, "value", ["'loud'"]),
    "NaN value": ({2: "1,s1,power,NaN,1,5,0,5,0,"}, 3, "value", ["a number", "NaN"]),
    "infinite position": ({2: "1,s1,power,-60,1,inf,0,5,0,"}, 3, "sensor_x",
                          ["finite", "inf"]),
    "empty time": ({0: ",s1,bearing,10,1,0,0,5,0,"}, 1, "time", ["a number"]),
    "empty sensor": ({0: "0,,bearing,10,1,0,0,5,0,"}, 1, "sensor", ["sensor id"]),
    "time decreasing": ({3: "0.5,s1,frequency,1e9,2,5,0,5,0,"}, 4, "time",
                        ["sensor 's1'", ">= 1 s", "found 0.5"]),
    "duplicate": ({3: "1,s1,power,-61,1,5,0,5,0,"}, 4, "time",
                  ["duplicate of row 3", "kind 'power'"]),
    "zero sigma": ({0: "0,s1,bearing,10,0,0,0,5,0,"}, 1, "sigma", ["> 0", "found 0"]),
    "negative sigma": ({0: "0,s1,bearing,10,-1,0,0,5,0,"}, 1, "sigma", ["> 0", "found -1"]),
    "bearing too large": ({0: "0,s1,bearing,360.5,1,0,0,5,0,"}, 1, "value",
                          ["[-360, 360]", "360.5"]),
    "bearing too small": ({0: "0,s1,bearing,-361,1,0,0,5,0,"}, 1, "value", ["[-360, 360]"]),
    "elevation": ({0: "0,s1,elevation,90.5,1,0,0,5,0,"}, 1, "value", ["[-90, 90]", "90.5"]),
    "frequency zero": ({1: "0,s1,frequency,0,2,0,0,5,0,"}, 2, "value", ["frequency within (0"]),
    "frequency negative": ({1: "0,s1,frequency,-1e9,2,0,0,5,0,"}, 2, "value", ["(0, 1e+15]"]),
    "negative range": ({0: "0,s1,range,-0.5,1,0,0,5,0,"}, 1, "value",
                       ["range within [0, 1000000000]"]),
    "range beyond reach": ({0: "0,s1,range,1e300,1,0,0,5,0,"}, 1, "value",
                           ["range within [0, 1000000000] m", "1e300"]),
    "time 1e300": ({4: "1e300,s1,range_difference,15,3,10,0,5,0,1"}, 5, "time",
                   ["within [-1e+10, 1e+10] s", "epoch milliseconds"]),
    "time far from the others": ({4: "1e9,s1,range_difference,15,3,10,0,5,0,1"}, 5, "time",
                                 ["100 spans of the bulk", "found 1e9"]),
    "sigma 1e-300": ({0: "0,s1,bearing,10,1e-300,0,0,5,0,"}, 1, "sigma",
                     ["at least 1e-12 times the value", "1e-300"]),
    "position beyond reach": ({0: "0,s1,bearing,10,1,1e300,0,5,0,"}, 1, "sensor_x",
                              ["position within [-1e+09, 1e+09] m"]),
    "time_ref missing": ({4: "2,s1,range_difference,15,3,10,0,5,0,"}, 5, "time_ref",
                         ["range_difference", "empty"]),
    "time_ref equal to time": ({4: "2,s1,range_difference,15,3,10,0,5,0,2"}, 5, "time_ref",
                               ["before time (2 s)", "found 2"]),
    "time_ref after time": ({4: "2,s1,range_difference,15,3,10,0,5,0,2.5"}, 5, "time_ref",
                            ["before time"]),
    "time_ref on a bearing": ({0: "0,s1,bearing,10,1,0,0,5,0,-1"}, 1, "time_ref",
                              ["only range_difference", "bearing"]),
    "no position at time_ref": ({4: "2,s1,range_difference,15,3,10,0,5,0,-1"}, 5, "time_ref",
                                ["no sensor position known at time_ref -1"]),
}


@pytest.mark.parametrize("case", list(BAD_CELLS))
def test_bad_cell_is_refused_naming_file_row_line_column(tmp_path, case):
    changes, row, column, words = BAD_CELLS[case]
    rows = [changes.get(i, r) for i, r in enumerate(GOOD_ROWS)]
    message = refused(write_csv(tmp_path, rows))
    line = row + 2  # format line and header come first
    assert f"row {row} (line {line}), column '{column}': expected " in message
    for word in words:
        assert word in message
    assert "1 problem in" in message


def test_good_rows_are_accepted(tmp_path):
    """Several kinds at the same time of one sensor (power and frequency) are normal."""
    ms = read_measurements(write_csv(tmp_path, GOOD_ROWS))
    assert ms.kind.tolist() == ["bearing", "frequency", "power", "frequency",
                                "range_difference"]
    # time_ref 1 is the time of the row before: its state is the reference state
    assert ms.ref_sensor_state[4].tolist() == [5, 0, 0, 5, 0, 0]


@pytest.mark.parametrize("column", ["time", "sensor", "kind", "value", "sigma", "sensor_x",
                                    "sensor_y"])
def test_missing_required_column(tmp_path, column):
    names = HEADER.split(",")
    keep = [i for i, c in enumerate(names) if c != column]
    rows = [",".join(r.split(",")[i] for i in keep) for r in GOOD_ROWS]
    message = refused(write_csv(tmp_path, rows, header=",".join(names[i] for i in keep)))
    assert f"column '{column}' is missing: " in message


def test_a_csv_without_any_column_of_the_format_names_every_missing_one(tmp_path):
    # a wide log given without its mapping (tma examples' bearings.csv): no known column at all
    path = tmp_path / "bearings.csv"
    path.write_text("epoch_s,bearing_deg\n1777887010.000,229.34\n")
    message = refused(path)
    assert str(path) in message
    assert all(f"column '{c}' is missing: " in message for c in HEADER.split(",")[:7])
    assert "a wide log (a row per time, a column per measurement) is read with a column " \
        "mapping (--mapping MAP.toml; tma import wide LOG --guess proposes one" in message


def test_a_csv_separated_by_semicolons_is_told_the_separator(tmp_path):
    path = tmp_path / "semi.csv"
    path.write_text(HEADER.replace(",", ";") + "\n" + GOOD_ROWS[0].replace(",", ";") + "\n")
    assert "tmakit's own file separates its columns by commas" in refused(path)


def test_missing_velocity_names_the_kinds_that_need_it(tmp_path):
    header = "time,sensor,kind,value,sigma,sensor_x,sensor_y,time_ref"
    rows = [",".join(r.split(",")[:7] + r.split(",")[9:]) for r in GOOD_ROWS]
    message = refused(write_csv(tmp_path, rows, header=header))
    assert "column 'sensor_vx' is missing" in message
    assert "column 'sensor_vy' is missing" in message
    assert "needed by the kind frequency" in message
    # without such kinds the velocity columns may be left out (velocity 0)
    ok = [r for r in rows if "frequency" not in r]
    ms = read_measurements(write_csv(tmp_path, ok, header=header, name="ok.csv"))
    assert np.all(ms.sensor_state[:, 3:] == 0)


def test_missing_time_ref_column_with_range_differences(tmp_path):
    rows = [r.rsplit(",", 1)[0] for r in GOOD_ROWS]
    message = refused(write_csv(tmp_path, rows, header=HEADER.rsplit(",", 1)[0]))
    assert "column 'time_ref' is missing" in message


def test_all_problems_are_reported(tmp_path):
    rows = ["0,s1,bearing,400,1,0,0,5,0,", "x,s1,frequency,1e9,-2,0,0,5,0,",
            "1,s1,kite,-60,1,5,0,5,0,", *GOOD_ROWS[3:]]
    message = refused(write_csv(tmp_path, rows))
    assert "4 problems" in message
    assert "row 1 (line 3), column 'value'" in message
    assert "row 2 (line 4), column 'time'" in message
    assert "row 2 (line 4), column 'sigma'" in message
    assert "row 3 (line 5), column 'kind'" in message


def test_long_problem_lists_are_capped(tmp_path):
    rows = [f"{i},s1,bearing,10,-1,0,0,0,0," for i in range(30)]
    with pytest.raises(MeasurementFileError) as info:
        read_measurements(write_csv(tmp_path, rows))
    assert len(info.value.problems) == 30
    message = str(info.value)
    assert "row 25 (line 27)" in message and "row 26 (line 28)" not in message
    assert message.endswith("... and 5 more problems")
    copy = pickle.loads(pickle.dumps(info.value))
    assert str(copy) == message and copy.problems == info.value.problems


def test_line_numbers_count_comments_blank_lines_and_quoted_line_breaks(tmp_path):
    path = tmp_path / "obs.csv"
    path.write_text(f"{FORMAT_LINE}\n# site: north\n\n{HEADER}\n"
                    '0,"two\nlines",bearing,10,1,0,0,5,0,\n'
                    "\n"
                    "1,s1,bearing,10,-1,0,0,5,0,\n")
    message = refused(path)
    assert "row 2 (line 8), column 'sigma'" in message


def test_windows_line_ends_and_byte_order_mark(tmp_path):
    path = tmp_path / "excel.csv"
    text = "\r\n".join([FORMAT_LINE, "# site: north ", HEADER, *GOOD_ROWS[:2],
                         "1,s1,power,-60,0,5,0,5,0,"]) + "\r\n"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert "row 3 (line 6), column 'sigma'" in refused(path)
    path.write_bytes(b"\xef\xbb\xbf" + text.replace(",0,5,0,5,0,", ",1,5,0,5,0,").encode())
    ms = read_measurements(path)
    assert ms.metadata == {"site": "north"} and len(ms) == 3


def test_a_header_in_another_case_is_told_to_rename_it(tmp_path):
    """'TIME,SENSOR,...' was told 'none of the columns of tmakit's measurement file: a wide
    log ...'; an extra 'Sensor_Z' column was dropped without a word (its heights read as 0)."""
    upper = refused(write_csv(tmp_path, GOOD_ROWS, header=HEADER.upper()))
    assert ("column names are lower case in tmakit's measurement file: rename 'TIME' to "
            "'time', 'SENSOR' to 'sensor'") in upper and "wide log" not in upper
    z = write_csv(tmp_path, [r + ",3" for r in GOOD_ROWS], header=HEADER + ",Sensor_Z",
                  name="z.csv")
    assert "rename 'Sensor_Z' to 'sensor_z'" in refused(z)
    import pyarrow.parquet as parquet

    pq = tmp_path / "z.parquet"
    write_measurements(read_measurements(write_csv(tmp_path, GOOD_ROWS, name="good.csv")), pq)
    table = parquet.read_table(pq)
    parquet.write_table(table.rename_columns(
        ["Time" if n == "time" else n for n in table.column_names]), pq)
    assert "rename 'Time' to 'time'" in refused(pq)
    kept = write_csv(tmp_path, [r + ",x" for r in GOOD_ROWS], header=HEADER + ",Note",
                     name="note.csv")
    assert len(read_measurements(kept)) == len(GOOD_ROWS)  # not a column of the format


def test_cells_padded_with_spaces_read_as_their_text(tmp_path):
    """' bearing ' was refused as no kind, where the sensor's and the numbers' padding read."""
    padded = [",".join(f" {c} " for c in r.split(",")) for r in GOOD_ROWS]
    ms = read_measurements(write_csv(tmp_path, padded))
    assert list(ms.kinds) == ["bearing", "frequency", "power", "range_difference"]


def test_a_pandas_index_column_is_named_as_such(tmp_path):
    """df.to_csv(path) writes an unnamed index first: say so, and how pandas leaves it out."""
    path = write_csv(tmp_path, [f"{k},{row}" for k, row in enumerate(GOOD_ROWS)],
                     header="," + HEADER)
    assert ("column 1 of the header has no name (pandas writes its index there: "
            "to_csv(..., index=False) leaves it out)") in refused(path)


def test_trailing_lines_of_spaces_are_blank_lines(tmp_path):
    """An editor's trailing '  ' and tab lines were refused as records of one field."""
    path = write_csv(tmp_path, GOOD_ROWS)
    path.write_text(path.read_text() + "\n   \n\t\n\n")
    assert len(read_measurements(path)) == len(GOOD_ROWS)
    inside = write_csv(tmp_path, [GOOD_ROWS[0], "   ", *GOOD_ROWS[1:]], name="inside.csv")
    assert "row 2 (line 4): expected 10 fields" in refused(inside)  # named where it is


def test_ragged_row_is_refused(tmp_path):
    message = refused(write_csv(tmp_path, [GOOD_ROWS[0], GOOD_ROWS[1] + ",extra"]))
    assert "row 2 (line 4): expected 10 fields" in message


def test_parquet_problems_name_row_and_column(tmp_path):
    ms = realistic_set().take(np.arange(8))
    sigma, value = ms.sigma.copy(), ms.value.copy()  # the set's arrays are read-only
    sigma[2], value[0] = -1.0, 720.0
    ms.sigma, ms.value = sigma, value
    path = write_measurements(ms, tmp_path / "bad.parquet")
    message = refused(path)
    assert "row 1, column 'value': expected a bearing within [-360, 360] deg, found 720" \
        in message
    assert "row 3, column 'sigma'" in message
    assert "line" not in message.split("\n", 1)[1]


def test_unknown_suffix_is_refused(tmp_path):
    path = tmp_path / "obs.txt"
    path.write_text("time\n")
    message = refused(path)
    assert "'.txt'" in message and ".csv" in message and ".parquet" in message
    with pytest.raises(ValueError, match=r"obs\.json.*'\.json' file.*\.csv"):
        write_measurements(realistic_set(), tmp_path / "obs.json")
    assert not (tmp_path / "obs.json").exists()


# -- latitude/longitude positions ----------------------------------------------------------

GEO_HEADER = "time,sensor,kind,value,sigma,sensor_lat,sensor_lon,sensor_alt"
GEO_ROWS = ["0,a,bearing,10,1,48.2,11.6,600", "1,a,bearing,11,1,48.25,11.55,650",
            "1,b,range,5000,10,48.0,11.4,0"]


def test_lat_lon_with_origin_in_metadata(tmp_path):
    meta = (FORMAT_LINE, "# origin_lat: 48.1", "# origin_lon: 11.5", "# origin_alt: 520")
    ms = read_measurements(write_csv(tmp_path, GEO_ROWS, GEO_HEADER, meta))
    lat, lon, alt = np.array([r.split(",")[5:8] for r in GEO_ROWS], dtype=float).T
    e, n, u = geodetic_to_enu(lat, lon, alt, (48.1, 11.5, 520.0))
    np.testing.assert_array_equal(ms.sensor_state[:, :3], np.column_stack([e, n, u]))
    assert np.all(ms.sensor_state[:, 3:] == 0)
    assert ms.metadata["origin_lat"] == "48.1"


def test_lat_lon_origin_argument_wins_and_is_recorded(tmp_path):
    meta = (FORMAT_LINE, "# origin_lat: 48.1", "# origin_lon: 11.5", "# origin_alt: 520")
    ms = read_measurements(write_csv(tmp_path, GEO_ROWS, GEO_HEADER, meta),
                           origin=(48.0, 11.4, 0.0))
    assert np.allclose(ms.sensor_state[2, :3], 0.0, atol=1e-6)
    assert (ms.metadata["origin_lat"], ms.metadata["origin_lon"]) == ("48.0", "11.4")


def test_lat_lon_without_origin_is_refused(tmp_path):
    message = refused(write_csv(tmp_path, GEO_ROWS, GEO_HEADER))
    assert "no ENU origin" in message and "origin=(lat, lon, alt)" in message
    assert "--" not in message  # the library names its parameter; the CLI names its flag


def test_the_command_line_names_its_origin_flag(tmp_path):
    from typer.testing import CliRunner

    from tmakit.cli import app

    result = CliRunner().invoke(app, ["show", str(write_csv(tmp_path, GEO_ROWS, GEO_HEADER))])
    assert result.exit_code == 2
    assert "--origin LAT,LON,ALT" in result.output and "read_measurements" not in result.output


def test_lat_lon_out_of_range(tmp_path):
    rows = [GEO_ROWS[0].replace("48.2", "91")]
    message = refused(write_csv(tmp_path, rows, GEO_HEADER), origin=(48, 11, 0))
    assert "row 1 (line 3), column 'sensor_lat': expected a latitude" in message


# -- range differences: the sensor state at time_ref ---------------------------------------

RD_HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,time_ref"


def test_reference_state_from_the_row_at_time_ref(tmp_path):
    rows = ["0,a,power,-60,1,100,200,30,1,2,", "0,b,power,-60,1,-5,-5,0,0,0,",
            "0.5,a,power,-61,1,101,201,30,1,2,", "0.5,a,range_difference,3,1,101,201,30,1,2,0"]
    ms = read_measurements(write_csv(tmp_path, rows, RD_HEADER))
    assert ms.ref_sensor_state[3].tolist() == [100, 200, 30, 1, 2, 0]


def test_reference_state_interpolated_between_rows(tmp_path):
    rows = ["0,a,power,-60,1,0,0,10,10,0,", "1,a,power,-60,1,10,1,10,10,2,",
            "2,a,power,-60,1,20,4,10,10,4,", "2,a,range_difference,3,1,20,4,10,10,4,0.25",
            "3,a,range_difference,3,1,30,9,10,10,6,1"]
    ms = read_measurements(write_csv(tmp_path, rows, RD_HEADER))
    track = RecordedTrack([0, 1, 2], [[0, 0, 10], [10, 1, 10], [20, 4, 10]],
                          [[10, 0, 0], [10, 2, 0], [10, 4, 0]])
    np.testing.assert_allclose(ms.ref_sensor_state[3], track.states([0.25])[0])
    assert ms.ref_sensor_state[4].tolist() == [10, 1, 10, 10, 2, 0]  # row at t = 1
    # the reference state columns, when given, are used as they are
    header = RD_HEADER + ",ref_sensor_x,ref_sensor_y"
    rows = [r + ",," for r in rows[:3]] + [rows[3] + ",7,8"]
    ms = read_measurements(write_csv(tmp_path, rows, header, name="given.csv"))
    assert ms.ref_sensor_state[3].tolist() == [7, 8, 0, 0, 0, 0]


def test_reference_state_outside_the_sensor_rows_is_refused(tmp_path):
    rows = ["1,a,power,-60,1,0,0,10,10,0,", "2,b,power,-60,1,0,0,10,10,0,",
            "3,b,range_difference,3,1,20,4,10,10,4,0.5"]
    message = refused(write_csv(tmp_path, rows, RD_HEADER))
    assert "row 3 (line 5), column 'time_ref'" in message
    assert "no sensor position known at time_ref 0.5" in message


# -- writing safely ------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_no_overwrite_without_force(tmp_path, suffix):
    path = tmp_path / f"obs{suffix}"
    path.write_bytes(b"precious\x00bytes")
    ms = realistic_set()
    with pytest.raises(FileExistsError) as info:
        write_measurements(ms, path)
    assert str(path) in str(info.value) and "force=True" in str(info.value)
    assert path.read_bytes() == b"precious\x00bytes"
    assert sorted(os.listdir(tmp_path)) == [path.name]
    write_measurements(ms, path, force=True)
    assert read_measurements(path).equals(ms)
    assert sorted(os.listdir(tmp_path)) == [path.name]


def test_failed_write_leaves_nothing_behind(tmp_path):
    ms = realistic_set()
    ms.metadata["note"] = "two\nlines"
    path = tmp_path / "obs.csv"
    with pytest.raises(ValueError, match="line break"):
        write_measurements(ms, path)
    assert os.listdir(tmp_path) == []
    # an existing file survives a failed forced write byte for byte
    path.write_text("old contents\n")
    with pytest.raises(ValueError, match="line break"):
        write_measurements(ms, path, force=True)
    assert path.read_text() == "old contents\n"
    assert os.listdir(tmp_path) == [path.name]


def test_failed_parquet_write_leaves_nothing_behind(tmp_path, monkeypatch):
    import pyarrow.parquet as pq

    def broken(table, where, **kwargs):
        Path(where).write_bytes(b"PAR1 half a file")
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", broken)
    with pytest.raises(OSError, match="disk full"):
        write_measurements(realistic_set(), tmp_path / "obs.parquet")
    assert os.listdir(tmp_path) == []


def test_import_tmakit_does_not_import_pandas():
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    code = ("import sys, tmakit; heavy = [m for m in ('pandas', 'pandera', 'pyarrow') "
            "if m in sys.modules]; assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_simulated_scenarios_round_trip(tmp_path):
    import tmakit as tk

    for name, _ in tk.builtin_scenarios():
        ms = tk.load_scenario(name).simulate(rng=3)
        for suffix in (".csv", ".parquet"):
            path = write_measurements(ms, tmp_path / f"{name}{suffix}")
            assert read_measurements(path).equals(ms), (name, suffix)


def test_example_in_the_docs_is_a_valid_file(tmp_path):
    text = (SRC.parent / "docs" / "file-format.md").read_text(encoding="utf-8")
    example = text.split("```csv\n", 1)[1].split("```", 1)[0]
    path = tmp_path / "example.csv"
    path.write_text(example, encoding="utf-8")
    ms = read_measurements(path)
    assert set(ms.kind) >= {"bearing", "frequency", "power", "range_difference"}
    assert ms.metadata["scenario"] == "docs-example"
    assert np.isfinite(ms.ref_sensor_state[ms.kind == "range_difference"]).all()


# -- reading large files: numbers parsed directly, each cell named by its row and line ---------

def test_numbers_are_read_back_exactly(tmp_path):
    x = np.random.default_rng(3).normal(size=2000) * 10.0 ** np.arange(-100, 100).repeat(10)
    rows = [f"{i},a,bearing,{float(v) % 360!r},1,0,0,5,0," for i, v in enumerate(x)]
    ms = read_measurements(write_csv(tmp_path, rows))
    assert ms.value.tolist() == [float(v) % 360 for v in x]


def test_a_bad_cell_keeps_its_row_number(tmp_path):
    rows = [f"{i},a,bearing,10,1,0,0,5,0," for i in range(7)]
    rows[4] = "4,a,bearing,10,-1.50,0,0,5,0,"
    message = refused(write_csv(tmp_path, rows))
    assert "row 5 (line 7), column 'sigma'" in message and "-1.50" in message


_FIELDS = "expected 3 fields (one per header column), found"
_RECORDS = [
    (b"a,b,c\n1,2,3\n", ("read", ["a", "b", "c"], [6])),
    (b"a,b,c\n1,2,3", ("read", ["a", "b", "c"], [6])),
    (b"a,b,c\n\n1,2,3\n\n\n4,5\n", ("refused", [f"row 2 (line 10): {_FIELDS} 2"])),
    (b"a, b ,c\n1,2,3,4\n,,\n \n", ("refused", [f"row 1 (line 6): {_FIELDS} 4",
                                               f"row 3 (line 8): {_FIELDS} 1"])),
    (b"a,a,\n1,2,3\n", ("refused", ["line 5: column 'a' appears more than once in the header",
                                    "line 5: column 3 of the header has no name"])),
    (b"a,b\n", ("read", ["a", "b"], [])), (b"a,b", ("read", ["a", "b"], [])),
    (b"x\n1\n\n2\n\n", ("read", ["x"], [6, 8]))]


@pytest.mark.parametrize(("body", "expected"), _RECORDS)
def test_records_give_the_header_the_line_of_each_row_and_their_problems(body, expected):
    """Blank lines are skipped, lines counted after 4 preamble lines, short and long rows named."""
    from tmakit.io import csv_file
    from tmakit.io.errors import MeasurementFileError

    try:
        names, _, lines = csv_file._record_lines(Path("x.csv"), body, 4)
    except MeasurementFileError as e:
        assert ("refused", e.problems) == expected
    else:
        assert ("read", names, lines.tolist()) == expected
