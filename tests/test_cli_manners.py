"""The command's manners (issue 12, item 8): -h, --version, plain help, words not dicts."""

from __future__ import annotations

import json
import re

import pytest
from typer.testing import CliRunner

import tmakit
from tmakit.cli import app

runner = CliRunner()
COMMANDS = ["scenarios", "simulate", "show", "crlb", "estimate", "reproduce", "montecarlo",
            "track", "plan", "demo"]


def run(*args: str):
    return runner.invoke(app, list(args))


def test_version():
    out = run("--version")
    assert out.exit_code == 0 and out.output.strip() == f"tma (tmakit) {tmakit.__version__}"


@pytest.mark.parametrize("command", [None, *COMMANDS])
def test_short_help_is_the_long_help_and_plain(command):
    args = [command] if command else []
    short, long = run(*args, "-h"), run(*args, "--help")
    assert short.exit_code == 0 and short.output == long.output
    text = short.output
    assert "<bool>" not in text  # flags are --name / --no-name, no placeholder
    assert not re.search(r"[\u2460-\u24ff\U0001F000-\U0001FAFF]", text)  # no emoji markup
    assert "[bold" not in text and "[/" not in text


def test_exact_help_reads_as_written():
    text = run("estimate", "-h").output
    assert "curvilinear with M manoeuvres: fit exactly M" in " ".join(text.split())


def test_show_prints_the_truth_in_words_and_power_sigma_in_db(tmp_path):
    obs = tmp_path / "gu.csv"
    run("simulate", "gu2007", "--seed", "1", "-o", str(obs))
    out = run("show", str(obs)).output
    assert "{" not in out and "}" not in out  # no raw Python or JSON dicts
    assert "x = 3200 m" in out and "vx = -21.65 m/s" in out
    power = next(line for line in out.splitlines() if " power " in line)
    assert "dBm" in power and power.rstrip(" │").endswith("dB")  # value dBm, sigma dB


def test_crlb_at_gives_the_course_in_degrees_true():
    out = run("crlb", "gu2007", "--at", "60").output
    course = next(line for line in out.splitlines() if line.strip().startswith("course"))
    value = float(course.split()[1])
    assert 0 <= value < 360 and course.rstrip().endswith("deg")
    assert value == pytest.approx(240.0, abs=0.01)  # vx -21.65, vy -12.5: 240 deg true
    assert "course_deg" not in out  # the JSON's degree copy is not printed twice


def test_crlb_at_json_adds_the_course_in_degrees_and_keeps_radians():
    import json

    data = json.loads(run("crlb", "gu2007", "--at", "60", "--json").stdout)
    at = data["at"]
    assert at["course_deg"]["value"] == pytest.approx(240.0, abs=0.01)
    assert at["course"]["value"] == pytest.approx(-2.0944, abs=1e-3)  # pinned key, radians
    assert at["course_deg"]["std"] == pytest.approx(
        at["course"]["std"] * 180 / 3.141592653589793)


def test_reproduction_figures_are_printed_as_words_not_python_values():
    from tmakit.cli.studies import plain

    text = plain({"rmse": [1.0, 2.5e-7], "ok": True, "n": 3})
    assert text == "rmse = 1, 2.5e-07; ok = true; n = 3"
    assert "[" not in plain([[1.0, 2.0], [3.0]]) and "{" not in plain({"a": {"b": 1.0}})


@pytest.mark.parametrize("command", [*COMMANDS, "import", "examples"])
def test_help_names_values_not_python_types(command):
    text = run(command, "-h").output
    # typer's type labels (<str>, <float>, <int>, <path>, <list[Path]>) and {file} usage
    assert not re.search(r"<(str|int|float|path|bool|list\[[^]]*\])>", text), text
    assert "{" not in text.split("\n\n")[0]  # the usage line


def test_help_shows_what_each_value_is():
    text = " ".join(run("estimate", "-h").output.split())
    assert "estimate [OPTIONS] FILE... Estimate" in text  # one file, or a Debrief replay's
    for shown in ("--origin LAT,LON,ALT", "--plot FILE", "--units si|nautical", "--at T",
                  "--bearing-sigma DEG"):
        assert shown in text
    assert "--json print JSON" in text  # a flag takes no value
    assert "-o, --output FILE" in " ".join(run("track", "-h").output.split())


