"""Fixed memory of a streamed read: the text pyarrow reads ahead, the libraries it imports."""

from __future__ import annotations

import subprocess
import sys

import pyarrow as pa
from test_streaming_and_rules import (
    HEADER,
    RD_HEADER,
    range_difference_rows,
    two_sensor_rows,
    write_rows,
)

from tmakit.io import csv_file, read_measurements


def test_the_text_held_while_streaming_is_a_few_dozen_blocks_of_a_large_file(tmp_path,
                                                                             monkeypatch):
    block = 1 << 14
    monkeypatch.setattr(csv_file, "BLOCK_BYTES", block)
    path = write_rows(tmp_path / "obs.csv", two_sensor_rows(30_000))  # ~4 MB: ~250 blocks
    size = path.stat().st_size
    assert size > 150 * block
    pool = pa.default_memory_pool()
    held = []
    put = csv_file._put

    def spy(cols, name, col):
        held.append(pool.bytes_allocated())
        put(cols, name, col)

    monkeypatch.setattr(csv_file, "_put", spy)
    meas = csv_file.stream_csv(path)
    assert meas is not None and len(meas) == 75_000
    # the reader's input thread queues up to about 32 blocks ahead, whatever the file's size
    assert max(held) <= 48 * block < size / 3


def test_a_range_difference_file_streams_without_importing_pandas(tmp_path):
    # pandas (39 MB of a process's memory, whatever the file's size) came with the empty
    # cells of time_ref through pyarrow's to_numpy
    path = write_rows(tmp_path / "rd.csv", range_difference_rows(40))
    path.write_text(path.read_text().replace(HEADER, RD_HEADER, 1))
    code = ("import sys; from pathlib import Path; from tmakit.io import csv_file; "
            f"m = csv_file.stream_csv(Path({str(path)!r})); "
            "print(m is not None, int(m.kind_code.size), 'pandas' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["True", str(len(read_measurements(path))), "False"]
