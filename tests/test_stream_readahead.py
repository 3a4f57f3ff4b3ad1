"""The text pyarrow's streaming reader holds is bounded by blocks, not by the file's size."""

from __future__ import annotations

import pyarrow as pa
from test_streaming_and_rules import two_sensor_rows, write_rows

from tmakit.io import csv_stream


def test_the_text_held_while_streaming_is_a_few_dozen_blocks_of_a_large_file(tmp_path,
                                                                             monkeypatch):
    block = 1 << 14
    monkeypatch.setattr(csv_stream, "BLOCK_BYTES", block)
    path = write_rows(tmp_path / "obs.csv", two_sensor_rows(30_000))  # ~4 MB: ~250 blocks
    size = path.stat().st_size
    assert size > 150 * block
    pool = pa.default_memory_pool()
    held = []
    put = csv_stream._put

    def spy(cols, name, col):
        held.append(pool.bytes_allocated())
        put(cols, name, col)

    monkeypatch.setattr(csv_stream, "_put", spy)
    meas = csv_stream.stream_csv(path)
    assert meas is not None and len(meas) == 75_000
    # the reader's input thread queues up to about 32 blocks ahead, whatever the file's size
    assert max(held) <= 48 * block < size / 3
