"""`tma` refuses what it cannot honour in words that name the option, file or row.

The defects a new user's trials found (tenth session): a reversed Debrief window, a second file
after one ``--export``, sigmas no angle can have."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app

EXAMPLES = Path(tk.__file__).parent / "examples"
REPLAY = [EXAMPLES / "Freq_BlueSensor.rep", EXAMPLES / "Freq_BlueTrack.rep"]
runner = CliRunner()


def run(*args: object):
    result = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in result.output
    return result, " ".join(result.output.split())


@pytest.mark.parametrize("command", [["estimate", "--motion", "cv2d"], ["track"]])
def test_a_reversed_window_of_a_replay_names_both_options_and_says_it_is_empty(command):
    """Was: "1 problem in the measurement file: no cut between 12:00 and 11:00", blaming the
    file for the options' order."""
    result, text = run(command[0], *REPLAY, *command[1:], "--from", "12:00", "--to", "11:00")
    assert result.exit_code == 2
    assert ("error: --from 12:00 is after --to 11:00 (2010-01-12T12:00:00Z > "
            "2010-01-12T11:00:00Z): the window ends before it starts, so it is empty") in text
    assert "problem in the measurement file" not in text


def test_an_empty_window_of_a_replay_names_the_options_not_a_file_problem():
    result, text = run("estimate", *REPLAY, "--motion", "cv2d", "--from", "15:00", "--to", "16:00")
    assert result.exit_code == 2
    assert "error: --from/--to: no cut between 15:00 and 16:00 in" in text
    assert "the window is empty (the cuts span 2010-01-12T12:00:00Z to" in text
    assert "problem in the measurement file" not in text


def test_a_reversed_window_from_python_is_a_value_error_naming_the_window():
    with pytest.raises(ValueError, match="--from 12:00 is after --to 11:00"):
        tk.read_measurements(REPLAY, window=("12:00", "11:00"))
