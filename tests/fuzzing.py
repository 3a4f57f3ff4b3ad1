"""Hostile inputs for the ``tma`` command, shared by tests/test_fuzz.py and benchmarks/.

Three families, each a hypothesis strategy giving a case to run in-process (CliRunner):
measurement files (cells, headers, metadata, encodings, sizes), TOML scenarios and option
strings.  :func:`run_case` runs one and classifies the outcome; :data:`GOOD` lists the
acceptable outcomes (exit 0 with a valid result, exit 4 with an honest status, exit 2 with an
``error:`` naming the field); anything else is a failure of tmakit.
"""

from __future__ import annotations

import hashlib
import re
import time
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st
from typer.testing import CliRunner

from tmakit.cli import app

runner = CliRunner()

HEADER = "time,sensor,kind,value,sigma,sensor_x,sensor_y,sensor_z,sensor_vx,sensor_vy,sensor_vz"
TRUTH = '{"vx": -6.0, "vy": -3.0, "x": 4000.0, "y": 9000.0}'
GOOD = ("ok", "honest status", "clear error")
HONEST = ("unobservable", "diverged", "did not converge", "not converged", "NOT fully")


def base_rows(n: int = 30) -> list[str]:
    """Valid bearings of a CV target from a sensor moving on a zig-zag (deg, m, m/s)."""
    import numpy as np

    rows = []
    for k in range(n):
        t = 10.0 * k
        sx, sy = 5.0 * t, 800.0 * ((k // 6) % 2)
        tx, ty = 4000.0 - 6.0 * t, 9000.0 - 3.0 * t
        b = np.degrees(np.arctan2(tx - sx, ty - sy)) % 360
        rows.append(f"{t:g},ship,bearing,{b:.6f},1,{sx:g},{sy:g},0,5,0,0")
    return rows


def base_file(metadata: dict[str, str] | None = None, rows: list[str] | None = None) -> str:
    meta = {"motion": "cv2d", "truth": TRUTH, "ref_time": "0.0"} if metadata is None else metadata
    lines = [f"# {k}: {v}" for k, v in meta.items()]
    return "\n".join([*lines, HEADER, *(base_rows() if rows is None else rows)]) + "\n"


# -- measurement files ----------------------------------------------------------------------

CELLS = st.one_of(
    st.sampled_from(["", " ", "nan", "NaN", "inf", "-inf", "1e400", "-1e400", "1e308", "0",
                     "-0", "-1", "1e-320", "360", "720", "-90", "abc", "1,2", '"', "'",
                     "0x10", "1_000", "١٢", "∞", "\t5", "5 ", "True", "None", "[]", "{}",
                     "2026-01-01", "1.7e9", "99999999999999999999"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=8),
)
META_KEYS = st.sampled_from(["truth", "ref_time", "origin_lat", "origin_lon", "origin_alt",
                             "motion", "seed", "nuisance", "scenario", "weird key"])
META_VALUES = st.one_of(
    st.sampled_from(["{bad json", "yesterday", "1000", "nan", "inf", "-4", "[1, 2]",
                     '{"x": "a"}', '{"x": NaN}', "cv2d", "curvilinear:1000", "warp9", "",
                     TRUTH, '{"x": 1e400}', "0", "1.7e9"]),
    st.text(max_size=12).filter(lambda s: "\n" not in s and "\r" not in s),
)


def _header_case(draw: st.DrawFn, rows: list[str]) -> tuple[str, bytes]:
    names = HEADER.split(",")
    op = draw(st.sampled_from(["drop", "duplicate", "rename", "extra", "blank", "many"]))
    j = draw(st.integers(0, len(names) - 1))
    if op == "drop":
        names.pop(j)
    elif op == "duplicate":
        names.append(names[j])
    elif op == "rename":
        names[j] = draw(st.text(max_size=6))
    elif op == "extra":
        names.append("comment")
    elif op == "blank":
        names[j] = ""
    else:  # many columns: linear, not quadratic, in the header
        names += [f"c{k}" for k in range(draw(st.integers(1, 5000)))]
    head = ",".join(n.replace(",", ";").replace("\n", " ") for n in names)
    text = "\n".join([f"# truth: {TRUTH}", "# motion: cv2d", head, *rows]) + "\n"
    return f"header {op}", text.encode("utf-8", "replace")


@st.composite
def measurement_files(draw: st.DrawFn) -> tuple[str, bytes]:
    """Return ``(what was changed, file bytes)``: one mutation family per case."""
    family = draw(st.sampled_from(["cell", "header", "metadata", "encoding", "size",
                                   "rows"]))
    rows = base_rows()
    if family == "cell":
        i = draw(st.integers(0, len(rows) - 1))
        cells = rows[i].split(",")
        j = draw(st.integers(0, len(cells) - 1))
        cells[j] = draw(CELLS)
        rows[i] = ",".join(cells)
        return f"cell {HEADER.split(',')[j]}", base_file(rows=rows).encode("utf-8", "replace")
    if family == "header":
        return _header_case(draw, rows)
    if family == "metadata":
        meta = {"motion": "cv2d", "truth": TRUTH}
        meta[draw(META_KEYS)] = draw(META_VALUES)
        return "metadata", base_file(meta).encode("utf-8", "replace")
    if family == "encoding":
        enc = draw(st.sampled_from(["utf-16", "latin-1", "utf-8-sig", "binary", "nul",
                                    "cp1252"]))
        text = base_file().replace("ship", "shïp")
        if enc == "binary":
            return "encoding binary", bytes(draw(st.binary(min_size=1, max_size=200)))
        if enc == "nul":
            return "encoding nul", text.encode() + b"\x00\x00"
        return f"encoding {enc}", text.encode(enc)
    if family == "size":
        n = draw(st.sampled_from([0, 1, 2, 3]))
        return f"size {n} rows", base_file(rows=rows[:n]).encode()
    # rows: reordered, duplicated, ragged
    op = draw(st.sampled_from(["reverse", "duplicate", "ragged", "blank lines", "crlf"]))
    if op == "reverse":
        rows = rows[::-1]
    elif op == "duplicate":
        rows = rows + rows[:3]
    elif op == "ragged":
        rows[draw(st.integers(0, len(rows) - 1))] += ",extra"
    elif op == "blank lines":
        rows = [r + "\n" for r in rows]
    else:
        return "rows crlf", base_file().replace("\n", "\r\n").encode()
    return f"rows {op}", base_file(rows=rows).encode()


# -- TOML scenarios -------------------------------------------------------------------------

SCENARIO = """name = "fuzz"
{origin}
[target]
motion = "cv2d"
truth = {{ x = {x}, y = 9000.0, vx = -6.0, vy = -3.0 }}

[[sensors]]
id = "ship"
type = "legs"
start = [0.0, 0.0]
heading_deg = {heading}
speed = {speed}
legs = [{{ duration = 300.0 }}, {{ duration = inf, turn_rate_deg_s = 0.0 }}]

[[measurements]]
kind = "bearing"
sensor = "ship"
times = {{ start = {start}, stop = {stop}, step = {step} }}
sigma = {sigma}
"""
TOML_VALUES = st.sampled_from(["nan", "inf", "-inf", "-1.0", "0.0", "1e300", "1e-300",
                               '"text"', "[1.0]", "true", "1000.0", "1.0"])


@st.composite
def toml_scenarios(draw: st.DrawFn) -> tuple[str, bytes]:
    """Return ``(field changed, TOML bytes)``: one field of a valid scenario made hostile."""
    fields = {"origin": "", "x": "4000.0", "heading": "90.0", "speed": "5.0",
              "start": "0.0", "stop": "600.0", "step": "10.0", "sigma": "1.0"}
    field = draw(st.sampled_from([*fields, "binary", "syntax"]))
    if field == "binary":
        return "binary", draw(st.binary(min_size=1, max_size=100))
    if field == "syntax":
        return "syntax", SCENARIO.format(**fields)[: draw(st.integers(0, 300))].encode()
    if field == "origin":
        lat = draw(st.sampled_from(["1000.0", "-91.0", "nan", "45.0"]))
        fields["origin"] = f"origin = [{lat}, 0.0, 0.0]"
    elif field == "stop":
        fields["stop"] = draw(st.sampled_from(["1e8", "-5.0", "nan", "inf", "10.0"]))
    else:
        fields[field] = draw(TOML_VALUES)
    return field, SCENARIO.format(**fields).encode()


# -- latitude/longitude files with range differences ---------------------------------------

ORIGIN = (48.137, 11.575, 520.0)
GEO_HEADER = ("time,sensor,kind,value,sigma,sensor_lat,sensor_lon,sensor_alt,sensor_vx,"
              "sensor_vy,sensor_vz,time_ref")


def latlon_rows(n: int = 20) -> list[str]:
    """A UAV 300 m up flying East at 40 m/s: bearings, and range differences against the
    previous second (a row's own time) and the previous half second (interpolated)."""
    import numpy as np
    import pymap3d

    def r(t: float) -> float:
        return float(np.sqrt((3000.0 - 40.0 * t) ** 2 + 4000.0**2 + 300.0**2))

    rows = []
    for k in range(n):
        t = float(k)
        lat, lon, h = pymap3d.enu2geodetic(40.0 * t, 0.0, 300.0, *ORIGIN)
        where = f"{lat:.9f},{lon:.9f},{h:.3f},40,0,0"
        b = np.degrees(np.arctan2(3000.0 - 40.0 * t, 4000.0)) % 360
        rows.append(f"{t:g},uav,bearing,{b:.6f},1,{where},")
        if k:
            rows.append(f"{t:g},uav,range_difference,{r(t) - r(t - 1):.4f},0.7,{where},{t - 1:g}")
            rows.append(f"{t:g},uav,range_difference,{r(t) - r(t - 0.5):.4f},0.7,{where},"
                        f"{t - 0.5:g}")
    return rows


@st.composite
def latlon_range_difference_files(draw: st.DrawFn) -> tuple[str, bytes]:
    """Return ``(what was changed, file bytes)`` of a lat/lon file with range differences."""
    rows = latlon_rows()
    meta = {"origin_lat": ORIGIN[0], "origin_lon": ORIGIN[1], "origin_alt": ORIGIN[2],
            "dim": "3"}
    head = GEO_HEADER
    op = draw(st.sampled_from(["none", "time_ref", "ref on bearing", "no origin", "ghost sensor",
                               "one chain", "no velocity", "enu and geo", "crlf bom"]))
    i = draw(st.integers(0, len(rows) - 1))
    if op == "time_ref":
        i = next(k for k in range(i, len(rows) + i) if "range_diff" in rows[k % len(rows)])
        cells = rows[i % len(rows)].split(",")
        cells[-1] = draw(st.one_of(CELLS, st.sampled_from(["-5", cells[0], "1e300", "19.5"])))
        rows[i % len(rows)] = ",".join(cells)
    elif op == "ref on bearing":
        rows[0] = rows[0] + "0"
    elif op == "no origin":
        meta = {"dim": "3"}
    elif op == "ghost sensor":  # a range difference of a sensor with no row at time_ref
        rows.append(rows[2].replace("uav,", "ghost,"))
    elif op == "one chain":  # every range difference against the first sample
        rows = [r.rsplit(",", 1)[0] + ",0" if "range_diff" in r else r for r in rows]
    elif op == "no velocity":
        head = head.replace("sensor_vx,sensor_vy,sensor_vz,", "")
        rows = [",".join(r.split(",")[:8] + r.split(",")[11:]) for r in rows]
    elif op == "enu and geo":
        head += ",sensor_x"
        rows = [r + ",0" for r in rows]
    lines = [*(f"# {k}: {v}" for k, v in meta.items()), head, *rows]
    text = "\n".join(lines) + "\n"
    if op == "crlf bom":
        return op, b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode()
    return f"latlon {op}", text.encode("utf-8", "replace")


# -- planning tables ------------------------------------------------------------------------

def plan_table() -> str:
    """The built-in ``plan-bearings-only`` scenario file's text."""
    from importlib.resources import files

    return (files("tmakit.scenario") / "builtin" / "plan-bearings-only.toml").read_text()


PLAN_EDITS = {
    "limits": [("min_speed = 8.0", v) for v in ("min_speed = 20.0", "min_speed = -1.0",
                                                 "min_speed = nan")]
    + [("max_turn_rate_deg_s = 9.0", v) for v in ("max_turn_rate_deg_s = 0.0",
                                                   "max_turn_rate_deg_s = -9.0",
                                                   "max_turn_rate_deg_s = inf")],
    "horizon": [("horizon = 1", f"horizon = {v}") for v in ("0", "2", "4", "50", "1.5", '"2"')],
    "interval": [("interval = 10.0 ", f"interval = {v} ") for v in ("0.0", "-10.0", "7.0",
                                                                    "1e300")],
    "duration": [("duration = 600.0", f"duration = {v}") for v in ("0.0", "615.0", "1e12")],
    "actions": [("heading_changes_deg = [-90.0, -45.0, 0.0, 45.0, 90.0]",
                 f"heading_changes_deg = {v}") for v in ("[]", "[0.0]", "[1e9]",
                                                         "[-90.0, nan]")],
    "particles": [("particles = 2000", f"particles = {v}") for v in ("0", "1", "3", "1e9")],
    "weights": [('criterion = "trace"', f'criterion = "trace"\nweights = {v}')
                for v in ("[0.0, 0.0, 0.0, 0.0]", "[1.0, -1.0, 0.0, 0.0]", "[1.0]")],
    "constraint": [("hard = true", "hard = true\n" + v) for v in (
        '[[planning.constraints]]\ntype = "max_range"\ndistance = 500.0',
        '[[planning.constraints]]\ntype = "keep_out"\npolygons = [[]]',
        '[[planning.constraints]]\ntype = "keep_out"\npolygons = [[[-500.0, -500.0], '
        '[500.0, -500.0], [500.0, 500.0], [-500.0, 500.0]]]',
        '[[planning.constraints]]\ntype = "operating_area"\npolygon = [[0.0, 0.0], '
        '[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]',
        '[[planning.constraints]]\ntype = "operating_area"\npolygon = [[5000.0, 5000.0], '
        '[6000.0, 5000.0], [6000.0, 6000.0]]')],
    "sensor": [('sensor = "observer"          #', 'sensor = "nobody" #')],
    "measurements": [('kind = "bearing"\nsigma = 1.0                  # deg',
                      f'kind = "{k}"\nsigma = {v}') for k, v in (
        ("frequency", "1.0"), ("range", "0.0"), ("bearng", "1.0"), ("range_difference", "1.0"))],
}


@st.composite
def plan_scenarios(draw: st.DrawFn) -> tuple[str, bytes]:
    """Return ``(field changed, TOML bytes)``: ``plan-bearings-only`` with one odd value."""
    field = draw(st.sampled_from(sorted(PLAN_EDITS)))
    old, new = draw(st.sampled_from(PLAN_EDITS[field]))
    text = plan_table()
    assert old in text, old
    return f"{field}: {new.splitlines()[-1]}", text.replace(old, new, 1).encode()


# -- option strings -------------------------------------------------------------------------

OPTION_TEXT = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "x=nan", "x=inf,y=1", "x=4000,x=5", "x=", "=5",
                     "x=1,,y=2", "1e400", "-1", "0", "abc", "", "x=4000,y=9000,vx=-6,vy=-3",
                     "1,2", "1,2,3", "95,0,0", "1e9", "1.7e9", "-0.5"]),
    st.text(max_size=10).filter(lambda s: not s.startswith("-")),
)
OPTIONS = {
    "crlb": ["--truth", "--ref-time", "--motion"],
    "estimate": ["--init", "--ref-time", "--motion", "--origin"],
    "track": ["--q", "--prior-time", "--rows", "--ellipses", "--filter", "--particles"],
    "show": ["--origin"],
}


