"""Output that cannot be written ends ``tma`` with one line and status 1, never a traceback.

A full disk (``/dev/full``), a read-only or failing device: the machine's failure, said as
such, not "internal error (please report)" and not typer's traceback of the help text.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys

import pytest
import typer

from tmakit.cli.guard import EXIT_STATUS, guarded

FULL = "/dev/full"


@pytest.mark.skipif(not os.path.exists(FULL), reason="no /dev/full on this system")
@pytest.mark.parametrize("args", [["--help"], ["scenarios"], ["estimate", "--help"]],
                         ids=["help", "scenarios", "command-help"])
def test_a_full_disk_is_one_line_and_status_1(args):
    with open(FULL, "w") as full:
        done = subprocess.run([sys.executable, "-c", "from tmakit.cli import main; main()",
                               *args], stdout=full, stderr=subprocess.PIPE, text=True,
                              timeout=120)
    assert done.returncode == EXIT_STATUS, done.stderr
    name = " ".join(args[:1])
    assert done.stderr.strip() == (f"error: `tma {name}` could not write its output: "
                                   "No space left on device")


def test_a_command_that_cannot_write_its_file_says_which(capsys):
    def export(path: str = "out.csv") -> None:
        raise OSError(errno.EROFS, "Read-only file system", path)

    with pytest.raises(typer.Exit) as stop:
        guarded(export)(path="/mnt/ro/out.csv")
    assert stop.value.exit_code == EXIT_STATUS
    assert capsys.readouterr().err == ("error: `tma export` could not write /mnt/ro/out.csv: "
                                       "Read-only file system\n")


def test_other_os_errors_are_still_internal_errors(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("TMA_LOG_DIR", str(tmp_path))

    def broken() -> None:
        raise OSError(errno.EBADF, "Bad file descriptor")

    with pytest.raises(typer.Exit) as stop:
        guarded(broken)()
    assert stop.value.exit_code == 3
    assert "internal error" in capsys.readouterr().err