def test_montecarlo_table_has_units():
    out = run("montecarlo", "gu2007", "--runs", "2", "--no-progress")
    assert out.exit_code == 0, out.output
    header = next(line for line in out.output.splitlines() if "parameter" in line)
    assert "unit" in header
    vx = next(line for line in out.output.splitlines() if line.strip("│ ").startswith("vx "))
    assert "m/s" in vx


def test_montecarlo_of_a_motion_it_cannot_start_is_an_error_not_a_traceback():
    out = run("montecarlo", "hoerst2010", "--runs", "2", "--no-progress")
    assert out.exit_code == 2 and out.output.startswith("error:") and "hoerst2010" in out.output
    assert "Traceback" not in out.output


def test_curvilinear_estimate_gives_the_course_in_degrees_true(tmp_path):
    obs = tmp_path / "ho.csv"
    assert run("simulate", "hoerst2010", "--seed", "1", "-o", str(obs)).exit_code == 0
    out = run("estimate", str(obs), "--motion", "curvilinear:1").output
    course = next(line.split() for line in out.splitlines() if line.strip().startswith("course"))
    assert course[-1] == "deg"
    # the truth starts East (90 deg); one manoeuvre fewer than the truth bends it a little,
    # a value in radians (1.57) would be far off
    assert float(course[1]) == pytest.approx(90.0, abs=15.0)
    answer = next(line for line in out.splitlines() if "course (true)" in line)
    assert answer.rstrip(" │").endswith("deg") and "rad" not in out


def test_reproduce_parameter_tables_say_their_units():
    """Printed reproduction tables with a parameter column gain a unit column (JSON unchanged)."""
    from tmakit.cli.studies import with_unit_column

    text = runner.invoke(app, ["reproduce", "doppler-lecture"])
    assert text.exit_code == 0, text.output
    rows = {ln.split("│")[1].strip(): ln.split("│")[2].strip()
            for ln in text.output.splitlines() if ln.startswith("│") and ln.count("│") > 6}
    assert rows["x"] == "m" and rows["vz"] == "m/s" and rows["carrier"] == "Hz"
    data = json.loads(runner.invoke(app, ["reproduce", "doppler-lecture", "--json"]).stdout)
    assert "unit" not in data["sections"][1]["header"]
    # A table that has a unit column already, or no parameter column, is left as it is.
    assert with_unit_column(["parameter", "unit"], [["x", "m"]]) == (
        ["parameter", "unit"], [["x", "m"]])
    assert with_unit_column(["case", "n"], [["a", 1]]) == (["case", "n"], [["a", 1]])


def test_crlb_at_follows_units():
    """``tma crlb SCENARIO --at T --units nautical``: speeds in knots, the JSON still in SI."""
    si = runner.invoke(app, ["crlb", "hurtado2008", "--at", "10"])
    kn = runner.invoke(app, ["crlb", "hurtado2008", "--at", "10", "--units", "nautical"])
    assert si.exit_code == 0 and kn.exit_code == 0, kn.output

    def speed(text):
        line = next(ln for ln in text.splitlines() if ln.strip().startswith("speed"))
        return float(line.split()[1]), line.split()[-1]

    (v_si, u_si), (v_kn, u_kn) = speed(si.output), speed(kn.output)
    assert (u_si, u_kn) == ("m/s", "kn")
    assert v_kn == pytest.approx(v_si * 3600 / 1852, rel=1e-5)
    data = json.loads(runner.invoke(app, ["crlb", "hurtado2008", "--at", "10", "--json",
                                          "--units", "nautical"]).stdout)
    assert data["at"]["speed"]["value"] == pytest.approx(v_si, rel=1e-5)


def test_reproduce_list_figures_are_named_with_units():
    """``tma reproduce gu2007``: the Monte Carlo RMSE line names each parameter and its unit."""
    res = runner.invoke(app, ["reproduce", "gu2007", "--runs", "3"])
    assert res.exit_code == 0, res.output
    line = next(ln for ln in res.output.splitlines() if ln.startswith("ml rmse:"))
    assert re.fullmatch(r"ml rmse: x \S+ m, y \S+ m, vx \S+ m/s, vy \S+ m/s", line), line
    data = json.loads(runner.invoke(app, ["reproduce", "gu2007", "--runs", "3",
                                          "--json"]).stdout)
    assert len(data["figures"]["ml_rmse"]) == 4 and "labels" not in data