@st.composite
def option_cases(draw: st.DrawFn) -> tuple[str, list[str]]:
    """Return ``(option, arguments after FILE)`` for a command run on the valid file."""
    command = draw(st.sampled_from(sorted(OPTIONS)))
    option = draw(st.sampled_from(OPTIONS[command]))
    value = draw(OPTION_TEXT)
    extra = ["--motion", "cv2d"] if command in ("crlb", "estimate") and option != "--motion" \
        else ["--filter", "pf", "--seed", "1"] if option == "--particles" else []
    if option == "--particles":
        value = draw(st.one_of(OPTION_TEXT, st.sampled_from(["2", "3", "6", "7", "50"])))
    return f"{command} {option}", [command, "{file}", option, value, *extra]


# -- running a case -------------------------------------------------------------------------

@dataclass
class Outcome:
    kind: str  # ok | honest status | clear error | unclear error | traceback | changed
    # file | nonsense
    exit_code: int
    seconds: float
    output: str


def _snapshot(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in folder.iterdir() if p.is_file()}


def run_case(args: list[str], folder: Path, may_write: tuple[str, ...] = ()) -> Outcome:
    """Run ``tma *args`` in-process; classify the outcome.

    Files in ``folder`` other than ``may_write`` must not change, and no file may appear
    there but ``may_write``.
    """
    before = _snapshot(folder)
    start = time.process_time()  # CPU, not the wall clock: a loaded machine slows no test
    result = runner.invoke(app, args)
    seconds = time.process_time() - start
    out = result.output
    after = _snapshot(folder)
    changed = [n for n in set(before) | set(after)
               if before.get(n) != after.get(n) and n not in may_write]
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        kind = "traceback"
    elif "Traceback" in out or "please report" in out:
        kind = "traceback"
    elif changed:
        kind = "changed file"
    elif result.exit_code == 0 and re.search(r"(?<![\w.])-?(nan|inf)(?![\w])", out, re.I):
        kind = "nonsense"  # exit 0 with NaN or infinite numbers in the result
    elif result.exit_code == 0:
        kind = "ok"
    elif result.exit_code == 4 and any(w in out for w in HONEST):
        kind = "honest status"
    elif (result.exit_code == 2 and out.startswith("error:")) or (
            result.exit_code == 2 and "Usage:" in out and "Invalid value" in out):
        kind = "clear error"
    else:
        kind = "unclear error"
    return Outcome(kind, result.exit_code, seconds, out)
