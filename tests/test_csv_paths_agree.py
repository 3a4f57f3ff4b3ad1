"""The CSV file's two paths and a set's constructor refuse a bad cell by one rule, in one wording.

A valid file streams (``csv_file.stream_csv``); any other goes to the checker, which names every
problem by row, line and column.  The same bad files are fed to the stream (it must refuse them,
never building a set the checker would refuse), to the reader (the checker's message) and, where
a set can hold the cell, to ``MeasurementSet`` (``tmakit.rules.column_problems``): the reader's
problem is the constructor's, with the line added.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import tmakit as tk
from tmakit.io import MeasurementFileError, csv_file, read_measurements
from tmakit.io.checker import check_table
from tmakit.io.csv_file import load_csv

HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,sensor_vz"
GOOD = [f"{t}.0,ship,bearing,{30 + t}.0,1.0,{5 * t}.0,0.0,0.0,5.0,0.0,0.0" for t in range(8)]


def _with_cell(column: str, text: str, kind: str = "bearing") -> list[str]:
    """The good rows, row 5's ``column`` replaced by ``text`` (and its kind by ``kind``)."""
    rows = [r.split(",") for r in GOOD]
    names = HEADER.split(",")
    rows[4][names.index(column)] = text
    rows[4][names.index("kind")] = kind
    return [",".join(r) for r in rows]


BAD_CELLS = [  # (column, cell, kind, the words of what was expected)
    ("value", "400", "bearing", "a bearing within [-360, 360] deg"),
    ("value", "-5", "range", "a range within [0, 1000000000] m"),
    ("value", "inf", "bearing", "a finite number"),
    ("sigma", "-1", "bearing", "a noise standard deviation > 0"),
    ("sigma", "1e-20", "bearing", "a noise standard deviation of at least 1e-12 times"),
    ("time", "1e11", "bearing", "a time within [-1e+10, 1e+10] s of the time origin"),
    ("sensor_x", "inf", "bearing", "a finite number"),
    ("sensor_y", "2e9", "bearing", "a position within [-1e+09, 1e+09] m of the origin"),
    ("sensor_vx", "4e8", "bearing", "a velocity within [-299792458, 299792458] m/s"),
]


def _set_of(rows: list[str]) -> tk.MeasurementSet:
    """Build the rows as a set by the constructor (file units), as a caller of the library."""
    cells = [r.split(",") for r in rows]
    number = np.array([[float(c) for i, c in enumerate(r) if i not in (1, 2)] for r in cells])
    return tk.MeasurementSet(number[:, 0], [r[1] for r in cells], [r[2] for r in cells],
                             value_file=number[:, 1], sigma_file=number[:, 2],
                             sensor_state=number[:, 3:])


@pytest.mark.parametrize(("column", "cell", "kind", "expected"), BAD_CELLS,
                         ids=[f"{c}={v}" for c, v, _, _ in BAD_CELLS])
def test_a_bad_cell_is_refused_by_both_paths_with_the_constructors_words(tmp_path, column,
                                                                         cell, kind, expected):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join([HEADER, *_with_cell(column, cell, kind)]) + "\n")
    assert csv_file.stream_csv(path) is None  # the stream leaves it to the checker
    with pytest.raises(MeasurementFileError) as file_error:
        read_measurements(path)
    problems = file_error.value.problems
    reader = next(p for p in problems if f"column '{column}'" in p)
    assert reader == f"row 5 (line 6), column '{column}': expected {reader.split('expected ')[1]}"
    assert f"expected {expected}" in reader and reader.endswith(f"found {cell}")
    with pytest.raises(ValueError) as set_error:
        _set_of(_with_cell(column, cell, kind))
    library = [p.strip() for p in str(set_error.value).split(": ", 1)[1].splitlines()]
    own = next(p for p in library if p.startswith(f"row 5, column '{column}'"))
    # the same problem, word for word but for the line and the cell as written
    assert re.sub(r" \(line \d+\)", "", reader).split(", found")[0] == own.split(", found")[0]


RD_HEADER = HEADER + ",time_ref,ref_sensor_x,ref_sensor_y"
RD_ROWS = ["0.0,ship,bearing,30.0,1.0,0.0,0.0,0.0,5.0,0.0,0.0,,,"] + [
    f"{t}.0,ship,range_difference,{t}.5,1.0,{5 * t}.0,0.0,0.0,5.0,0.0,0.0,{t - 1}.0,,"
    for t in range(1, 8)]


@pytest.mark.parametrize(("row", "expected"), [
    ("4.0,ship,range_difference,1.5,1.0,20.0,0.0,0.0,5.0,0.0,0.0,,,",
     "column 'time_ref': expected a time_ref (s) before time: range_difference / tdoa / fdoa "
     "rows need one, found an empty cell"),
    ("4.0,ship,range_difference,1.5,1.0,20.0,0.0,0.0,5.0,0.0,0.0,9.0,,",
     "column 'time_ref': expected a time_ref before time (4 s), found 9.0"),
    ("4.0,ship,bearing,15.0,1.0,20.0,0.0,0.0,5.0,0.0,0.0,3.0,,",
     "column 'time_ref': expected an empty cell: only range_difference / tdoa / fdoa rows have "
     "a time_ref (this row is bearing), found 3.0"),
    ("4.0,ship,range_difference,1.5,1.0,20.0,0.0,0.0,5.0,0.0,0.0,inf,,",
     "column 'time_ref': expected a finite number, found inf"),
    ("4.0,ship,range_difference,1.5,1.0,20.0,0.0,0.0,5.0,0.0,0.0,3.0,7.0,",
     "column 'ref_sensor_y': expected a number (the other ref_sensor_* cells of this row are "
     "given; give all or none), found an empty cell"),
    ("4.0,ship,bearing,15.0,1.0,20.0,0.0,0.0,5.0,0.0,0.0,,7.0,0.0",
     "column 'ref_sensor_x': expected an empty cell: only range_difference / tdoa / fdoa rows "
     "have a sensor state at time_ref (this row is bearing), found 7.0"),
    ("4.0,ship,tdoa,1e-6,1e-8,20.0,0.0,0.0,5.0,0.0,0.0,3.0,7.0,0.0",
     "column 'time_ref': expected the row's own time (4 s): a tdoa is between two sensors at "
     "one time, found 3.0"),
    ("4.0,ship,tdoa,1e-6,1e-8,20.0,0.0,0.0,5.0,0.0,0.0,4.0,,",
     "column 'ref_sensor_x': expected a number: a tdoa row gives its reference sensor's state "
     "(or names it in ref_sensor), found an empty cell"),
])
def test_a_bad_range_difference_cell_is_refused_by_the_stream_and_named_by_the_checker(
        tmp_path, row, expected):
    # the stream's block check and the checker's cells run one set of rules
    # (checker.reference_problems): what the checker names, the stream never streams
    rows = [r if not r.startswith("4.0,") else row for r in RD_ROWS]
    path = tmp_path / "rd.csv"
    path.write_text("\n".join([RD_HEADER, *rows]) + "\n")
    assert csv_file.stream_csv(path) is None
    with pytest.raises(MeasurementFileError) as err:
        read_measurements(path)
    assert f"row 5 (line 6), {expected}" in err.value.problems
    good = tmp_path / "good.csv"  # the control: the unchanged rows stream to the checker's set
    good.write_text("\n".join([RD_HEADER, *RD_ROWS]) + "\n")
    streamed = csv_file.stream_csv(good)
    assert streamed is not None and streamed.equals(check_table(good, load_csv(good)))
