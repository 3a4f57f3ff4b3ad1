"""Hostile inputs through every door: ``tma`` and the Python API, each must refuse or warn.

Issue 26's figure: "the hostile-input cases: 0 accepted nonsense, 0 tracebacks, 0 inputs
overwritten".  Each case makes its files in a folder of its own (from the sample logs that
``tma examples`` writes, or a simulated measurement file), then either runs ``tma`` in a
child process (as a user would) or calls the Python API, and is classified:

* **refused**: exit 2 with a line starting ``error:`` (Python: ``ValueError``, ``TypeError``,
  ``FileNotFoundError`` or :class:`tmakit.io.MeasurementFileError` with a message), no output
  file written;
* **warned**: the case expects an answer with a warning (``warning:`` printed);
* **accepted nonsense**: exit 0 (or an answer) where a refusal or a warning was due, or an
  output written by a refused command;
* **traceback**: a Python traceback or an internal error (exit 3), or another exception;
* **input overwritten**: a file that existed before the command changed;
* **hang**: no end within the case's time limit;
* **unclear refusal**: refused, but without the words the case expects (a library's own
  message, naming no row, column or option).

The cases are issue 26's hostile-input run as far as the issue names them (importers: REP,
DSF, wide CSV/Parquet, GPX, NMEA; epoch units; duplicates; overwriting an input), completed
to 45 cases in the same spirit, and the older ones it lists (``tma show`` of a time of
1e300 or a sigma of 1e-300, a target at x = 1e300, times 1e-12 s apart, ``--q 1e300``,
``--at 1e12``, a file of NUL bytes, a FIFO, two Monte Carlo studies into one file); then 21
more (priors, model options and times beyond what they can mean, headers in another case, a
blank sensor id), each refusal checked for the words that name its file, row or option.

Run::

    python benchmarks/hostile_inputs.py             # every case (about 2 minutes)
    python benchmarks/hostile_inputs.py --fast      # the cases the issue names (the tests')
    python benchmarks/hostile_inputs.py --nul-gb 2  # the NUL-byte file at 2 GB (as the issue)
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

#: Seconds a case may take before it counts as a hang.
LIMIT_S = 60.0
OUTCOMES = ("refused", "warned", "accepted nonsense", "traceback", "input overwritten", "hang",
            "unclear refusal")


@dataclass
class Case:
    """One hostile input: how to make it, what to run, what is due."""

    name: str
    make: Callable[[Path], list[str] | Callable[[], object]]
    due: str = "refused"  # or "warned"
    fast: bool = False  # named in issue 26: run by the tests
    outputs: tuple[str, ...] = ("out.csv", "out.parquet", "out.png", "runs.csv")
    words: tuple[str, ...] = field(default_factory=tuple)  # expected in the message (either)


# -- files -----------------------------------------------------------------------------------

def example(folder: Path, name: str) -> Path:
    """Copy a sample log shipped with tmakit into ``folder``."""
    path = folder / name
    path.write_bytes((resources.files("tmakit") / "examples" / name).read_bytes())
    return path


def examples(folder: Path) -> None:
    for name in ("contact.rep", "drone.csv", "drone.toml", "own.gpx", "own.nmea",
                 "bearings.csv", "bearings.toml"):
        example(folder, name)


@functools.cache
def _simulated_text() -> str:
    import tmakit as tk

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "obs.csv"
        tk.write_measurements(tk.load_scenario("bearings-only-2d").simulate(rng=1), path)
        return path.read_text()


def simulated(folder: Path, name: str = "obs.csv") -> Path:
    """A valid measurement file (bearings-only-2d, seed 1)."""
    path = folder / name
    path.write_text(_simulated_text())
    return path


def edit_cell(path: Path, row: int, column: str, value: str) -> Path:
    """Set one cell of a tmakit CSV measurement file (row counted from 0 after the header)."""
    lines = path.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("time,"))
    names = lines[head].split(",")
    cells = lines[head + 1 + row].split(",")
    cells[names.index(column)] = value
    lines[head + 1 + row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


def edit_line(path: Path, number: int, old: str, new: str) -> Path:
    """Replace text in one line (1-based) of a text file."""
    lines = path.read_text().splitlines()
    assert old in lines[number - 1], (path, number, old)
    lines[number - 1] = lines[number - 1].replace(old, new, 1)
    path.write_text("\n".join(lines) + "\n")
    return path


def edit_csv(path: Path, row: int, column: str, value: str) -> Path:
    """Set one cell of a plain CSV log (row counted from 0 after the header)."""
    lines = path.read_text().splitlines()
    names = lines[0].split(",")
    cells = lines[1 + row].split(",")
    cells[names.index(column)] = value
    lines[1 + row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


def nmea_field(path: Path, sentence: str, index: int, value: str) -> Path:
    """Set a field of the first ``sentence`` (``GPGGA``) of an NMEA log, checksum remade."""
    lines = path.read_text().splitlines()
    for k, line in enumerate(lines):
        if line.startswith("$" + sentence):
            body = line[1:line.index("*")].split(",")
            body[index] = value
            text = ",".join(body)
            check = functools.reduce(lambda a, c: a ^ ord(c), text, 0)
            lines[k] = f"${text}*{check:02X}"
            break
    path.write_text("\n".join(lines) + "\n")
    return path


def import_wide(folder: Path, log: str = "drone.csv", mapping: str = "drone.toml") -> list[str]:
    return ["import", "wide", str(folder / log), "--mapping", str(folder / mapping), "-o",
            str(folder / "out.csv")]


def import_gpx(folder: Path, track: str = "own.gpx", log: str = "bearings.csv",
               mapping: str = "bearings.toml", fmt: str = "gpx") -> list[str]:
    return ["import", fmt, str(folder / track), str(folder / log), "--mapping",
            str(folder / mapping), "-o", str(folder / "out.csv")]


def import_rep(folder: Path, name: str = "contact.rep") -> list[str]:
    return ["import", "rep", str(folder / name), "-o", str(folder / "out.csv")]


def rep_bearing(value: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        examples(folder)
        edit_line(folder / "contact.rep", 4, " 21.52 NULL", f" {value} NULL")
        return import_rep(folder)
    return make


def rep_range(value: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        examples(folder)
        edit_line(folder / "contact.rep", 4, " 21.52 NULL", f" 21.52 {value}")
        return import_rep(folder)
    return make


def drone_cell(column: str, value: str, row: int = 3) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        examples(folder)
        edit_csv(folder / "drone.csv", row, column, value)
        return import_wide(folder)
    return make


def bearings_cell(column: str, value: str, row: int = 3,
                  unit: str | None = None) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        examples(folder)
        edit_csv(folder / "bearings.csv", row, column, value)
        if unit is not None:
            toml = folder / "bearings.toml"
            toml.write_text(toml.read_text().replace('time = "epoch_s"',
                                                     f'time = "epoch_s"\ntime_unit = "{unit}"'))
        return import_gpx(folder)
    return make


def bearings_times(scale: int, unit: str | None = None) -> Callable[[Path], list[str]]:
    """Epoch seconds rewritten as integers in another unit (x ``scale``)."""
    def make(folder: Path) -> list[str]:
        examples(folder)
        path = folder / "bearings.csv"
        lines = path.read_text().splitlines()
        lines[1:] = [f"{round(float(t) * scale)},{b}" for t, b in
                     (line.split(",") for line in lines[1:])]
        path.write_text("\n".join(lines) + "\n")
        if unit is not None:
            toml = folder / "bearings.toml"
            toml.write_text(toml.read_text().replace('time = "epoch_s"',
                                                     f'time = "epoch_s"\ntime_unit = "{unit}"'))
        return import_gpx(folder)
    return make


def measurement_cell(column: str, value: str, row: int = 5,
                     command: str = "show") -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        edit_cell(simulated(folder), row, column, value)
        return [command, str(folder / "obs.csv")]
    return make


def gpx_point(attribute: str, value: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        examples(folder)
        path = folder / "own.gpx"
        text = path.read_text()
        if attribute == "ele":
            start = text.index("<ele>") + 5
            text = text[:start] + value + text[text.index("</ele>", start):]
        else:
            start = text.index(f'{attribute}="') + len(attribute) + 2
            text = text[:start] + value + text[text.index('"', start):]
        path.write_text(text)
        return import_gpx(folder)
    return make


# -- Python cases -----------------------------------------------------------------------------

def py_set(time: object = None, sigma: float = 1.0, value: float = 10.0,
           duplicate: bool = False) -> Callable[[Path], Callable[[], object]]:
    def make(folder: Path) -> Callable[[], object]:
        import tmakit as tk

        t = np.arange(10.0)
        if time is not None:
            t[-1] = float(time)  # type: ignore[arg-type]
        if duplicate:
            t[5] = t[4]
        values = np.full(10, value)
        return lambda: tk.MeasurementSet(t, ["s"] * 10, ["bearing"] * 10, values,
                                         np.full(10, sigma), np.zeros((10, 6)))
    return make


def py_answer(time: float) -> Callable[[Path], Callable[[], object]]:
    def make(folder: Path) -> Callable[[], object]:
        import tmakit as tk

        meas = tk.read_measurements(simulated(folder))
        result = tk.estimate(meas, "cv2d")
        return lambda: result.answer(meas, time=time)
    return make


def py_read(make_files: Callable[[Path], list[str]], **options: object
            ) -> Callable[[Path], Callable[[], object]]:
    """A ``tma import`` case read with ``tk.read_measurements`` instead."""
    def make(folder: Path) -> Callable[[], object]:
        import tmakit as tk

        args = make_files(folder)
        fmt, files = args[1], [a for a in args[2:] if not a.startswith("-")]
        mapping = args[args.index("--mapping") + 1] if "--mapping" in args else None
        if fmt in ("gpx", "nmea"):
            return lambda: tk.read_measurements(files[0], measurements=files[1],
                                                mapping=mapping, **options)
        return lambda: tk.read_measurements(files[0], format=fmt if fmt == "wide" else None,
                                            mapping=mapping, **options)
    return make


# -- the older cases --------------------------------------------------------------------------

def simulate_far_target(folder: Path) -> list[str]:
    scenario = (resources.files("tmakit.scenario") / "builtin"
                / "bearings-only-2d.toml").read_text()
    (folder / "far.toml").write_text(scenario.replace("x = 4000.0", "x = 1e300"))
    return ["simulate", str(folder / "far.toml"), "-o", str(folder / "out.csv")]


def track_of(*options: str) -> Callable[[Path], list[str]]:
    """``tma track`` of the simulated file with ``options`` (``{obs}`` is the file)."""
    def make(folder: Path) -> list[str]:
        obs = str(simulated(folder))
        return ["track", obs, *(o.replace("{obs}", obs) for o in options)]
    return make


def scenario_edit(old: str, new: str) -> Callable[[Path], list[str]]:
    """``tma simulate`` of bearings-only-2d with ``old`` replaced by ``new`` in its file."""
    def make(folder: Path) -> list[str]:
        scenario = (resources.files("tmakit.scenario") / "builtin"
                    / "bearings-only-2d.toml").read_text()
        assert old in scenario, old
        (folder / "edited.toml").write_text(scenario.replace(old, new, 1))
        return ["simulate", str(folder / "edited.toml"), "-o", str(folder / "out.csv")]
    return make


def header_edit(old: str, new: str) -> Callable[[Path], list[str]]:
    """``tma show`` of the simulated file with its header line edited."""
    def make(folder: Path) -> list[str]:
        path = simulated(folder)
        lines = path.read_text().splitlines()
        head = next(i for i, line in enumerate(lines) if line.startswith("time,"))
        lines[head] = lines[head].replace(old, new)
        path.write_text("\n".join(lines) + "\n")
        return ["show", str(path)]
    return make


def blank_sensor_mapping(folder: Path) -> list[str]:
    examples(folder)
    mapping = folder / "drone.toml"
    mapping.write_text(mapping.read_text().replace('sensor = "drone"', 'sensor = ""'))
    return import_wide(folder)


def tiny_times(folder: Path) -> list[str]:
    path = simulated(folder)
    lines = path.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("time,"))
    for k in range(head + 1, len(lines)):
        cells = lines[k].split(",")
        cells[0] = repr((k - head) * 1e-12)
        lines[k] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return ["estimate", str(path)]


def picture_over_input(folder: Path) -> list[str]:
    path = folder / "obs.png"
    path.write_text(_simulated_text())
    return ["estimate", str(path), "--format", "csv", "--plot", str(path), "--force"]


def import_over_log(folder: Path) -> list[str]:
    examples(folder)
    return ["import", "wide", str(folder / "drone.csv"), "--mapping",
            str(folder / "drone.toml"), "-o", str(folder / "drone.csv"), "--force"]


def nul_file(size: int) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        path = folder / "nul.csv"
        with open(path, "wb") as f:
            block = bytes(1 << 20)
            for _ in range(max(size >> 20, 1)):
                f.write(block)
        return ["show", str(path)]
    return make


def fifo(name: str, command: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        path = folder / name
        os.mkfifo(path)
        return [command, str(path)] + (["-o", str(folder / "out.csv")]
                                       if command == "simulate" else [])
    return make


def nul_mapping(folder: Path) -> list[str]:
    examples(folder)
    (folder / "drone.toml").write_bytes(b"\x00" * 4096)
    return import_wide(folder)


def two_montecarlo_runs(folder: Path) -> Callable[[], object]:
    """A long study into runs.csv, and a second one into the same file meanwhile."""
    def run() -> object:
        out = str(folder / "runs.csv")
        first = subprocess.Popen([*tma(), "montecarlo", "gu2007", "--runs", "4000",
                                  "--no-progress", "-o", out], stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True)
        lock = folder / ".runs.csv.tma-lock"
        for _ in range(600):
            if lock.exists() or first.poll() is not None:
                break
            time.sleep(0.05)
        second = subprocess.run([*tma(), "montecarlo", "gu2007", "--runs", "10",
                                 "--no-progress", "-o", out, "--force"],
                                capture_output=True, text=True, timeout=LIMIT_S)
        first_out, _ = first.communicate(timeout=LIMIT_S)
        saved = (folder / "runs.csv").exists() and len(
            (folder / "runs.csv").read_text().splitlines()) > 4000
        if "Traceback" in first_out + second.stdout + second.stderr or 3 in (
                first.returncode, second.returncode):
            raise RuntimeError("a traceback or an internal error")
        if first.returncode == 0 and saved and second.returncode == 2:
            raise ValueError(second.stderr.strip())  # refused, the long run's work saved
        return "both ran" if second.returncode == 0 else "the long run's work was lost"
    return run


# -- the cases --------------------------------------------------------------------------------

CASES = [
    # Debrief replay files (REP, DSF)
    Case("rep bearing 1e300", rep_bearing("1e300"), fast=True),
    Case("rep bearing -1e300", rep_bearing("-1e300")),
    Case("rep bearing 400 deg", rep_bearing("400")),
    Case("rep range 1e300", rep_range("1e300"), fast=True),
    Case("rep range -5 yd", rep_range("-5")),
    Case("rep duplicate time, another bearing",
         lambda f: (examples(f), edit_line(f / "contact.rep", 5, "093010.000", "093005.000"),
                    import_rep(f))[-1], fast=True),
    Case("rep track speed 1e300 kn",
         lambda f: (examples(f), edit_line(f / "contact.rep", 2, "15.55", "1e300"),
                    import_rep(f))[-1]),
    Case("rep latitude 95 deg",
         lambda f: (examples(f), edit_line(f / "contact.rep", 2, "47 57", "95 57"),
                    import_rep(f))[-1]),
    Case("dsf of NUL bytes", lambda f: ((f / "x.dsf").write_bytes(bytes(4096)),
                                        ["import", "dsf", str(f / "x.dsf"), "-o",
                                         str(f / "out.csv")])[-1]),
    # wide CSV / Parquet logs
    Case("wide rssi 1e300 dBm", drone_cell("rssi_dbm", "1e300")),
    Case("wide frequency -1 Hz", drone_cell("freq_hz", "-1")),
    Case("wide frequency inf", drone_cell("freq_hz", "inf")),
    Case("wide latitude 100.5", drone_cell("lat", "100.5")),
    Case("wide longitude 500", drone_cell("lon", "500")),
    Case("wide altitude 1e300", drone_cell("alt_m", "1e300")),
    Case("wide velocity 1e300 m/s", drone_cell("vn", "1e300")),
    Case("wide time 1e300", drone_cell("utc", "1e300"), fast=True),
    Case("wide time in the year 2500", drone_cell("utc", "2500-05-04T09:30:03Z"),
         words=("row 4 (line 5), column 'utc'", "between 1970 and 2200")),
    Case("wide time before 1970", drone_cell("utc", "-5")),
    Case("wide duplicate time, another value",
         drone_cell("utc", "2026-05-04T09:30:02.000Z"), fast=True),
    Case("wide bearing 1e300", bearings_cell("bearing_deg", "1e300"), fast=True),
    Case("wide bearing -1e300", bearings_cell("bearing_deg", "-1e300")),
    Case("wide bearing nan", bearings_cell("bearing_deg", "nan")),
    Case("wide epoch ms read as s", bearings_times(1000), fast=True),
    Case("wide epoch ns read as ms", bearings_times(10**9, "ms")),
    Case("wide epoch us read as ns: 1970", bearings_times(10**6, "ns")),
    Case("wide one time in ms among s", bearings_cell("epoch_s", "1777887030000")),
    Case("wide parquet bearing 1e300",
         lambda f: (examples(f), _parquet_log(f), import_gpx(f, log="b.parquet"))[-1]),
    # GPX and NMEA own tracks
    Case("gpx latitude 100.5", gpx_point("lat", "100.5"), fast=True),
    Case("gpx longitude 400", gpx_point("lon", "400")),
    Case("gpx elevation 1e300", gpx_point("ele", "1e300")),
    Case("nmea altitude 1e300",
         lambda f: (examples(f), nmea_field(f / "own.nmea", "GPGGA", 9, "1e300"),
                    import_gpx(f, track="own.nmea", fmt="nmea"))[-1], fast=True),
    Case("nmea speed 1e300 kn",
         lambda f: (examples(f), nmea_field(f / "own.nmea", "GPVTG", 5, "1e300"),
                    import_gpx(f, track="own.nmea", fmt="nmea"))[-1]),
    Case("nmea heading 1e300",
         lambda f: (examples(f), nmea_field(f / "own.nmea", "HEHDT", 1, "1e300"),
                    import_gpx(f, track="own.nmea", fmt="nmea"))[-1]),
    # outputs over inputs
    Case("estimate --plot over its input, --force", picture_over_input, fast=True),
    Case("import -o over its log, --force", import_over_log),
    Case("mapping of NUL bytes", nul_mapping),
    # the measurement file and the Python doors
    Case("csv range 1e300", lambda f: (edit_cell(simulated(f), 5, "kind", "range"),
                                       edit_cell(f / "obs.csv", 5, "value", "1e300"),
                                       ["show", str(f / "obs.csv")])[-1]),
    Case("csv sensor_x 1e300", measurement_cell("sensor_x", "1e300")),
    Case("csv time 1e9 among 1..600 s", measurement_cell("time", "1e9", row=599)),
    Case("python set with a time of 1e300", py_set(time=1e300)),
    Case("python set with a duplicate time", py_set(duplicate=True)),
    Case("python set with sigma 1e-300", py_set(sigma=1e-300)),
    Case("python read_measurements rep bearing 1e300", py_read(rep_bearing("1e300"))),
    Case("python read_measurements gpx latitude 100.5", py_read(gpx_point("lat", "100.5"))),
    Case("python answer(time=nan)", py_answer(float("nan")), fast=True),
    # the older cases
    Case("show a time of 1e300", measurement_cell("time", "1e300", row=599), fast=True),
    Case("show a sigma of 1e-300", measurement_cell("sigma", "1e-300"), fast=True),
    Case("simulate a target at x = 1e300", simulate_far_target, fast=True),
    Case("estimate times 1e-12 s apart", tiny_times, due="warned",
         words=("warning:", "faster than any craft"), fast=True),
    Case("track --q 1e300", lambda f: ["track", str(simulated(f)), "--q", "1e300"], fast=True),
    Case("estimate --at 1e12", lambda f: ["estimate", str(simulated(f)), "--at", "1e12"],
         fast=True),
    Case("python answer(time=1e12)", py_answer(1e12)),
    Case("show a file of NUL bytes", nul_file(8 << 20), fast=True),
    Case("show a FIFO with no writer", fifo("fifo.csv", "show"), fast=True),
    Case("simulate a FIFO scenario", fifo("fifo.toml", "simulate")),
    Case("two montecarlo studies into one file", two_montecarlo_runs, outputs=()),
    # the eleventh session's cases: priors and model options beyond what they can mean
    Case("track --range-prior 1:1e12", track_of("--range-prior", "1:1e12"),
         words=("--range-prior '1:1e12'", "MAX <= 1e+09")),
    Case("track --range-prior 1e-9:1e9", track_of("--range-prior", "1e-9:1e9"),
         words=("--range-prior '1e-9:1e9'",)),
    Case("track --speed-prior 1e-300", track_of("--speed-prior", "1e-300"),
         words=("--speed-prior 1e-300",)),
    Case("track --height-prior 0:1e300", track_of("--height-prior", "0:1e300"),
         words=("--height-prior '0:1e300'",)),
    Case("track imm --turn-rate-noise 1e300", track_of("--filter", "imm", "--turn-rate-noise",
                                                       "1e300"), words=("--turn-rate-noise",)),
    Case("track imm --model-q 1e300", track_of("--filter", "imm", "--model-q", "1e300"),
         words=("--model-q",)),
    Case("track --prior-time after the data's start", track_of(
        "--prior", "x=5000,y=8000,vx=0,vy=0", "--prior-std", "x=1e4,y=1e4,vx=10,vy=10",
        "--prior-time", "700"), words=("--prior-time 700: after the first measurement",)),
    Case("track --prior x=1e300", track_of(
        "--prior", "x=1e300,y=0,vx=0,vy=0", "--prior-std", "x=1e4,y=1e4,vx=10,vy=10"),
        words=("--prior: expected positions within",)),
    Case("track --follow --interval 1e300", track_of("--follow", "--interval", "1e300"),
         words=("--interval 1e+300",)),
    Case("estimate --init x=1e300", lambda f: ["estimate", str(simulated(f)), "--motion",
                                               "cv2d", "--init", "x=1e300,y=0,vx=0,vy=0"],
         words=("init x=1e+300",)),
    Case("estimate --propagation-speed 1e300", lambda f: [
        "estimate", str(simulated(f)), "--motion", "cv2d", "--propagation-speed", "1e300"],
        words=("--propagation-speed",)),
    Case("estimate --export-every 1e-9", lambda f: [
        "estimate", str(example(f, "contact.rep")), "--motion", "cv2d", "--export",
        str(f / "s.rep"), "--export-every", "1e-9"], outputs=("s.rep",),
        words=("solution points at one every 1e-09 s",)),
    Case("crlb --truth x=1e300", lambda f: ["crlb", str(simulated(f)), "--motion", "cv2d",
                                            "--truth", "x=1e300,y=0,vx=0,vy=0"],
         words=("truth x=1e+300",)),
    Case("crlb --at 1e12", lambda f: ["crlb", str(simulated(f)), "--motion", "cv2d",
                                      "--truth", "x=1,y=2,vx=0,vy=0", "--at", "1e12"],
         words=("--at 1000000000000",)),
    Case("plan --duration 1e300", lambda f: ["plan", "plan-bearings-only", "--duration",
                                             "1e300"], words=("1e+299 decisions",)),
    Case("simulate heading_deg 1e300", scenario_edit("heading_deg = 45.0",
                                                     "heading_deg = 1e300"),
         words=("heading_deg",)),
    Case("simulate a turn of 1e9 deg/s", scenario_edit("turn_rate_deg_s = -9.0",
                                                       "turn_rate_deg_s = -1e9"),
         words=("turn_rate_deg_s",)),
    Case("csv header in upper case", header_edit("time,sensor,kind", "TIME,SENSOR,KIND"),
         words=("rename 'TIME' to 'time'",)),
    Case("csv column Sensor_Z", header_edit("sensor_z,", "Sensor_Z,"),
         words=("rename 'Sensor_Z' to 'sensor_z'",)),
    Case("wide mapping sensor = ''", blank_sensor_mapping, words=("sensor: expected a sensor",)),
    Case("wide time in the year 1500", drone_cell("utc", "1500-05-04T09:30:03Z"),
         words=("row 4 (line 5), column 'utc'",)),
]


def _parquet_log(folder: Path) -> None:
    import pandas as pd

    frame = pd.read_csv(folder / "bearings.csv")
    frame.loc[3, "bearing_deg"] = 1e300
    frame.to_parquet(folder / "b.parquet")


# -- running ----------------------------------------------------------------------------------

@functools.cache
def tma() -> tuple[str, ...]:
    return (sys.executable, "-m", "tmakit.cli")


def _digests(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()
            if p.is_file()}


def run_case(case: Case, folder: Path, in_process: bool = False) -> tuple[str, str]:
    """Run one case in ``folder``; return its outcome (:data:`OUTCOMES`) and what it said.

    ``in_process``: run ``tma`` in this process (typer's test runner: the tests' speed)
    rather than in a child process.
    """
    folder.mkdir(parents=True, exist_ok=True)
    action = case.make(folder)
    before = _digests(folder)
    start = time.perf_counter()
    if callable(action):
        outcome, said = _run_python(action, case)
    elif in_process:
        outcome, said = _classify(*_invoke(action), case)
    else:
        outcome, said = _run_command(action, case)
    if time.perf_counter() - start > LIMIT_S and outcome != "hang":
        outcome = "hang"
    after = _digests(folder)
    if any(after.get(name) != digest for name, digest in before.items()):
        return "input overwritten", said
    if outcome == "refused" and any(n in after and n not in before for n in case.outputs):
        return "accepted nonsense", said + " (and an output was written)"
    return outcome, said


def _run_command(args: list[str], case: Case) -> tuple[str, str]:
    try:
        done = subprocess.run([*tma(), *args], capture_output=True, text=True,
                              timeout=LIMIT_S, stdin=subprocess.DEVNULL,
                              env={**os.environ, "COLUMNS": "200"})
    except subprocess.TimeoutExpired:
        return "hang", f"no end within {LIMIT_S:g} s"
    return _classify(done.returncode, (done.stderr + done.stdout).strip(), case)


def _invoke(args: list[str]) -> tuple[int, str]:
    from typer.testing import CliRunner

    from tmakit.cli import app

    result = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    said = result.output.strip()
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        return 3, f"Traceback: {type(result.exception).__name__}: {result.exception}"
    return result.exit_code, said


def _classify(code: int, said: str, case: Case) -> tuple[str, str]:
    if "Traceback" in said or code == 3:
        return "traceback", said
    if case.due == "warned":
        if code in (0, 1) and all(w in said for w in case.words):
            return "warned", said
        return ("refused" if code == 2 else "accepted nonsense"), said
    if code == 2 and "error:" in said:
        return ("refused" if all(w in said for w in case.words) else "unclear refusal"), said
    return "accepted nonsense", said


def _run_python(action: Callable[[], object], case: Case) -> tuple[str, str]:
    from tmakit.io import MeasurementFileError

    try:
        result = action()
    except (ValueError, TypeError, FileNotFoundError, MeasurementFileError) as e:
        return ("refused" if str(e) else "traceback"), f"{type(e).__name__}: {e}"
    except Exception as e:  # any other exception is a traceback for the user
        return "traceback", f"{type(e).__name__}: {e}"
    return "accepted nonsense", f"returned {str(result)[:200]!r}"


def run_all(cases: list[Case], root: Path, verbose: bool = True,
            in_process: bool = False) -> Counter[str]:
    """Run ``cases`` in folders under ``root``; print one line each; return the outcomes."""
    counts: Counter[str] = Counter()
    for k, case in enumerate(cases):
        outcome, said = run_case(case, root / f"case{k:02d}", in_process)
        good = outcome == case.due
        counts["ok" if good else outcome] += 1
        if verbose:
            first = said.splitlines()[-1] if said else ""
            print(f"{'ok ' if good else 'BAD'} {case.name:45s} {outcome:18s} {first[:110]}",
                  flush=True)
    return counts


def main() -> None:
    global LIMIT_S
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fast", action="store_true", help="the subset the tests run")
    parser.add_argument("--nul-gb", type=float, default=0.0,
                        help="also show a file of this many GB of NUL bytes")
    parser.add_argument("--limit", type=float, default=LIMIT_S, help="seconds per case")
    args = parser.parse_args()
    LIMIT_S = args.limit
    cases = [c for c in CASES if c.fast or not args.fast]
    if args.nul_gb > 0:
        cases.append(Case(f"show {args.nul_gb:g} GB of NUL bytes",
                          nul_file(int(args.nul_gb * 2**30))))
    with tempfile.TemporaryDirectory() as d:
        start = time.perf_counter()
        counts = run_all(cases, Path(d))
        took = time.perf_counter() - start
        shutil.rmtree(d, ignore_errors=True)
    print(f"\n{len(cases)} cases in {took:.0f} s: "
          f"{counts['ok']} refused or warned as due")
    for outcome in OUTCOMES[2:]:
        print(f"  {outcome}: {counts[outcome]}")
    bad = sum(counts[o] for o in OUTCOMES[2:])
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
