"""``tma track --follow``: keep tracking as the measurement files grow (a live watch)."""

from __future__ import annotations

import queue
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from .common import fail

__all__ = ["STDIN_SUFFIXES", "GrowingFiles", "follow"]

#: ``--format`` of standard input, and the suffix its snapshot gets.
STDIN_SUFFIXES = {"rep": ".rep", "csv": ".csv", "nmea": ".nmea", "wide": ".csv"}
_BINARY = (".parquet", ".pq")


class _Source:
    """One growing source: a file read from an offset, or standard input by a reader thread."""

    def __init__(self, path: Path, snapshot: Path) -> None:
        self.path, self.snapshot = path, snapshot
        self.offset = 0
        self.tail = b""
        self.ended = False
        self.lines: queue.Queue[bytes | None] | None = None
        if str(path) == "-":
            self.lines = queue.Queue()
            threading.Thread(target=self._read_stdin, args=(sys.stdin.buffer,),
                             daemon=True).start()
        snapshot.write_bytes(b"")

    def _read_stdin(self, stream: BinaryIO) -> None:
        assert self.lines is not None
        for line in iter(stream.readline, b""):
            self.lines.put(line)
        self.lines.put(None)  # end of input

    def new_bytes(self) -> bytes:
        """Give the bytes that arrived since the last look (whole lines and a partial tail)."""
        if self.lines is not None:
            got = []
            while True:
                try:
                    item = self.lines.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    self.ended = True
                    break
                got.append(item)
            return b"".join(got)
        try:
            size = self.path.stat().st_size
        except FileNotFoundError:
            return b""
        if size < self.offset:  # rewritten or rotated: start again
            self.offset, self.tail = 0, b""
            self.snapshot.write_bytes(b"")
        if size == self.offset:
            return b""
        with open(self.path, "rb") as f:
            f.seek(self.offset)
            data = f.read(size - self.offset)
        self.offset += len(data)
        return data

    def poll(self) -> bool:
        """Copy the complete lines that arrived into the snapshot; whether there were any."""
        data = self.tail + self.new_bytes()
        cut = data.rfind(b"\n") + 1
        if self.ended and cut < len(data):  # the last line of an input that ended
            data, cut = data + b"\n", len(data) + 1
        whole, self.tail = data[:cut], data[cut:]
        if not whole:
            return False
        with open(self.snapshot, "ab") as f:
            f.write(whole)
        return True


class GrowingFiles:
    """Snapshots of growing text files (their complete lines), in a folder."""

    def __init__(self, paths: list[Path], fmt: str | None, folder: Path) -> None:
        names: set[str] = set()
        self.sources = []
        for k, path in enumerate(paths):
            if str(path) == "-":
                if fmt not in STDIN_SUFFIXES:
                    raise fail("--follow -: standard input needs --format, one of "
                               + ", ".join(STDIN_SUFFIXES))
                name = f"stdin{STDIN_SUFFIXES[fmt]}"
            else:
                if path.is_dir():
                    raise fail(f"{path}: is a folder, not a measurement file")
                if path.suffix.lower() in _BINARY or fmt == "parquet":
                    raise fail(f"--follow {path}: follows text files (REP/DSF, NMEA, CSV), "
                               "not Parquet")
                name = path.name
            if name in names:
                name = f"{k}-{name}"
            names.add(name)
            self.sources.append(_Source(path, folder / name))

    @property
    def snapshots(self) -> list[Path]:
        """The snapshot files, in the order of the files given."""
        return [s.snapshot for s in self.sources]

    @property
    def ended(self) -> bool:
        """Whether standard input (when read) has ended: nothing more will come."""
        return any(s.ended for s in self.sources if s.lines is not None)

    def poll(self) -> bool:
        """Take in what arrived; whether any snapshot gained complete lines."""
        grew = [s.poll() for s in self.sources]
        return any(grew)


def follow(paths: list[Path], fmt: str | None, update: Callable[[list[Path]], bool],
           interval: float, max_updates: int | None, say: Any) -> None:
    """Run ``update`` on the snapshots each time the files grow, until told to stop."""
    from .guard import Terminated

    if not interval > 0:
        raise fail(f"--interval {interval:g}: expected seconds > 0")
    if max_updates is not None and max_updates < 1:
        raise fail(f"--max-updates {max_updates}: expected 1 or more")
    for p in paths:
        if str(p) != "-" and not p.exists():
            raise fail(f"{p}: no such file (--follow waits for a file to grow, not to appear)")
    updates = 0
    with tempfile.TemporaryDirectory(prefix="tma-follow-") as folder:
        growing = GrowingFiles(paths, fmt, Path(folder))
        try:
            while max_updates is None or updates < max_updates:
                if growing.poll():
                    updates += bool(update(growing.snapshots))
                elif growing.ended:
                    say.print(f"standard input ended: {updates} update(s)", highlight=False)
                    break
                else:
                    time.sleep(interval)
        except (KeyboardInterrupt, Terminated):
            say.print(f"stopped after {updates} complete update(s); the files written are "
                      "kept", highlight=False)
            raise

