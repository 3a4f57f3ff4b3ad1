"""``tma track --follow`` (issue 29 item 5): a live watch of a growing file.

The test grows a Debrief file while the watch runs and waits for each update line before
writing more (no clock is asserted: the timeouts only keep a broken run from hanging).
"""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from tmakit.cli import app

HANG = 300  # s: only against a hung run, never asserted


@pytest.fixture(scope="module")
def contact(tmp_path_factory) -> list[str]:
    folder = tmp_path_factory.mktemp("ex")
    assert CliRunner().invoke(app, ["examples", str(folder)]).exit_code == 0
    return (folder / "contact.rep").read_text().splitlines(keepends=True)


class Watch:
    """A ``tma track --follow`` process and its output lines as they come."""

    def __init__(self, *args: str, stdin: bool = False) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tmakit.cli", "track", "--follow", *args],
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True)
        self.lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.seen: list[str] = []

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def rest(self) -> str:
        """What the process printed after the lines already taken (once it has ended)."""
        got = []
        while (line := self.lines.get(timeout=HANG)) is not None:
            got.append(line)
        return "".join(got)

    def next_update(self) -> str:
        while True:
            line = self.lines.get(timeout=HANG)
            assert line is not None, f"ended: {self.proc.stderr.read()}"
            self.seen.append(line)
            if line.startswith("update "):
                return line


def _rows(line: str) -> int:
    return int(line.split(", ")[1].split()[0])


def test_follow_tracks_a_growing_file_and_rewrites_its_outputs(contact, tmp_path):
    grow = tmp_path / "grow.rep"
    page, table = tmp_path / "watch.html", tmp_path / "track.csv"
    grow.write_text("".join(contact[:400]))
    w = Watch(str(grow), "--interval", "0.05", "--max-updates", "3", "--html", str(page),
              "-o", str(table))
    first = w.next_update()
    assert first.startswith("update 1:") and "lat " in first and "course " in first
    rows = [_rows(first)]
    for k, end in ((2, 600), (3, len(contact))):
        with open(grow, "a") as f:
            f.write("".join(contact[400 if k == 2 else 600:end]))
        line = w.next_update()
        assert line.startswith(f"update {k}:")
        rows.append(_rows(line))
    assert w.proc.wait(timeout=HANG) == 0
    assert rows[0] < rows[1] < rows[2]
    # the last update is the whole file's track, as tma track gives it
    whole = tmp_path / "whole.csv"
    r = CliRunner().invoke(app, ["track", str(grow), "-o", str(whole)])
    assert r.exit_code == 0, r.output
    pd.testing.assert_frame_equal(pd.read_csv(table), pd.read_csv(whole))
    assert "tmaSolutionPage" in page.read_text() and page.read_text().rstrip().endswith(
        "</html>")


def test_a_partial_last_line_waits(contact, tmp_path):
    """A line being written (no newline yet) is not read until it is whole."""
    grow = tmp_path / "grow.rep"
    cut = contact[500]
    grow.write_text("".join(contact[:500]) + cut[:20])
    w = Watch(str(grow), "--interval", "0.05")
    first = w.next_update()
    with open(grow, "a") as f:
        f.write(cut[20:] + "".join(contact[501:]))
    # a large append may become visible a page at a time: an update may see part of it
    second = w.next_update()
    while _rows(second) == _rows(first):
        second = w.next_update()
    w.proc.send_signal(signal.SIGTERM)
    assert w.proc.wait(timeout=HANG) == 143
    assert _rows(second) > _rows(first)
    assert "error" not in w.proc.stderr.read()


def test_sigterm_stops_the_watch_keeping_what_was_written(contact, tmp_path):
    grow = tmp_path / "grow.rep"
    page = tmp_path / "watch.html"
    grow.write_text("".join(contact))
    w = Watch(str(grow), "--interval", "0.05", "--html", str(page))
    w.next_update()
    while not w.seen[-1].startswith(f"wrote {page}"):  # the update's outputs are written
        w.seen.append(w.lines.get(timeout=HANG))
    w.proc.send_signal(signal.SIGTERM)
    assert w.proc.wait(timeout=HANG) == 143
    err = w.proc.stderr.read()
    assert "stopped after" in w.rest() and "Traceback" not in err
    assert "terminated" in err
    assert page.read_text().rstrip().endswith("</html>")
    assert not list(Path(tmp_path).glob(".*tmp*"))  # no temporary file left beside it


def test_follow_reads_standard_input(contact, tmp_path):
    w = Watch("-", "--format", "rep", stdin=True)
    w.proc.stdin.write("".join(contact))
    w.proc.stdin.close()
    line = w.next_update()
    assert w.proc.wait(timeout=HANG) == 0
    assert line.startswith("update 1:")
    assert "standard input ended" in w.rest()


