"""A command never writes over the file it reads, even with --force."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from tmakit.cli import app

runner = CliRunner()


def _simulated(tmp_path: Path) -> Path:
    path = tmp_path / "obs.csv"
    result = runner.invoke(app, ["simulate", "bearings-only-2d", "-o", str(path)])
    assert result.exit_code == 0, result.output
    return path


def test_track_refuses_to_write_its_output_over_its_input_even_with_force(tmp_path):
    obs = _simulated(tmp_path)
    before = obs.read_bytes()
    for target in (str(obs), str(tmp_path / "." / "obs.csv")):
        result = runner.invoke(app, ["track", str(obs), "-o", target, "--force"])
        assert result.exit_code == 2
        assert "is the input file" in result.output
        assert obs.read_bytes() == before


def test_import_refuses_to_write_over_the_log_it_reads(tmp_path):
    obs = _simulated(tmp_path)
    before = obs.read_bytes()
    result = runner.invoke(app, ["import", "wide", str(obs), "-o", str(obs), "--force"])
    assert result.exit_code == 2
    assert "is the input file" in result.output
    assert obs.read_bytes() == before


def test_another_existing_file_is_still_replaced_with_force(tmp_path):
    obs = _simulated(tmp_path)
    out = tmp_path / "tracked.csv"
    out.write_text("old\n")
    result = runner.invoke(app, ["track", str(obs), "-o", str(out), "--force"])
    assert result.exit_code == 0, result.output
    assert out.read_text() != "old\n"


def test_no_option_writes_over_a_file_named_anywhere_on_the_command_line(tmp_path):
    """`tma estimate obs.png --format csv --plot obs.png --force` replaced its own input."""
    obs = _simulated(tmp_path)
    picture = tmp_path / "obs.png"
    picture.write_bytes(obs.read_bytes())  # a measurement file named like a picture
    before = picture.read_bytes()
    for args in (["estimate", str(picture), "--format", "csv", "--plot", str(picture)],
                 ["show", str(picture), "--format", "csv", "--plot", str(tmp_path / "obs")],
                 ["show", str(picture), "--format", "csv", "--plot", str(picture)]):
        result = runner.invoke(app, [*args, "--force"])
        assert result.exit_code == 2, (args, result.output)
        assert "is the input file" in result.output and "--force or not" in result.output
        assert picture.read_bytes() == before