def test_follow_refusals(contact, tmp_path):
    runner = CliRunner()
    r = runner.invoke(app, ["track", "--follow", "-"])
    assert r.exit_code == 2 and "--format" in r.output
    r = runner.invoke(app, ["track", "--follow", str(tmp_path / "nothing.rep")])
    assert r.exit_code == 2 and "no such file" in r.output
    grow = tmp_path / "g.rep"
    grow.write_text("".join(contact))
    r = runner.invoke(app, ["track", "--follow", str(grow), "--max-updates", "0"])
    assert r.exit_code == 2 and "--max-updates" in r.output
    # 1e300 s ended in an internal error (time.sleep's OverflowError); 1e-9 s is a busy loop
    for interval in ("1e300", "1e-9"):
        r = runner.invoke(app, ["track", "--follow", str(grow), "--interval", interval])
        assert r.exit_code == 2, r.output
        assert "expected seconds within [0.01, 86400] (a day)" in r.output


def test_follow_a_growing_csv_file(tmp_path):
    """A CSV file written row by row (a recorder's log): the header first, then the rows."""
    full = tmp_path / "obs.csv"
    r = CliRunner().invoke(app, ["simulate", "bearings-only-2d", "--seed", "2", "-o", str(full)])
    assert r.exit_code == 0, r.output
    lines = full.read_text().splitlines(keepends=True)
    head = [x for x in lines if x.startswith("#")]
    body = [x for x in lines if not x.startswith("#")]
    grow = tmp_path / "grow.csv"
    grow.write_text("".join(head + body[:301]))  # the header row and 300 rows
    w = Watch(str(grow), "--interval", "0.05", "--max-updates", "50")
    first = w.next_update()
    with open(grow, "a") as f:
        f.write("".join(body[301:]))
    # the watch may read the append half written: an update then tracks the whole lines so far
    rows = [_rows(first)]
    while rows[-1] < len(body) - 1:
        rows.append(_rows(w.next_update()))
    w.proc.terminate()
    w.proc.wait(timeout=HANG)
    assert rows[0] == 300 and rows == sorted(set(rows)) and rows[-1] == len(body) - 1


def test_a_bad_row_already_written_stops_the_watch_naming_the_users_file(contact, tmp_path):
    """Lines already written cannot change: the watch says so and stops, naming the file given
    (not its snapshot), where waiting for more lines would wait for ever."""
    grow = tmp_path / "grow.rep"
    bad = contact[:300]
    fields = bad[250].split()
    bad[250] = " ".join([*fields[:2], "xx", *fields[3:]]) + "\n"
    grow.write_text("".join(bad))
    w = Watch(str(grow), "--interval", "0.05")
    assert w.proc.wait(timeout=HANG) == 2
    said = w.proc.stderr.read()
    assert f"{grow}:" in said and "line 251" in said and "cannot change" in said
    assert "tma-follow-" not in said and "waiting" not in said


def test_follow_to_ends_the_watch_once_the_data_pass_it(contact, tmp_path):
    """``--from``/``--to`` with ``--follow``: the stretch is tracked as it comes, and the watch
    ends (status 0) at the first update whose data pass ``--to``, its track the stretch's."""
    grow, table = tmp_path / "grow.rep", tmp_path / "track.csv"
    grow.write_text("".join(contact[:400]))  # up to 09:56:30
    w = Watch(str(grow), "--interval", "0.05", "--from", "09:40", "--to", "10:05", "-o",
              str(table))
    first = w.next_update()
    assert first.startswith("update 1:")
    with open(grow, "a") as f:
        f.write("".join(contact[400:]))
    # a large append may become visible a page at a time: more than one update may follow
    assert w.proc.wait(timeout=HANG) == 0
    assert "the data have passed --to: the window is tracked" in w.rest()
    stretch = tmp_path / "stretch.csv"
    r = CliRunner().invoke(app, ["track", str(grow), "--from", "09:40", "--to", "10:05", "-o",
                                 str(stretch)])
    assert r.exit_code == 0, r.output
    pd.testing.assert_frame_equal(pd.read_csv(table), pd.read_csv(stretch))


def test_follow_stops_on_a_bad_window(contact, tmp_path):
    grow = tmp_path / "grow.rep"
    grow.write_text("".join(contact))
    for window, message in ((["--from", "noon"], "--from 'noon': expected seconds"),
                            (["--from", "10:05", "--to", "09:40"], "is after --to 09:40"),
                            (["--from", "08:00", "--to", "09:00"], "no measurement between")):
        w = Watch(str(grow), "--interval", "0.05", *window)
        assert w.proc.wait(timeout=HANG) == 2
        err = w.proc.stderr.read()
        assert message in " ".join(err.split()) and "Traceback" not in err
